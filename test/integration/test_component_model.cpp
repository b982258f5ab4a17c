// The component model, end to end: a nodelet manager with the example basic component (/counter) and
// the example aggregate (/statistics) loaded; lifecycle, contracts, commands, operations, status, events.
#include <actionlib/client/action_client.h>
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cmath>
#include <limits>

#include "test_helpers.h"
#include "xpersif/AddValues.h"
#include "xpersif/ResultCode.h"
#include "xpersif/CountToAction.h"
#include "xpersif/GetContracts.h"
#include "xpersif/GetState.h"
#include "xpersif/GetSummary.h"
#include "xpersif/SelectFeatures.h"
#include "xpersif/core/common/validation.h"

using xpersif::ComponentEvent;
using xpersif::ComponentStatus;
using xpersif_test::Recorder;
using xpersif_test::transition;
using xpersif_test::waitFor;
using Client = actionlib::SimpleActionClient<xpersif::CountToAction>;
using State = actionlib::SimpleClientGoalState;

namespace {

std::uint8_t stateOf(const std::string& component) {
  xpersif::GetState call;
  EXPECT_TRUE(ros::service::call(component + "/get_state", call));
  return call.response.state;
}

// Bring a component to ACTIVE whatever its state (refusals along the way are fine).
void ensureActive(const std::string& component) {
  if (stateOf(component) == ComponentStatus::ACTIVE) return;
  transition(component, "configure");
  ASSERT_TRUE(transition(component, "activate").success);
}

xpersif::AddValues::Response addValues(const std::string& component, const std::vector<double>& values) {
  xpersif::AddValues call;
  call.request.values = values;
  EXPECT_TRUE(ros::service::call(component + "/add_values", call));
  return call.response;
}

double counterTotal() { return addValues("/counter", {}).total; }

xpersif::CountToGoal goal(double target, double step, double deadline = 0) {
  xpersif::CountToGoal g;
  g.target = target;
  g.step = step;
  g.deadline = deadline;
  return g;
}

class ComponentModel : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(ros::service::waitForService("/counter/get_state", ros::Duration(30.0)));
    ASSERT_TRUE(ros::service::waitForService("/statistics/get_state", ros::Duration(30.0)));
    ASSERT_TRUE(ros::service::waitForService("/feature_selection/get_state", ros::Duration(30.0)));
  }
  ros::NodeHandle nh_;
};

}  // namespace

TEST_F(ComponentModel, LifecycleWalksLegalTransitionsAndRefusesIllegalOnesWithAReason) {
  Recorder<ComponentEvent> events(nh_, "/statistics/events");
  ASSERT_TRUE(events.waitForConnection(10.0));
  ASSERT_EQ(stateOf("/statistics"), ComponentStatus::UNCONFIGURED);

  auto r = transition("/statistics", "activate");
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.code, xpersif::ResultCode::PRECONDITION_FAILED);  // callers decide on codes, not on wording
  EXPECT_EQ(r.state, ComponentStatus::UNCONFIGURED);
  EXPECT_NE(r.message.find("configure it first"), std::string::npos) << r.message;

  r = transition("/statistics", "deactivate");
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("only an ACTIVE component can be deactivated"), std::string::npos) << r.message;

  EXPECT_TRUE(transition("/statistics", "configure").success);
  EXPECT_EQ(stateOf("/statistics"), ComponentStatus::INACTIVE);
  r = transition("/statistics", "activate");
  EXPECT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.code, xpersif::ResultCode::OK);
  EXPECT_EQ(r.state_name, "ACTIVE");

  r = transition("/statistics", "configure");
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.state, ComponentStatus::ACTIVE) << "a refused transition changes nothing";
  EXPECT_NE(r.message.find("deactivate it first"), std::string::npos) << r.message;

  // Every transition, refused or not, is mirrored on ~events.
  ComponentEvent refused;
  EXPECT_TRUE(events.waitForMatch(
      [](const ComponentEvent& e) {
        return e.kind == ComponentEvent::LIFECYCLE && e.name == "activate" && e.outcome == "refused";
      },
      5.0, &refused));
  EXPECT_NE(refused.reason.find("configure it first"), std::string::npos);
  EXPECT_TRUE(events.waitForMatch(
      [](const ComponentEvent& e) { return e.name == "activate" && e.outcome == "ok"; }, 5.0));
}

TEST_F(ComponentModel, StatusIsAHeartbeatWithStateAndParts) {
  ensureActive("/statistics");
  Recorder<ComponentStatus> status(nh_, "/statistics/status");
  ASSERT_TRUE(waitFor([&] { return status.messages().size() >= 3; }, 10.0));
  const auto messages = status.messages();
  EXPECT_GT(messages.back().heartbeat, messages[messages.size() - 2].heartbeat);
  const ComponentStatus& last = messages.back();
  EXPECT_EQ(last.component, "/statistics");
  EXPECT_EQ(last.type, "xpersif/ExampleStatisticsNodelet");
  EXPECT_EQ(last.state_name, "ACTIVE");
  EXPECT_NEAR(last.heartbeat_period, 0.2, 1e-9);
  ASSERT_EQ(last.parts.size(), 2u) << "the aggregate lists its parts";
  EXPECT_EQ(last.parts[0].name, "sum");
  EXPECT_EQ(last.parts[0].state_name, "ACTIVE");
  EXPECT_EQ(last.parts[1].name, "extremes");
}

TEST_F(ComponentModel, CommandWhosePreconditionFailsIsRejectedWithTheReason) {
  ensureActive("/counter");
  Client client("/counter/count_to", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(10.0)));

  client.sendGoal(goal(1000.0, 1.0));  // ~limit is 100
  ASSERT_TRUE(client.waitForResult(ros::Duration(10.0)));
  EXPECT_EQ(client.getState(), State::REJECTED);
  EXPECT_NE(client.getState().getText().find("precondition 'within_limit(1000)'"), std::string::npos)
      << client.getState().getText();
  EXPECT_NE(client.getState().getText().find("~limit is 100"), std::string::npos);

  client.sendGoal(goal(std::nan(""), 1.0));
  ASSERT_TRUE(client.waitForResult(ros::Duration(10.0)));
  EXPECT_EQ(client.getState(), State::REJECTED);
  EXPECT_EQ(client.getState().getText(), "invalid goal: goal.target is NaN; it must be a finite number");

  client.sendGoal(goal(counterTotal() + 1, 0.0));
  ASSERT_TRUE(client.waitForResult(ros::Duration(10.0)));
  EXPECT_EQ(client.getState(), State::REJECTED);
  EXPECT_NE(client.getState().getText().find("goal.step is 0"), std::string::npos);
}

TEST_F(ComponentModel, CommandThatSucceedsRecordsItsEffects) {
  ensureActive("/counter");
  Recorder<ComponentEvent> events(nh_, "/counter/events");
  ASSERT_TRUE(events.waitForConnection(10.0));
  Client client("/counter/count_to", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(10.0)));
  const double target = std::floor(counterTotal()) + 2;

  client.sendGoal(goal(target, 0.5));
  ASSERT_TRUE(client.waitForResult(ros::Duration(30.0)));
  EXPECT_EQ(client.getState(), State::SUCCEEDED) << client.getState().getText();
  EXPECT_DOUBLE_EQ(client.getResult()->total, target);

  ComponentEvent succeeded;
  ASSERT_TRUE(events.waitForMatch(
      [](const ComponentEvent& e) { return e.kind == ComponentEvent::COMMAND && e.outcome == "succeeded"; }, 5.0,
      &succeeded));
  EXPECT_EQ(succeeded.name, "count_to");
  ASSERT_EQ(succeeded.effects.size(), 1u);
  EXPECT_EQ(succeeded.effects[0], "total(counter, " + xpersif::core::describeNumber(target) + ")");
  EXPECT_NE(succeeded.request.find("target"), std::string::npos) << "the goal is recorded as text";
  EXPECT_TRUE(events.waitForMatch([](const ComponentEvent& e) { return e.outcome == "accepted"; }, 1.0));

  // The postcondition now holds, so the same goal fails its precondition.
  client.sendGoal(goal(target, 0.5));
  ASSERT_TRUE(client.waitForResult(ros::Duration(10.0)));
  EXPECT_EQ(client.getState(), State::REJECTED);
  EXPECT_NE(client.getState().getText().find("above("), std::string::npos);
}

TEST_F(ComponentModel, CancelMidwayGivesPreemptedAndFailureGivesAbortedNeverConfused) {
  ensureActive("/counter");
  Client client("/counter/count_to", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(10.0)));
  std::atomic<int> feedback_count{0};

  // 1000 steps of 10 ms: long enough to cancel in the middle.
  client.sendGoal(goal(counterTotal() + 10.0, 0.01), Client::SimpleDoneCallback(), Client::SimpleActiveCallback(),
                  [&](const xpersif::CountToFeedbackConstPtr&) { ++feedback_count; });
  ASSERT_TRUE(waitFor([&] { return feedback_count > 3; }, 10.0)) << "feedback flows while the command runs";

  // One goal at a time: a second goal is rejected while the first runs.
  Client second("/counter/count_to", true);
  ASSERT_TRUE(second.waitForServer(ros::Duration(10.0)));
  second.sendGoal(goal(99.0, 1.0));
  ASSERT_TRUE(second.waitForResult(ros::Duration(10.0)));
  EXPECT_EQ(second.getState(), State::REJECTED);
  EXPECT_NE(second.getState().getText().find("busy"), std::string::npos) << second.getState().getText();

  client.cancelGoal();
  ASSERT_TRUE(client.waitForResult(ros::Duration(10.0)));
  EXPECT_EQ(client.getState(), State::PREEMPTED);
  EXPECT_NE(client.getState().getText().find("stopped at total"), std::string::npos);

  // A deadline that passes is a failure: ABORTED with the reason.
  client.sendGoal(goal(counterTotal() + 10.0, 0.01, 0.05));
  ASSERT_TRUE(client.waitForResult(ros::Duration(10.0)));
  EXPECT_EQ(client.getState(), State::ABORTED);
  EXPECT_NE(client.getState().getText().find("deadline of 0.05 s passed"), std::string::npos)
      << client.getState().getText();
}

TEST_F(ComponentModel, AGoalSentTheMomentThePreviousOneEndedIsAccepted) {
  // The command is free before its result goes out: a client that sends the next goal as soon as it has a
  // result never finds it busy (it did, now and then, when the result went out first).
  ensureActive("/counter");
  Client client("/counter/count_to", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(10.0)));
  double total = std::floor(counterTotal());
  for (int i = 0; i < 30; ++i) {
    client.sendGoal(goal(total + 1.0, 1.0));  // one step
    ASSERT_TRUE(client.waitForResult(ros::Duration(10.0))) << "goal " << i;
    ASSERT_EQ(client.getState(), State::SUCCEEDED) << "goal " << i << ": " << client.getState().getText();
    total = client.getResult()->total;
  }
}

TEST_F(ComponentModel, DeactivatingTheComponentAbortsItsRunningCommandAndRefusesNewGoals) {
  ensureActive("/counter");
  Client client("/counter/count_to", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(10.0)));
  client.sendGoal(goal(counterTotal() + 10.0, 0.01));
  ASSERT_TRUE(waitFor([&] { return client.getState() == State::ACTIVE; }, 10.0));

  ASSERT_TRUE(transition("/counter", "deactivate").success);
  ASSERT_TRUE(client.waitForResult(ros::Duration(10.0)));
  EXPECT_EQ(client.getState(), State::ABORTED) << "a stop the client did not ask for is not PREEMPTED";
  EXPECT_NE(client.getState().getText().find("deactivated"), std::string::npos);

  client.sendGoal(goal(counterTotal() + 1.0, 1.0));
  ASSERT_TRUE(client.waitForResult(ros::Duration(10.0)));
  EXPECT_EQ(client.getState(), State::REJECTED);
  EXPECT_NE(client.getState().getText().find("needs component /counter ACTIVE, but it is INACTIVE"), std::string::npos)
      << client.getState().getText();
  ensureActive("/counter");
}

TEST_F(ComponentModel, OperationWithBadInputGetsAClearErrorAndChangesNothing) {
  ensureActive("/counter");
  Recorder<ComponentEvent> events(nh_, "/counter/events");
  ASSERT_TRUE(events.waitForConnection(10.0));
  const auto before = addValues("/counter", {});

  auto r = addValues("/counter", {1.0, std::numeric_limits<double>::quiet_NaN(), 2.0});
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.message, "invalid request: values[1] is NaN; every element must be a finite number");
  EXPECT_EQ(r.code, xpersif::ResultCode::INVALID);

  r = addValues("/counter", std::vector<double>(11, 1.0));  // ~max_values is 10
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.message, "invalid request: values has 11 elements; at most 10 are allowed");

  r = addValues("/counter", {std::numeric_limits<double>::infinity()});
  EXPECT_FALSE(r.success);

  const auto after = addValues("/counter", {});
  EXPECT_DOUBLE_EQ(after.total, before.total) << "refused calls change nothing";
  EXPECT_EQ(after.count, before.count);

  r = addValues("/counter", {1.5, 2.5});
  EXPECT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.code, xpersif::ResultCode::OK);
  EXPECT_DOUBLE_EQ(r.total, before.total + 4.0);

  ComponentEvent refused;
  ASSERT_TRUE(events.waitForMatch(
      [](const ComponentEvent& e) { return e.kind == ComponentEvent::OPERATION && e.outcome == "refused"; }, 5.0,
      &refused));
  EXPECT_EQ(refused.name, "add_values");
  EXPECT_NE(refused.request.find("nan"), std::string::npos) << refused.request;
  EXPECT_TRUE(events.waitForMatch(
      [](const ComponentEvent& e) {
        return e.outcome == "ok" && e.effects.size() == 1 && e.effects[0] == "increased(total)";
      },
      5.0));
}

TEST_F(ComponentModel, OperationsNeedAnActiveComponent) {
  ASSERT_TRUE(transition("/counter", "deactivate").success || stateOf("/counter") != ComponentStatus::ACTIVE);
  auto r = addValues("/counter", {1.0});
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.code, xpersif::ResultCode::NOT_ACTIVE);
  EXPECT_NE(r.message.find("operation 'add_values' needs component /counter ACTIVE"), std::string::npos) << r.message;
  ensureActive("/counter");
}

// An operation offered while INACTIVE (FEATURESELECTION's select_features) is still refused before configure: an
// UNCONFIGURED component would answer from parameters it has not read (a restarted FEATURESELECTION once answered
// "the feature selection is empty"). NOT_ACTIVE, so that a patient caller waits for the configure.
TEST_F(ComponentModel, OperationsOfferedWhileInactiveNeedAConfiguredComponent) {
  ASSERT_EQ(stateOf("/feature_selection"), ComponentStatus::UNCONFIGURED);
  xpersif::SelectFeatures select;  // no names: back to the initial selection
  ASSERT_TRUE(ros::service::call("/feature_selection/select_features", select));
  EXPECT_FALSE(select.response.success);
  EXPECT_EQ(select.response.code, xpersif::ResultCode::NOT_ACTIVE);
  EXPECT_NE(select.response.message.find("needs component /feature_selection configured"), std::string::npos)
      << select.response.message;
  ASSERT_TRUE(transition("/feature_selection", "configure").success);
  select = xpersif::SelectFeatures();
  ASSERT_TRUE(ros::service::call("/feature_selection/select_features", select));
  EXPECT_TRUE(select.response.success) << select.response.message;
  EXPECT_FALSE(select.response.selected.empty());
}

TEST_F(ComponentModel, ContractsCanBeReadThroughAnOperation) {
  xpersif::GetContracts call;
  ASSERT_TRUE(ros::service::call("/counter/get_contracts", call));
  ASSERT_TRUE(call.response.success);
  ASSERT_EQ(call.response.contracts.size(), 2u);
  const auto& count_to = call.response.contracts[0];
  EXPECT_EQ(count_to.name, "count_to");
  EXPECT_EQ(count_to.kind, "command");
  EXPECT_EQ(count_to.interface_type, "xpersif/CountToAction");
  ASSERT_EQ(count_to.preconditions.size(), 2u);
  EXPECT_EQ(count_to.preconditions[0].literal, "above(?target, total)");
  EXPECT_FALSE(count_to.preconditions[0].description.empty());
  EXPECT_EQ(count_to.effects, std::vector<std::string>{"total(counter, ?target)"});
  EXPECT_EQ(call.response.contracts[1].kind, "operation");

  call.request.name = "fly";
  call.response = {};
  ASSERT_TRUE(ros::service::call("/counter/get_contracts", call));
  EXPECT_FALSE(call.response.success);
  EXPECT_NE(call.response.message.find("has no command or operation 'fly'; it has: count_to, add_values"),
            std::string::npos)
      << call.response.message;
}

TEST_F(ComponentModel, AggregateShowsOneFacadeOverItsParts) {
  ensureActive("/statistics");
  auto r = addValues("/statistics", {1.0, 5.0, -2.0, 4.0});
  ASSERT_TRUE(r.success) << r.message;
  xpersif::GetSummary summary;
  ASSERT_TRUE(ros::service::call("/statistics/get_summary", summary));
  EXPECT_GE(summary.response.count, 4u);
  EXPECT_DOUBLE_EQ(summary.response.min, -2.0) << "part 'extremes' keeps the last 3 values";
  EXPECT_DOUBLE_EQ(summary.response.max, 5.0);
  EXPECT_DOUBLE_EQ(r.total, summary.response.sum);
  // The parts have no interface of their own: only the facade is advertised.
  EXPECT_FALSE(ros::service::exists("/statistics/sum/add_values", false));
}

TEST_F(ComponentModel, AggregatePartThatFailsToConfigurePutsTheAggregateInErrorNamingThePart) {
  ensureActive("/statistics");
  ASSERT_TRUE(transition("/statistics", "deactivate").success);
  ros::param::set("/statistics/extremes/history", 0);
  auto r = transition("/statistics", "configure");
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.code, xpersif::ResultCode::FAILED);
  EXPECT_EQ(r.state_name, "ERROR");
  EXPECT_NE(r.message.find("part 'extremes' failed to configure: /statistics/extremes/history is 0"),
            std::string::npos)
      << r.message;
  xpersif::GetState state;
  ASSERT_TRUE(ros::service::call("/statistics/get_state", state));
  EXPECT_EQ(state.response.health, ComponentStatus::HEALTH_ERROR);
  EXPECT_EQ(state.response.last_error, r.message);

  ros::param::set("/statistics/extremes/history", 3);
  r = transition("/statistics", "configure");
  EXPECT_TRUE(r.success) << "configure recovers from ERROR: " << r.message;
  EXPECT_TRUE(transition("/statistics", "activate").success);
}

TEST_F(ComponentModel, AParameterOfTheWrongTypeOrOutOfItsDeclaredRangeFailsConfigureNamingIt) {
  // NodeHandle::param would fall back on the default without a word; the declaration says what is wrong.
  ensureActive("/counter");
  ASSERT_TRUE(transition("/counter", "deactivate").success);
  ros::param::set("/counter/max_values", std::string("ten"));
  auto r = transition("/counter", "configure");
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("~max_values (/counter/max_values) is set but is not of type int"), std::string::npos)
      << r.message;
  ros::param::set("/counter/max_values", 0);
  r = transition("/counter", "configure");
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("~max_values is 0; it must lie in [1, 1e+07]"), std::string::npos) << r.message;
  ros::param::set("/counter/max_values", 10);
  r = transition("/counter", "configure");
  EXPECT_TRUE(r.success) << "configure recovers: " << r.message;
  EXPECT_TRUE(transition("/counter", "activate").success);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_component_model");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
