#include <gtest/gtest.h>

#include "xpersif/core/planning/planner.h"
#include "xpersif/core/common/validation.h"

#include <algorithm>

using namespace xpersif::core;

namespace {

Contract makeContract(const std::string& name, std::vector<std::string> params, std::vector<Condition> pre,
                      std::vector<std::string> effects) {
  Contract c;
  c.name = name;
  c.kind = Contract::Kind::Command;
  c.parameters = std::move(params);
  c.preconditions = std::move(pre);
  c.effects = std::move(effects);
  return c;
}

Contract observeBefore() {
  return makeContract("observe_before", {}, {}, {"observed(before)"});
}

Contract push(const std::string& name = "push") {
  return makeContract(name, {"?object", "?side", "?offset", "?distance"},
                      {{"observed(before)", "the scene must be observed before the push"},
                       {"finite(?offset)", "the offset must be a finite number"},
                       {"positive(?distance)", "the distance must be positive"}},
                      {"pushed(?object, ?side)"});
}

Contract observeAfter() {
  return makeContract("observe_after", {"?object", "?side"},
                      {{"pushed(?object, ?side)", "the object must have been pushed"}}, {"observed(after, ?object)"});
}

Contract record() {
  return makeContract("record", {"?object", "?side"},
                      {{"observed(before)", "the scene before the push must be known"},
                       {"pushed(?object, ?side)", "the push must have happened"},
                       {"observed(after, ?object)", "the scene after the push must be known"}},
                      {"recorded(?object, ?side)"});
}

PlanningProblem experimentChain() {
  PlanningProblem p;
  // Deliberately not in execution order: the order must come from the contracts.
  p.operators = {record(), observeAfter(), push(), observeBefore()};
  p.goal = {"recorded(red_cube, +x)"};
  return p;
}

std::vector<std::string> strings(const std::vector<PlanStep>& steps) {
  std::vector<std::string> out;
  for (const auto& s : steps) out.push_back(s.toString());
  return out;
}

}  // namespace

TEST(Planner, FindsTheExperimentChainInOrderWithBindings) {
  const PlanningProblem p = experimentChain();
  const PlanResult r = plan(p);
  ASSERT_TRUE(r.found) << r.reason;
  EXPECT_EQ(strings(r.steps), (std::vector<std::string>{"observe_before()", "push(red_cube, +x, ?offset, ?distance)",
                                                        "observe_after(red_cube, +x)", "record(red_cube, +x)"}));
  const PlanStep& pushStep = r.steps[1];
  EXPECT_EQ(pushStep.bindings.at("?object"), "red_cube");
  EXPECT_EQ(pushStep.bindings.at("?side"), "+x");
  // The offset and distance occur only in static checks: open, supplied by the experiment at execution.
  EXPECT_EQ(pushStep.openParameters(), (std::vector<std::string>{"?offset", "?distance"}));
  EXPECT_EQ(pushStep.assumed, (std::vector<std::string>{"finite(?offset)", "positive(?distance)"}));
  EXPECT_EQ(validatePlan(p, r.steps), "");
  EXPECT_GT(r.expanded, 0u);
}

TEST(Planner, DomainsBindParametersAndDistractorsDoNotLengthenThePlan) {
  PlanningProblem p = experimentChain();
  p.parameter_domains["?object"] = {"blue_cube", "green_cube", "red_cube", "yellow_cube"};
  p.parameter_domains["?side"] = {"-x", "+x", "-y", "+y"};
  p.parameter_domains["?offset"] = {"0.01"};
  p.parameter_domains["?distance"] = {"0.06"};
  const PlanResult r = plan(p);
  ASSERT_TRUE(r.found) << r.reason;
  ASSERT_EQ(r.steps.size(), 4u);
  EXPECT_EQ(r.steps[1].toString(), "push(red_cube, +x, 0.01, 0.06)");
  EXPECT_TRUE(r.steps[1].openParameters().empty());
  EXPECT_EQ(r.steps[1].assumed, (std::vector<std::string>{"finite(0.01)", "positive(0.06)"}));
}

TEST(Planner, GoalLiteralBindsTheOperatorThatProducesIt) {
  PlanningProblem p = experimentChain();
  p.goal = {"pushed(green_cube, -y)"};
  const PlanResult r = plan(p);
  ASSERT_TRUE(r.found) << r.reason;
  EXPECT_EQ(strings(r.steps),
            (std::vector<std::string>{"observe_before()", "push(green_cube, -y, ?offset, ?distance)"}));
}

TEST(Planner, GoalThatAlreadyHoldsNeedsNoSteps) {
  PlanningProblem p = experimentChain();
  p.initial_state = {"recorded(red_cube,+x)"};  // spacing differs from the goal's: literals are canonicalized
  const PlanResult r = plan(p);
  EXPECT_TRUE(r.found);
  EXPECT_TRUE(r.steps.empty());
}

TEST(Planner, UnreachableGoalIsNamedInTheReason) {
  PlanningProblem p = experimentChain();
  p.goal = {"recorded(red_cube, +x)", "calibrated(camera)"};
  PlanResult r = plan(p);
  EXPECT_FALSE(r.found);
  EXPECT_NE(r.reason.find("'calibrated(camera)'"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("no operator's effect produces it"), std::string::npos) << r.reason;

  // A missing link deep in the chain: the reason follows it down to the literal nothing produces.
  p = experimentChain();
  p.operators.pop_back();  // no observe_before
  r = plan(p);
  EXPECT_FALSE(r.found);
  EXPECT_NE(r.reason.find("'recorded(red_cube, +x)'"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("'observed(before)'"), std::string::npos) << r.reason;
}

TEST(Planner, DomainThatExcludesTheGoalValueIsPointedOut) {
  PlanningProblem p = experimentChain();
  p.goal = {"pushed(red_cube, +x)"};
  p.parameter_domains["?object"] = {"green_cube"};
  const PlanResult r = plan(p);
  EXPECT_FALSE(r.found);
  EXPECT_NE(r.reason.find("'pushed(red_cube, +x)'"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("parameter_domains"), std::string::npos) << r.reason;
}

TEST(Planner, StaticPredicatesAreAssumedUntilTheStateMentionsThem) {
  PlanningProblem p = experimentChain();
  p.operators[2].preconditions.push_back({"reachable(?object)", "the robot must be able to reach the object"});
  p.goal = {"pushed(red_cube, +x)"};
  PlanResult r = plan(p);
  ASSERT_TRUE(r.found) << r.reason;
  EXPECT_NE(std::find(r.steps[1].assumed.begin(), r.steps[1].assumed.end(), "reachable(red_cube)"),
            r.steps[1].assumed.end());

  // Once the state lists reachability, the planner tracks it (closed world): red is not reachable.
  p.initial_state = {"reachable(green_cube)"};
  r = plan(p);
  EXPECT_FALSE(r.found);
  EXPECT_NE(r.reason.find("'reachable(red_cube)'"), std::string::npos) << r.reason;
  p.goal = {"pushed(green_cube, +x)"};
  EXPECT_TRUE(plan(p).found);
}

namespace {

/// One hand: picking needs an empty hand and empties the table spot; placing frees the hand.
PlanningProblem handProblem() {
  PlanningProblem p;
  p.operators = {
      makeContract("pick", {"?x"},
                   {{"handempty()", "the gripper must be empty"}, {"on_table(?x)", "the object must be on the table"}},
                   {"holding(?x)", "not handempty()", "not on_table(?x)"}),
      makeContract("place", {"?x", "?place"}, {{"holding(?x)", "the object must be held"}},
                   {"at(?x, ?place)", "handempty()", "not holding(?x)"}),
  };
  p.initial_state = {"handempty()", "on_table(a)", "on_table(b)"};
  p.goal = {"at(a, p1)", "at(b, p2)"};
  return p;
}

}  // namespace

TEST(Planner, DeleteEffectsAreHonoured) {
  const PlanningProblem p = handProblem();
  const PlanResult r = plan(p);
  ASSERT_TRUE(r.found) << r.reason;
  ASSERT_EQ(r.steps.size(), 4u);
  // If "not handempty()" were ignored, picking both first would be as short (and found first).
  for (std::size_t i = 0; i < r.steps.size(); ++i) {
    EXPECT_EQ(r.steps[i].operator_name, i % 2 == 0 ? "pick" : "place") << strings(r.steps)[i];
  }
  EXPECT_EQ(validatePlan(p, r.steps), "");

  // The plan that ignores the delete is rejected at its second step, naming the precondition.
  std::vector<PlanStep> greedy = {r.steps[0], r.steps[2], r.steps[1], r.steps[3]};
  const std::string why = validatePlan(p, greedy);
  EXPECT_NE(why.find("step 2"), std::string::npos) << why;
  EXPECT_NE(why.find("'handempty()'"), std::string::npos) << why;
  EXPECT_NE(why.find("the gripper must be empty"), std::string::npos) << why;

  // applyStep: deletes, then adds.
  const auto after = applyStep(p, p.initial_state, r.steps[0]);
  EXPECT_EQ(after.count("handempty()"), 0u);
  EXPECT_EQ(after.count("holding(" + r.steps[0].bindings.at("?x") + ")"), 1u);
}

TEST(Planner, NegatedGoalsAndPreconditions) {
  PlanningProblem p;
  p.operators = {makeContract("launch", {}, {{"not running()", "the loop must be stopped"}}, {"running()", "launched()"}),
                 makeContract("stop", {}, {{"running()", "the loop must be running"}}, {"not running()"})};
  p.initial_state = {"running()"};
  p.goal = {"launched()"};
  PlanResult r = plan(p);
  ASSERT_TRUE(r.found) << r.reason;
  EXPECT_EQ(strings(r.steps), (std::vector<std::string>{"stop()", "launch()"}));

  p.goal = {"not running()"};
  r = plan(p);
  ASSERT_TRUE(r.found) << r.reason;
  EXPECT_EQ(strings(r.steps), (std::vector<std::string>{"stop()"}));

  // Each goal literal is reachable alone, never both together.
  p.goal = {"running()", "not running()"};
  r = plan(p);
  EXPECT_FALSE(r.found);
  EXPECT_NE(r.reason.find("together"), std::string::npos) << r.reason;

  // Nothing deletes it.
  p.operators.pop_back();
  p.goal = {"not running()"};
  r = plan(p);
  EXPECT_FALSE(r.found);
  EXPECT_NE(r.reason.find("'not running()'"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("no operator deletes it"), std::string::npos) << r.reason;
}

TEST(Planner, ReplanningAfterAFailedStepTakesTheAlternative) {
  PlanningProblem p = experimentChain();
  p.operators.push_back(push("nudge"));  // declared after push: the first plan uses push
  PlanResult r = plan(p);
  ASSERT_TRUE(r.found) << r.reason;
  ASSERT_EQ(r.steps[1].operator_name, "push");

  // observe_before succeeded, the push failed: plan again from what holds now.
  const auto now = applyStep(p, p.initial_state, r.steps[0]);
  const PlanResult again = replan(p, now, r.steps[1]);
  ASSERT_TRUE(again.found) << again.reason;
  EXPECT_EQ(strings(again.steps), (std::vector<std::string>{"nudge(red_cube, +x, ?offset, ?distance)",
                                                            "observe_after(red_cube, +x)", "record(red_cube, +x)"}));
  PlanningProblem from_now = p;
  from_now.initial_state = now;
  EXPECT_EQ(validatePlan(from_now, again.steps), "");

  // Excluding an operator by name.
  p.excluded_steps = {"push"};
  r = plan(p);
  ASSERT_TRUE(r.found) << r.reason;
  EXPECT_EQ(r.steps[1].operator_name, "nudge");
}

TEST(Planner, ReplanningWithoutAlternativeSaysTheFailedStepWasExcluded) {
  const PlanningProblem p = experimentChain();
  const PlanResult r = plan(p);
  ASSERT_TRUE(r.found);
  const PlanResult again = replan(p, {"observed(before)"}, r.steps[1]);
  EXPECT_FALSE(again.found);
  EXPECT_NE(again.reason.find("no plan avoids the failed step 'push(red_cube, +x, ?offset, ?distance)'"),
            std::string::npos)
      << again.reason;
  EXPECT_NE(again.reason.find("only by the excluded step"), std::string::npos) << again.reason;
}

TEST(Planner, LimitsAreRespected) {
  PlanningProblem p = experimentChain();
  p.max_depth = 3;
  PlanResult r = plan(p);
  EXPECT_FALSE(r.found);
  EXPECT_NE(r.reason.find("at most 3 steps"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("max_depth"), std::string::npos) << r.reason;
  p.max_depth = 4;
  EXPECT_TRUE(plan(p).found);

  p.max_expansions = 2;
  r = plan(p);
  EXPECT_FALSE(r.found);
  EXPECT_LE(r.expanded, 2u);
  EXPECT_NE(r.reason.find("max_expansions"), std::string::npos) << r.reason;

  p = experimentChain();
  p.parameter_domains["?object"] = {"a", "b", "c", "d", "e", "red_cube"};
  p.parameter_domains["?side"] = {"-x", "+x", "-y", "+y"};
  p.max_groundings = 10;
  r = plan(p);
  EXPECT_FALSE(r.found);
  EXPECT_NE(r.reason.find("max_groundings"), std::string::npos) << r.reason;
}

TEST(Planner, SearchOnlyConsidersRelevantInstances) {
  PlanningProblem p = experimentChain();
  p.parameter_domains["?object"] = {"blue_cube", "green_cube", "red_cube", "yellow_cube"};
  p.parameter_domains["?side"] = {"-x", "+x", "-y", "+y"};
  const PlanResult r = plan(p);
  ASSERT_TRUE(r.found);
  // Of 49 instances (observe_before and 16 of each other operator) the relevant ones are observe_before,
  // record(red_cube, +x), and, because any side's observe_after yields observed(after, red_cube), the four
  // observe_after(red_cube, *) and the four push(red_cube, *): 10. Other objects are pruned.
  EXPECT_EQ(r.groundings, 10u);
  EXPECT_EQ(r.steps.size(), 4u);
}

TEST(Planner, MalformedContractsThrowContractError) {
  PlanningProblem p = experimentChain();
  p.operators[0].effects.push_back("recorded(?nothing)");
  EXPECT_THROW(plan(p), ContractError);

  p = experimentChain();
  p.operators[1].preconditions[0].literal = "pushed(?object, ?side";
  EXPECT_THROW(plan(p), ContractError);

  p = experimentChain();
  p.operators[2].preconditions[0].description = "";
  EXPECT_THROW(plan(p), ContractError);

  p = experimentChain();
  p.operators.push_back(push());
  try {
    plan(p);
    FAIL() << "duplicate operator names were accepted";
  } catch (const ContractError& e) {
    EXPECT_NE(std::string(e.what()).find("'push'"), std::string::npos) << e.what();
  }
}

TEST(Planner, MalformedProblemsThrowValidationError) {
  PlanningProblem p = experimentChain();
  p.goal = {"recorded(?object, +x)"};
  EXPECT_THROW(plan(p), ValidationError);
  p = experimentChain();
  p.goal = {"recorded(red_cube"};
  EXPECT_THROW(plan(p), ValidationError);
  p = experimentChain();
  p.initial_state = {"not observed(before)"};
  EXPECT_THROW(plan(p), ValidationError);
  p = experimentChain();
  p.parameter_domains["?object"] = {};
  EXPECT_THROW(plan(p), ValidationError);
  p = experimentChain();
  p.parameter_domains["object"] = {"red_cube"};
  EXPECT_THROW(plan(p), ValidationError);
  p = experimentChain();
  p.parameter_domains["?object"] = {"red cube"};
  EXPECT_THROW(plan(p), ValidationError);
}

TEST(Planner, ValidatePlanReportsUnknownOperatorsAndUnmetGoals) {
  const PlanningProblem p = experimentChain();
  PlanStep bogus;
  bogus.operator_name = "teleport";
  EXPECT_NE(validatePlan(p, {bogus}).find("no operator named 'teleport'"), std::string::npos);

  const PlanResult r = plan(p);
  ASSERT_TRUE(r.found);
  std::vector<PlanStep> shortened(r.steps.begin(), r.steps.end() - 1);
  const std::string why = validatePlan(p, shortened);
  EXPECT_NE(why.find("goal literal 'recorded(red_cube, +x)' does not hold"), std::string::npos) << why;

  std::vector<PlanStep> swapped = {r.steps[1], r.steps[0], r.steps[2], r.steps[3]};
  const std::string first = validatePlan(p, swapped);
  EXPECT_NE(first.find("step 1 'push(red_cube, +x, ?offset, ?distance)'"), std::string::npos) << first;
  EXPECT_NE(first.find("'observed(before)'"), std::string::npos) << first;
}

TEST(Planner, GreedySearchHandlesManyIndependentSubgoals) {
  PlanningProblem p = handProblem();
  p.initial_state = {"handempty()"};
  p.goal.clear();
  for (int i = 0; i < 6; ++i) {
    p.initial_state.insert("on_table(o" + std::to_string(i) + ")");
    p.goal.push_back("at(o" + std::to_string(i) + ", p" + std::to_string(i) + ")");
  }
  p.max_expansions = 5000;
  // Breadth-first needs far more states for a 12-step plan (126300 measured without the limit).
  PlanResult r = plan(p);
  EXPECT_FALSE(r.found);
  EXPECT_NE(r.reason.find("max_expansions"), std::string::npos) << r.reason;

  p.search = SearchStrategy::GreedyGoalCount;
  r = plan(p);
  ASSERT_TRUE(r.found) << r.reason;
  EXPECT_EQ(r.steps.size(), 12u);
  EXPECT_LT(r.expanded, 5000u);
  EXPECT_EQ(validatePlan(p, r.steps), "");
}
