// Generic dispatch (issue 14, item 6): EXECUTION runs a test component's commands and operation, of interface types
// it has never heard of, through the component's ~invoke; a bad value is refused (code INVALID) with a sentence
// naming the parameter before any step runs; a step whose effects did not hold is replanned with core::replan
// within ~max_replans; ~invoke itself survives bad input with sentences.
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_msgs/Float64.h>

#include <algorithm>
#include <mutex>

#include "test_helpers.h"
#include "xpersif/ComponentEvent.h"
#include "xpersif/ExecutePlanAction.h"
#include "xpersif/InvokeAction.h"
#include "xpersif/ResultCode.h"

using actionlib::SimpleClientGoalState;
using xpersif::ResultCode;
using xpersif_test::waitFor;

namespace {

using ExecuteClient = actionlib::SimpleActionClient<xpersif::ExecutePlanAction>;
using InvokeClient = actionlib::SimpleActionClient<xpersif::InvokeAction>;

xpersif::PlanStep step(const std::string& op, const std::vector<std::string>& parameters,
                       const std::vector<std::string>& values) {
  xpersif::PlanStep s;
  s.component = "tank";
  s.operator_name = op;
  s.parameters = parameters;
  s.values = values;
  return s;
}

xpersif::PlanStep fill(const std::string& op, const std::string& level) { return step(op, {"?level"}, {level}); }

class Dispatch : public ::testing::Test {
 protected:
  void SetUp() override {
    level_sub_ = nh_.subscribe<std_msgs::Float64>("/tank/level", 10, [this](const std_msgs::Float64::ConstPtr& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      level_ = m->data;
    });
    events_sub_ = nh_.subscribe<xpersif::ComponentEvent>("/tank/events", 100, [this](const xpersif::ComponentEvent::ConstPtr& e) {
      std::lock_guard<std::mutex> lock(mutex_);
      events_.push_back(*e);
    });
    ASSERT_TRUE(execute_.waitForServer(ros::Duration(30.0)));
    ASSERT_TRUE(waitFor([this] { return level() >= 0; }, 30.0)) << "the tank's level never came";
    ASSERT_TRUE(waitFor([this] { return events_sub_.getNumPublishers() > 0; }, 10.0));
  }

  double level() {
    std::lock_guard<std::mutex> lock(mutex_);
    return level_;
  }

  /// The grounded effects of the tank's successful calls of @p name seen so far.
  std::vector<std::string> effectsOf(const std::string& name, const std::string& outcome) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::string> all;
    for (const auto& e : events_) {
      if (e.name == name && e.outcome == outcome) all.insert(all.end(), e.effects.begin(), e.effects.end());
    }
    return all;
  }
  bool saw(const std::string& name, const std::string& outcome) {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::any_of(events_.begin(), events_.end(),
                       [&](const xpersif::ComponentEvent& e) { return e.name == name && e.outcome == outcome; });
  }

  SimpleClientGoalState run(const std::vector<xpersif::PlanStep>& steps, const std::vector<std::string>& goal = {}) {
    xpersif::ExecutePlanGoal g;
    g.steps = steps;
    g.goal = goal;
    execute_.sendGoal(g);
    EXPECT_TRUE(execute_.waitForResult(ros::Duration(60.0)));
    return execute_.getState();
  }

  ros::NodeHandle nh_;
  ExecuteClient execute_{"/execution/execute_plan", true};
  ros::Subscriber level_sub_, events_sub_;
  std::mutex mutex_;
  double level_ = -1;
  std::vector<xpersif::ComponentEvent> events_;
};

}  // namespace

TEST_F(Dispatch, RunsACommandAndAnOperationItHasNeverHeardOf) {
  ASSERT_EQ(run({fill("fill_slow", "6"), step("drain", {"?amount"}, {"2.5"})}), SimpleClientGoalState::SUCCEEDED)
      << execute_.getState().getText();
  const auto result = execute_.getResult();
  EXPECT_EQ(result->code, ResultCode::OK);
  EXPECT_EQ(result->replans, 0u);
  EXPECT_TRUE(waitFor([this] { return std::abs(level() - 3.5) < 1e-9; }, 5.0)) << level();
  // The effects, as the commands' and operations' own paths report them.
  EXPECT_TRUE(waitFor([this] { return !effectsOf("drain", "ok").empty(); }, 5.0));
  const auto filled = effectsOf("fill_slow", "succeeded");
  EXPECT_NE(std::find(filled.begin(), filled.end(), "level(tank, 6)"), filled.end());
  const auto drained = effectsOf("drain", "ok");
  EXPECT_NE(std::find(drained.begin(), drained.end(), "drained(tank, 2.5)"), drained.end());
}

TEST_F(Dispatch, BadValuesAreRefusedNamingTheParameterBeforeAnyStepRuns) {
  ASSERT_EQ(run({fill("fill_slow", "1")}), SimpleClientGoalState::SUCCEEDED) << execute_.getState().getText();
  ASSERT_TRUE(waitFor([this] { return std::abs(level() - 1.0) < 1e-9; }, 5.0)) << level();
  struct Case {
    xpersif::PlanStep bad;
    std::string says;
  };
  const std::vector<Case> cases = {
      {fill("fill_slow", "nan"), "?level"},
      {fill("fill_slow", "inf"), "?level"},
      {fill("fill_slow", "lots"), "?level"},
      {fill("fill_slow", "1e400"), "?level"},
      {fill("fill_slow", "11"), "?level"},  // beyond ~capacity 10
      {step("drain", {"?amount"}, {"-1"}), "?amount"},
      {step("fill_slow", {"?colour"}, {"red"}), "?colour"},
      {step("paint", {}, {}), "paint"}};
  for (const auto& c : cases) {
    // A good first step: it must not run, since the whole plan is checked first.
    const SimpleClientGoalState state = run({fill("fill_slow", "7"), c.bad});
    const auto result = execute_.getResult();
    EXPECT_EQ(state, SimpleClientGoalState::ABORTED) << c.says;
    EXPECT_EQ(result->code, ResultCode::INVALID) << result->message;
    EXPECT_EQ(result->failed_step, 1u) << result->message;
    EXPECT_NE(result->message.find(c.says), std::string::npos) << result->message;
  }
  ros::Duration(0.3).sleep();
  EXPECT_DOUBLE_EQ(level(), 1.0);  // nothing ran
}

TEST_F(Dispatch, AFailedStepIsReplannedFromTheObservedStateWithinTheBound) {
  // fill_fast fails (its valve is stuck): with the goal given, core::replan finds fill_slow.
  ASSERT_EQ(run({fill("fill_fast", "5")}, {"level(tank, 5)"}), SimpleClientGoalState::SUCCEEDED)
      << execute_.getState().getText();
  auto result = execute_.getResult();
  EXPECT_EQ(result->code, ResultCode::OK);
  EXPECT_EQ(result->replans, 1u);
  EXPECT_TRUE(waitFor([this] { return std::abs(level() - 5.0) < 1e-9; }, 5.0)) << level();
  EXPECT_TRUE(saw("fill_fast", "aborted"));
  const auto filled = effectsOf("fill_slow", "succeeded");
  EXPECT_NE(std::find(filled.begin(), filled.end(), "level(tank, 5)"), filled.end());

  // Without the goal, no replan: the step fails for good.
  ASSERT_EQ(run({fill("fill_fast", "4")}), SimpleClientGoalState::ABORTED);
  result = execute_.getResult();
  EXPECT_EQ(result->code, ResultCode::FAILED);
  EXPECT_EQ(result->replans, 0u);
  EXPECT_NE(result->message.find("fast valve is stuck"), std::string::npos) << result->message;
}

TEST_F(Dispatch, InvokeSurvivesBadInputWithSentences) {
  InvokeClient invoke("/tank/invoke", true);
  ASSERT_TRUE(invoke.waitForServer(ros::Duration(10.0)));
  const auto call = [&](const std::string& op, std::vector<std::string> parameters, std::vector<std::string> values,
                        bool check_only = false) {
    xpersif::InvokeGoal goal;
    goal.operator_name = op;
    goal.parameters = std::move(parameters);
    goal.values = std::move(values);
    goal.check_only = check_only;
    invoke.sendGoal(goal);
    EXPECT_TRUE(invoke.waitForResult(ros::Duration(20.0)));
    return invoke.getResult();
  };
  auto r = call("fill_slow", {"?level"}, {"2"});
  EXPECT_EQ(invoke.getState(), SimpleClientGoalState::SUCCEEDED) << r->message;
  EXPECT_EQ(r->code, ResultCode::OK);
  EXPECT_EQ(r->interface_type, "xpersif/CountToAction");
  EXPECT_EQ(r->effects, std::vector<std::string>{"level(tank, 2)"});
  ASSERT_EQ(r->outputs, std::vector<std::string>{"level"});
  EXPECT_EQ(r->output_values, std::vector<std::string>{"2"});
  r = call("fill_slow", {"?level"}, {"3"}, true);  // only checked: nothing runs
  EXPECT_EQ(r->code, ResultCode::OK);
  ros::Duration(0.3).sleep();
  EXPECT_DOUBLE_EQ(level(), 2.0);
  struct Case {
    std::string op;
    std::vector<std::string> parameters, values;
    std::uint8_t code;
    std::string says;
  };
  const std::vector<Case> cases = {
      {"fill_slow", {"?level"}, {"NaN"}, ResultCode::INVALID, "?level"},
      {"fill_slow", {"?level"}, {"-inf"}, ResultCode::INVALID, "?level"},
      {"fill_slow", {"?level"}, {std::string(5000, '9')}, ResultCode::INVALID, "?level"},
      {"fill_slow", {"?level", "?level"}, {"1", "2"}, ResultCode::INVALID, "twice"},
      {"fill_slow", {"?level"}, {}, ResultCode::INVALID, "values"},
      {"fill_slow", {}, {}, ResultCode::INVALID, "?level"},
      {"fill_slow", {"?volume"}, {"1"}, ResultCode::INVALID, "?volume"},
      {"fill_fast", {"?level"}, {"3"}, ResultCode::FAILED, "stuck"},
      {std::string(500, 'x'), {}, {}, ResultCode::INVALID, "operator_name"},
      {"get_contracts", {}, {}, ResultCode::INVALID, "fill_slow"}};  // not a contracted one: what it runs instead
  for (const auto& c : cases) {
    r = call(c.op, c.parameters, c.values);
    EXPECT_EQ(invoke.getState(), SimpleClientGoalState::ABORTED) << c.says;
    EXPECT_EQ(r->code, c.code) << r->message;
    EXPECT_NE(r->message.find(c.says), std::string::npos) << r->message;
  }
  EXPECT_DOUBLE_EQ(level(), 2.0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_dispatch");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
