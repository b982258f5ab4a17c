// The PLANNER's searches on the PlanSearch interface (plan_search.h), on numbered spaces built by hand.
#include <gtest/gtest.h>

#include <memory>

#include "xpersif/core/plan_search.h"
#include "xpersif/core/planner.h"

using namespace xpersif::core;

namespace {

/// A one-handed robot moves n objects, each from the table to its own place: facts per object i are
/// on_table(i) = 3i, holding(i) = 3i + 1, at(i) = 3i + 2, and handempty = 3n. Goal: every at(i). A shortest
/// plan has 2n steps; breadth-first explores every interleaving, a goal count leads straight on.
SearchSpace handSpace(int n) {
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
std::string check(const SearchSpace& s, const std::vector<std::size_t>& plan) {
  std::vector<bool> state = s.initial;
  for (std::size_t k = 0; k < plan.size(); ++k) {
    if (plan[k] >= s.actions.size()) return "step " + std::to_string(k) + " names no action";
    if (!s.applicable(s.actions[plan[k]], state)) return "step " + std::to_string(k) + " is not applicable";
    state = s.apply(s.actions[plan[k]], state);
  }
  return s.satisfied(state) ? "" : "the goal does not hold at the end";
}

std::vector<std::unique_ptr<PlanSearch>> searches() {
  std::vector<std::unique_ptr<PlanSearch>> all;
  all.push_back(std::make_unique<BreadthFirstSearch>());
  all.push_back(std::make_unique<GreedyGoalCountSearch>());
  return all;
}

}  // namespace

TEST(PlanSearch, EverySearchFindsAValidPlan) {
  const SearchSpace s = handSpace(3);
  for (const auto& search : searches()) {
    const SearchResult r = search->search(s);
    ASSERT_EQ(r.outcome, SearchResult::Outcome::Found) << search->description();
    EXPECT_EQ(check(s, r.plan), "") << search->description();
    EXPECT_EQ(r.plan.size(), 6u) << search->description();
    EXPECT_GT(r.expanded, 0u);
  }
}

TEST(PlanSearch, TheHeuristicExpandsFewerStatesThanBreadthFirst) {
  const SearchSpace s = handSpace(4);
  const SearchResult breadth = BreadthFirstSearch().search(s);
  const SearchResult greedy = GreedyGoalCountSearch().search(s);
  ASSERT_EQ(breadth.outcome, SearchResult::Outcome::Found);
  ASSERT_EQ(greedy.outcome, SearchResult::Outcome::Found);
  EXPECT_EQ(check(s, greedy.plan), "");
  EXPECT_EQ(breadth.plan.size(), 8u);  // shortest
  EXPECT_LT(greedy.expanded * 5, breadth.expanded) << greedy.expanded << " vs " << breadth.expanded;
}

TEST(PlanSearch, SameSpaceSamePlan) {
  const SearchSpace s = handSpace(3);
  for (const auto& search : searches()) {
    const SearchResult a = search->search(s), b = search->search(s);
    EXPECT_EQ(a.plan, b.plan) << search->description();
    EXPECT_EQ(a.expanded, b.expanded) << search->description();
  }
}

TEST(PlanSearch, LimitsAndImpossibleGoalsAreReportedAsSuch) {
  for (const auto& search : searches()) {
    SearchSpace s = handSpace(3);
    s.max_expansions = 2;
    EXPECT_EQ(search->search(s).outcome, SearchResult::Outcome::ExpansionLimit) << search->description();
    EXPECT_LE(search->search(s).expanded, 2u);

    s = handSpace(3);
    s.max_depth = 5;  // the plan needs 6
    EXPECT_EQ(search->search(s).outcome, SearchResult::Outcome::DepthLimit) << search->description();

    // Two facts that undo each other: each is reachable, both together never.
    SearchSpace swap;
    swap.initial = {false, false};
    swap.goal = {{0, false}, {1, false}};
    swap.actions = {{{}, {}, {0}, {1}}, {{}, {}, {1}, {0}}};
    EXPECT_EQ(search->search(swap).outcome, SearchResult::Outcome::Exhausted) << search->description();
  }
}

TEST(PlanSearch, GoalThatHoldsNeedsNoSteps) {
  SearchSpace s = handSpace(1);
  s.goal = {{0, false}, {2, true}};  // on the table, not at its place
  for (const auto& search : searches()) {
    const SearchResult r = search->search(s);
    EXPECT_EQ(r.outcome, SearchResult::Outcome::Found);
    EXPECT_TRUE(r.plan.empty());
  }
}

TEST(PlanSearch, ThePlannerUsesTheSearchItIsGiven) {
  // A search that counts its calls and answers breadth-first: plan(problem, search) must go through it.
  struct Counting : PlanSearch {
    mutable int calls = 0;
    SearchResult search(const SearchSpace& space) const override {
      ++calls;
      return BreadthFirstSearch().search(space);
    }
    std::string description() const override { return "counting"; }
  } counting;
  PlanningProblem p;
  Contract move;
  move.name = "move";
  move.kind = Contract::Kind::Command;
  move.interface_type = "x/Move";
  move.description = "move";
  move.parameters = {"?to"};
  move.preconditions = {{"free(?to)", "the place is free"}};
  move.effects = {"at(?to)"};
  p.operators = {move};
  p.initial_state = {"free(a)"};
  p.goal = {"at(a)"};
  const PlanResult r = plan(p, counting);
  ASSERT_TRUE(r.found) << r.reason;
  EXPECT_EQ(counting.calls, 1);
  ASSERT_EQ(r.steps.size(), 1u);
  EXPECT_EQ(r.steps[0].toString(), "move(a)");
}
