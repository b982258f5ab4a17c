// The decision components' pure parts, without a roscore: the PLANNER's operators named per component (and
// the plan they give for a push goal), excluded steps, plan steps as messages; EXECUTION's step checks and pose
// parsing; GOALDESIGN's prediction of where a pushed object ends, in the world.
#include <gtest/gtest.h>

#include <cmath>

#include "xpersif/decision/execution.h"
#include "xpersif/decision/goal_design.h"
#include "xpersif/decision/planner.h"

using namespace xpersif;

namespace {

core::Contract getFeatures() {
  core::Contract c;
  c.name = "get_features";
  c.interface_type = "xpersif/GetFeatures";
  c.preconditions = {{"perceived(scene)", "a feature vector must exist"}};
  c.effects = {"observed(scene)"};
  return c;
}

core::Contract push() {
  core::Contract c;
  c.name = "push";
  c.kind = core::Contract::Kind::Command;
  c.interface_type = "xpersif/PushAction";
  c.parameters = {"?object", "?side", "?offset", "?distance"};
  c.preconditions = {{"known(?object)", "known"}, {"observed(scene)", "seen"}};
  c.effects = {"pushed(?object, ?side, ?offset, ?distance)", "not observed(scene)"};
  return c;
}

std::vector<ComponentContracts> embodiment() {
  return {{"observation", {getFeatures()}}, {"vision", {getFeatures()}}, {"manipulation", {push()}}};
}

}  // namespace

TEST(DecisionPlanner, OperatorsAreNamedPerComponentPreferredFirst) {
  const auto ops = qualifiedOperators(embodiment(), {"vision"});
  ASSERT_EQ(ops.size(), 3u);
  EXPECT_EQ(ops[0].name, "vision/get_features");
  EXPECT_EQ(ops[1].name, "observation/get_features");
  EXPECT_EQ(ops[2].name, "manipulation/push");
}

TEST(DecisionPlanner, PushGoalPlansGetFeaturesPushGetFeaturesWithVision) {
  core::PlanningProblem problem;
  problem.operators = qualifiedOperators(embodiment(), {"vision"});
  problem.goal = {"pushed(red_cube, -x, 0.01, 0.05)", "observed(scene)"};
  const auto result = core::plan(problem);
  ASSERT_TRUE(result.found) << result.reason;
  const auto steps = toStepMessages(result.steps, problem.operators);
  ASSERT_EQ(steps.size(), 3u);
  EXPECT_EQ(steps[0].component, "vision");
  EXPECT_EQ(steps[0].operator_name, "get_features");
  EXPECT_EQ(steps[1].component, "manipulation");
  EXPECT_EQ(steps[1].interface_type, "xpersif/PushAction");
  EXPECT_EQ(steps[1].values, (std::vector<std::string>{"red_cube", "-x", "0.01", "0.05"}));
  EXPECT_EQ(steps[2].component, "vision");
  // Without the preference, the component listed first wins.
  problem.operators = qualifiedOperators(embodiment(), {});
  EXPECT_EQ(toStepMessages(core::plan(problem).steps, problem.operators)[0].component, "observation");
}

TEST(DecisionPlanner, ExcludedEntriesAreQualified) {
  const auto ops = qualifiedOperators(embodiment(), {"vision"});
  const auto excluded = qualifyExcluded({"get_features", "push(red_cube, -x, 0.01, 0.05)", "vision/x"}, ops);
  EXPECT_EQ(excluded, (std::set<std::string>{"vision/get_features", "observation/get_features",
                                             "manipulation/push(red_cube, -x, 0.01, 0.05)", "vision/x"}));
  core::PlanningProblem problem;
  problem.operators = ops;
  problem.goal = {"pushed(red_cube, -x, 0.01, 0.05)"};
  problem.initial_state = {"observed(scene)"};
  problem.excluded_steps = qualifyExcluded({"push(red_cube, -x, 0.01, 0.05)"}, ops);
  const auto result = core::plan(problem);
  EXPECT_FALSE(result.found);
  EXPECT_NE(result.reason.find("excluded"), std::string::npos) << result.reason;
}

TEST(DecisionExecution, StepChecksNameWhatIsWrong) {
  PlanStep s;
  s.component = "manipulation";
  s.operator_name = "push";
  s.interface_type = "xpersif/PushAction";
  s.parameters = {"?object", "?side", "?offset", "?distance"};
  s.values = {"red_cube", "-x", "0.01", "0.05"};
  EXPECT_EQ(checkStep("steps[0]", s), "");
  s.values[2] = "?offset";
  EXPECT_NE(checkStep("steps[0]", s).find("?offset"), std::string::npos);
  s.values[2] = "0.01x";
  EXPECT_NE(checkStep("steps[0]", s).find("not a number"), std::string::npos);
  s.values.pop_back();
  EXPECT_NE(checkStep("steps[0]", s).find("values"), std::string::npos);
  s.values = {"red_cube", "-x", "0.01", "0.05"};
  s.interface_type = "xpersif/FlyAction";
  EXPECT_NE(checkStep("steps[0]", s).find("interface_type"), std::string::npos);
  s.component = "bad name!";
  EXPECT_NE(checkStep("steps[0]", s).find("component"), std::string::npos);
}

TEST(DecisionExecution, PosesParseWithOrWithoutParentheses) {
  const auto p = parsePose("pose", "(0.1, -0.2, 1.5)");
  EXPECT_DOUBLE_EQ(p.x, 0.1);
  EXPECT_DOUBLE_EQ(p.y, -0.2);
  EXPECT_DOUBLE_EQ(p.theta, 1.5);
  EXPECT_DOUBLE_EQ(parsePose("pose", "0, 0.3, 0").y, 0.3);
  EXPECT_THROW(parsePose("pose", "(0.1, 0.2)"), core::ValidationError);
  EXPECT_THROW(parsePose("pose", "(0.1, nan, 0)"), core::ValidationError);
  EXPECT_THROW(parsePose("pose", "(a, b, c)"), core::ValidationError);
}

TEST(DecisionGoalDesign, PredictedEndRotatesThePushFrameIntoTheWorld) {
  core::ObjectFeatures o;
  o.x = 0.1;
  o.y = -0.1;
  o.yaw = 0.3;
  // "-x": along the object's +x axis, world direction 0.3.
  auto end = core::predictedEnd(o, "-x", {0.05, 0.0, 0.0});
  EXPECT_NEAR(end.x, 0.1 + 0.05 * std::cos(0.3), 1e-12);
  EXPECT_NEAR(end.y, -0.1 + 0.05 * std::sin(0.3), 1e-12);
  // "+y": along the object's -y axis; dy to the left of the push (the object's +x).
  end = core::predictedEnd(o, "+y", {0.05, 0.02, 0.1});
  const double d = 0.3 - M_PI / 2;
  EXPECT_NEAR(end.x, 0.1 + 0.05 * std::cos(d) - 0.02 * std::sin(d), 1e-12);
  EXPECT_NEAR(end.y, -0.1 + 0.05 * std::sin(d) + 0.02 * std::cos(d), 1e-12);
  EXPECT_NEAR(end.yaw, 0.4, 1e-12);
}
