// Search spaces built by hand, shared by the tests of the PLANNER's searches (test_plan_search.cpp) and of
// their plugins (test_algorithm_plugins.cpp).
#pragma once

#include <string>
#include <vector>

#include "xpersif/core/planning/plan_search.h"

namespace xpersif::core::testing_spaces {

/// A one-handed robot moves n objects, each from the table to its own place: facts per object i are
/// on_table(i) = 3i, holding(i) = 3i + 1, at(i) = 3i + 2, and handempty = 3n. Goal: every at(i). A shortest
/// plan has 2n steps; breadth-first explores every interleaving, a goal count leads straight on.
inline SearchSpace handSpace(int n) {
  SearchSpace s;
  const int handempty = 3 * n;
  s.initial.assign(3 * n + 1, false);
  s.initial[handempty] = true;
  for (int i = 0; i < n; ++i) {
    s.initial[3 * i] = true;
    s.goal.emplace_back(3 * i + 2, false);
    s.actions.push_back({{3 * i, handempty}, {}, {3 * i + 1}, {3 * i, handempty}});  // pick(i)
    s.actions.push_back({{3 * i + 1}, {}, {3 * i + 2, handempty}, {3 * i + 1}});     // place(i)
    s.actions.push_back({{3 * i + 1}, {}, {3 * i, handempty}, {3 * i + 1}});         // put back(i)
  }
  return s;
}

/// "" when @p plan is applicable step by step and reaches the goal, else what is wrong.
inline std::string check(const SearchSpace& s, const std::vector<std::size_t>& plan) {
  std::vector<bool> state = s.initial;
  for (std::size_t k = 0; k < plan.size(); ++k) {
    if (plan[k] >= s.actions.size()) return "step " + std::to_string(k) + " names no action";
    if (!s.applicable(s.actions[plan[k]], state)) return "step " + std::to_string(k) + " is not applicable";
    state = s.apply(s.actions[plan[k]], state);
  }
  return s.satisfied(state) ? "" : "the goal does not hold at the end";
}

}  // namespace xpersif::core::testing_spaces
