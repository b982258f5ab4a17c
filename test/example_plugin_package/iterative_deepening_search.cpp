/**
 * @file iterative_deepening_search.cpp
 * @brief Another package's plan search for xpersif's PLANNER: iterative-deepening depth-first search. It needs
 *        only xpersif's ROS-free header plan_search.h and a pluginlib export (example_plugins.xml).
 */
#include <pluginlib/class_list_macros.hpp>

#include <set>
#include <vector>

#include "xpersif/core/planning/plan_search.h"

namespace xpersif_example_plugins {

using xpersif::core::SearchResult;
using xpersif::core::SearchSpace;

class IterativeDeepeningSearch : public xpersif::core::PlanSearch {
 public:
  SearchResult search(const SearchSpace& space) const override {
    SearchResult result;
    if (space.satisfied(space.initial)) {
      result.outcome = SearchResult::Outcome::Found;
      return result;
    }
    // Depth limits 1, 2, ...: the first plan found has the fewest steps, as breadth-first's.
    for (std::size_t limit = 1; limit <= space.max_depth; ++limit) {
      std::vector<std::vector<bool>> path{space.initial};  // states on the current path: no cycles
      bool cut = false;
      if (deepen(space, limit, path, result, cut)) {
        result.outcome = SearchResult::Outcome::Found;
        return result;
      }
      if (result.expanded >= space.max_expansions) {
        result.outcome = SearchResult::Outcome::ExpansionLimit;
        return result;
      }
      if (!cut) {  // no branch reached the limit: every reachable state was seen
        result.outcome = SearchResult::Outcome::Exhausted;
        return result;
      }
    }
    result.outcome = SearchResult::Outcome::DepthLimit;
    return result;
  }

  std::string description() const override { return "iterative-deepening depth-first (shortest plans)"; }

 private:
  static bool deepen(const SearchSpace& space, std::size_t limit, std::vector<std::vector<bool>>& path,
                     SearchResult& result, bool& cut) {
    if (path.size() - 1 == limit) {
      cut = true;
      return false;
    }
    if (result.expanded >= space.max_expansions) return false;
    ++result.expanded;
    for (std::size_t i = 0; i < space.actions.size(); ++i) {
      if (!space.applicable(space.actions[i], path.back())) continue;
      std::vector<bool> next = space.apply(space.actions[i], path.back());
      bool on_path = false;
      for (const auto& s : path) on_path = on_path || s == next;
      if (on_path) continue;
      result.plan.push_back(i);
      if (space.satisfied(next)) return true;
      path.push_back(std::move(next));
      if (deepen(space, limit, path, result, cut)) return true;
      path.pop_back();
      result.plan.pop_back();
    }
    return false;
  }
};

}  // namespace xpersif_example_plugins

PLUGINLIB_EXPORT_CLASS(xpersif_example_plugins::IterativeDeepeningSearch, xpersif::core::PlanSearch)
