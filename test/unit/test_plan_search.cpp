// The PLANNER's searches on the PlanSearch interface (plan_search.h), on numbered spaces built by hand.
#include <gtest/gtest.h>

#include <memory>

#include "xpersif/core/planning/plan_search.h"
#include "xpersif/core/planning/planner.h"
#include "search_spaces.h"

using namespace xpersif::core;
using testing_spaces::check;
using testing_spaces::handSpace;

namespace {

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
