// The decision components' pure parts, without a roscore: the PLANNER's operators named per component (and
// the plan they give for a push goal), excluded steps, plan steps as messages; EXECUTION's step checks; the
// embodiment's binders for ~invoke; GOALDESIGN's prediction of where a pushed object ends, in the world.
#include <gtest/gtest.h>

#include <cmath>

#include "xpersif/decision/execution.h"
#include "xpersif/decision/goal_design.h"
#include "xpersif/decision/planner_component.h"
#include "xpersif/embodiment/manipulation.h"
#include "xpersif/embodiment/relocation.h"
#include "xpersif/perception/latest_features.h"

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
  s.values[2] = "";
  EXPECT_NE(checkStep("steps[0]", s).find("?offset"), std::string::npos);
  s.values.pop_back();
  EXPECT_NE(checkStep("steps[0]", s).find("values"), std::string::npos);
  s.values = {"red_cube", "-x", "0.01", "0.05"};
  s.component = "bad name!";
  EXPECT_NE(checkStep("steps[0]", s).find("component"), std::string::npos);
}

TEST(DecisionExecution, StepsAreCheckedAgainstTheContractsNotAListOfTypes) {
  PlanStep s;
  s.component = "painter";
  s.operator_name = "push";
  s.interface_type = "xpersif/PushAction";
  s.parameters = {"?object", "?side", "?offset", "?distance"};
  s.values = {"red_cube", "-x", "0.01", "0.05"};
  const std::vector<core::Contract> contracts{getFeatures(), push()};
  EXPECT_EQ(checkStepContract("steps[0]", s, contracts), "");
  s.interface_type = "";  // not given: the contract's
  EXPECT_EQ(checkStepContract("steps[0]", s, contracts), "");
  s.interface_type = "xpersif/FlyAction";
  EXPECT_NE(checkStepContract("steps[0]", s, contracts).find("interface_type"), std::string::npos);
  s.interface_type = "xpersif/PushAction";
  s.parameters[1] = "?colour";
  EXPECT_NE(checkStepContract("steps[0]", s, contracts).find("?colour"), std::string::npos);
  s.parameters[1] = "?side";
  s.operator_name = "paint";
  const std::string why = checkStepContract("steps[0]", s, contracts);
  EXPECT_NE(why.find("paint"), std::string::npos) << why;
  EXPECT_NE(why.find("get_features, push"), std::string::npos) << why;  // what it offers instead
}

// The binders that replaced EXECUTION's list of four goal builders: each builds its typed goal from the bindings,
// and every bad value is a ValidationError (INVALID at ~invoke) whose sentence names the parameter.
TEST(DecisionBinders, BuildTypedGoalsFromBindings) {
  const std::vector<std::string> push_parameters{"?object", "?side", "?offset", "?distance"};
  const PushGoal push = pushGoalFrom(core::Invocation("push", push_parameters, push_parameters,
                                                      {"red_cube", "-x", "0.01", "0.05"}, {"pose_source"},
                                                      {"observation"}));
  EXPECT_EQ(push.object, "red_cube");
  EXPECT_EQ(push.side, "-x");
  EXPECT_DOUBLE_EQ(push.offset, 0.01);
  EXPECT_DOUBLE_EQ(push.distance, 0.05);
  EXPECT_EQ(push.pose_source, "observation");
  const GoToPoseGoal go = goToPoseGoalFrom(core::Invocation("go_to_pose", {"?pose"}, {"?pose"}, {"(0.1, -0.2, 1.5)"}));
  EXPECT_DOUBLE_EQ(go.target.x, 0.1);
  EXPECT_DOUBLE_EQ(go.target.y, -0.2);
  EXPECT_DOUBLE_EQ(go.target.theta, 1.5);
  EXPECT_EQ(go.pose_source, "");
  EXPECT_DOUBLE_EQ(turnToGoalFrom(core::Invocation("turn_to", {"?heading"}, {"?heading"}, {"-1.5"})).heading, -1.5);
  const auto features = LatestFeatures::binder();
  EXPECT_DOUBLE_EQ(features.bind(core::Invocation("get_features", {}, {}, {}, {"max_age"}, {"0.5"})).max_age, 0.5);
  GetFeatures::Response response;
  response.features.header.stamp = ros::Time(12.5);
  InvokeResult out;
  features.report(response, out);
  ASSERT_EQ(out.features.size(), 1u);
  EXPECT_EQ(out.features[0].header.stamp, ros::Time(12.5));
  PushResult pushed;
  pushed.robot_final.x = 0.25;
  reportPush(pushed, out);
  ASSERT_FALSE(out.outputs.empty());
  EXPECT_EQ(out.outputs[0], "robot_pose");
  EXPECT_DOUBLE_EQ(core::parsePose("robot_pose", out.output_values[0]).x, 0.25);
}

TEST(DecisionBinders, BadValuesAreSentencesNamingTheParameter) {
  const auto says = [](auto&& f) {
    try {
      f();
    } catch (const core::ValidationError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::vector<std::string> push_parameters{"?object", "?side", "?offset", "?distance"};
  const auto push = [&](std::vector<std::string> values) {
    return [=] { pushGoalFrom(core::Invocation("push", push_parameters, push_parameters, values)); };
  };
  EXPECT_NE(says(push({"red_cube", "-x", "nan", "0.05"})).find("?offset"), std::string::npos);
  EXPECT_NE(says(push({"red_cube", "-x", "0.01", "inf"})).find("?distance"), std::string::npos);
  EXPECT_NE(says(push({"red_cube", "-x", "0.01", "far"})).find("?distance"), std::string::npos);
  EXPECT_NE(says(push({"?o", "-x", "0.01", "0.05"})).find("?object"), std::string::npos);
  EXPECT_NE(says([] { pushGoalFrom(core::Invocation("push", {"?object"}, {"?object"}, {"red_cube"})); }).find("?side"),
            std::string::npos);  // needed, not given
  EXPECT_NE(says([] { goToPoseGoalFrom(core::Invocation("go_to_pose", {"?pose"}, {"?pose"}, {"(0.1, 0.2)"})); })
                .find("?pose"),
            std::string::npos);
  EXPECT_NE(says([] { turnToGoalFrom(core::Invocation("turn_to", {"?heading"}, {"?heading"}, {"1e300"})); })
                .find("?heading"),
            std::string::npos);  // beyond core::kMaxHeading
  EXPECT_NE(says([] { setMaxVelocityRequestFrom(core::Invocation("set_max_velocity", {"?linear", "?angular"},
                                                                 {"?linear", "?angular"}, {"0.1", "-nan"})); })
                .find("?angular"),
            std::string::npos);
  const auto features = LatestFeatures::binder();
  EXPECT_NE(says([&] { features.bind(core::Invocation("get_features", {}, {}, {}, {"max_age"}, {"-1"})); }).find("max_age"),
            std::string::npos);
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
