/**
 * @file plan_search.cpp
 * @brief Breadth-first and greedy best-first search over a grounded STRIPS space; see plan_search.h.
 */
#include "xpersif/core/planning/plan_search.h"

#include <algorithm>
#include <functional>
#include <set>
#include <tuple>
#include <unordered_set>

namespace xpersif::core {

bool SearchSpace::applicable(const SearchAction& action, const std::vector<bool>& state) const {
  return std::all_of(action.pre_pos.begin(), action.pre_pos.end(), [&](int f) { return state[f]; }) &&
         std::all_of(action.pre_neg.begin(), action.pre_neg.end(), [&](int f) { return !state[f]; });
}

std::vector<bool> SearchSpace::apply(const SearchAction& action, const std::vector<bool>& state) const {
  std::vector<bool> next = state;
  for (int f : action.del) next[f] = false;
  for (int f : action.add) next[f] = true;
  return next;
}

bool SearchSpace::satisfied(const std::vector<bool>& state) const { return unmet(state) == 0; }

std::size_t SearchSpace::unmet(const std::vector<bool>& state) const {
  return static_cast<std::size_t>(
      std::count_if(goal.begin(), goal.end(), [&](const auto& lit) { return state[lit.first] == lit.second; }));
}

namespace {

/// Best-first over states with the open list ordered by (priority, depth, creation); a priority of 0 for
/// every state makes it FIFO, i.e. breadth-first. Duplicate states are pruned when generated.
SearchResult bestFirst(const SearchSpace& space, const std::function<std::size_t(const std::vector<bool>&)>& priority) {
  SearchResult result;
  if (space.satisfied(space.initial)) {
    result.outcome = SearchResult::Outcome::Found;
    return result;
  }
  struct Node {
    std::vector<bool> state;
    long parent;
    std::size_t action;
    std::size_t depth;
  };
  std::vector<Node> nodes{{space.initial, -1, 0, 0}};
  std::unordered_set<std::vector<bool>> visited{space.initial};
  std::set<std::tuple<std::size_t, std::size_t, std::size_t>> open{{priority(space.initial), 0, 0}};
  bool depth_cut = false;
  while (!open.empty()) {
    const std::size_t current = std::get<2>(*open.begin());
    open.erase(open.begin());
    if (nodes[current].depth >= space.max_depth) {
      depth_cut = true;
      continue;
    }
    if (result.expanded >= space.max_expansions) {
      result.outcome = SearchResult::Outcome::ExpansionLimit;
      return result;
    }
    ++result.expanded;
    for (std::size_t i = 0; i < space.actions.size(); ++i) {
      const std::vector<bool>& state = nodes[current].state;
      if (!space.applicable(space.actions[i], state)) continue;
      std::vector<bool> next = space.apply(space.actions[i], state);
      if (!visited.insert(next).second) continue;
      const bool done = space.satisfied(next);
      nodes.push_back({std::move(next), static_cast<long>(current), i, nodes[current].depth + 1});
      if (done) {
        for (long k = static_cast<long>(nodes.size()) - 1; k > 0; k = nodes[k].parent) {
          result.plan.push_back(nodes[k].action);
        }
        std::reverse(result.plan.begin(), result.plan.end());
        result.outcome = SearchResult::Outcome::Found;
        return result;
      }
      open.insert({priority(nodes.back().state), nodes.back().depth, nodes.size() - 1});
    }
  }
  result.outcome = depth_cut ? SearchResult::Outcome::DepthLimit : SearchResult::Outcome::Exhausted;
  return result;
}

}  // namespace

SearchResult BreadthFirstSearch::search(const SearchSpace& space) const {
  return bestFirst(space, [](const std::vector<bool>&) { return std::size_t{0}; });
}

SearchResult GreedyGoalCountSearch::search(const SearchSpace& space) const {
  return bestFirst(space, [&space](const std::vector<bool>& state) { return space.unmet(state); });
}

}  // namespace xpersif::core
