/**
 * @file plan_search.h
 * @brief The PLANNER's search, beneath one interface so that it is chosen by name (`~search_type`), as
 *        move_base chooses its global planner: PlanSearch, and the two searches this package offers,
 *        breadth-first (shortest plans) and greedy best-first on the number of unmet goal literals.
 *
 * A search sees the planning problem after grounding and pruning (core/planner.h does both): facts are
 * numbered, actions are ground operators with positive and negative preconditions and add/delete effects, the
 * goal is a list of (fact, negated) literals. It never sees contracts or strings, so a search written in
 * another package needs nothing but this header (and, to be found by name, a pluginlib export; doc/plugins.md
 * "Plugins").
 *
 * Every search must:
 *  - return actions whose preconditions hold in turn from the initial state and after which the goal holds;
 *  - expand at most max_expansions states (a state is expanded when its successors are generated) and
 *    consider no plan longer than max_depth steps, saying which limit stopped it;
 *  - be deterministic: the same space gives the same plan (actions are offered in a fixed order).
 * No ROS here: the implementations are tested with plain gtest.
 */
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace xpersif::core {

/// One ground operator in the numbered form searches work on. Effects: deletes first, then adds.
struct SearchAction {
  std::vector<int> pre_pos;  ///< facts that must hold
  std::vector<int> pre_neg;  ///< facts that must not hold
  std::vector<int> add;
  std::vector<int> del;
};

/// A grounded planning problem: the state is one bool per fact.
struct SearchSpace {
  std::vector<bool> initial;                ///< size = number of facts
  std::vector<std::pair<int, bool>> goal;   ///< (fact, negated): negated literals must be false at the end
  std::vector<SearchAction> actions;        ///< in the order they are to be tried
  std::size_t max_depth = 16;
  std::size_t max_expansions = 200000;

  bool applicable(const SearchAction& action, const std::vector<bool>& state) const;
  std::vector<bool> apply(const SearchAction& action, const std::vector<bool>& state) const;
  bool satisfied(const std::vector<bool>& state) const;
  /// Goal literals that do not hold in @p state.
  std::size_t unmet(const std::vector<bool>& state) const;
};

struct SearchResult {
  enum class Outcome {
    Found,           ///< plan holds the action indices in order
    DepthLimit,      ///< no plan within max_depth steps (a longer one may exist)
    ExpansionLimit,  ///< max_expansions states expanded without reaching the goal
    Exhausted,       ///< every reachable state seen within max_depth: no plan exists
  };
  Outcome outcome = Outcome::Exhausted;
  std::vector<std::size_t> plan;  ///< indices into SearchSpace::actions
  std::size_t expanded = 0;       ///< states expanded
};

/// The PLANNER's search algorithm (a pluginlib base class: "xpersif::core::PlanSearch").
class PlanSearch {
 public:
  virtual ~PlanSearch() = default;
  /// Search @p space; never throws for a well-formed space (facts in range).
  virtual SearchResult search(const SearchSpace& space) const = 0;
  /// What the search promises, for messages and logs ("shortest plans", ...).
  virtual std::string description() const = 0;
};

/// Breadth-first: the first goal state found ends a shortest plan; explores every state up to its length.
class BreadthFirstSearch : public PlanSearch {
 public:
  SearchResult search(const SearchSpace& space) const override;
  std::string description() const override { return "breadth-first (shortest plans)"; }
};

/// Greedy best-first on the number of unmet goal literals (ties: shallower, then older states): fast when the
/// goal is made of many independent parts; its plans are not always shortest.
class GreedyGoalCountSearch : public PlanSearch {
 public:
  SearchResult search(const SearchSpace& space) const override;
  std::string description() const override { return "greedy best-first on unmet goal literals"; }
};

}  // namespace xpersif::core
