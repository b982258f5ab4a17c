// KNOWLEDGEBASE's calls and facts through ROS (issue 14, item 4): the example counter's command outcomes and
// operation calls reach the store through the shared component_events topic; get_calls filters them and refuses
// bad filters; get_facts follows the latest effect per subject; PLANNER plans from those facts on request.
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "test_helpers.h"
#include "xpersif/AddValues.h"
#include "xpersif/ComponentEvent.h"
#include "xpersif/CountToAction.h"
#include "xpersif/GetCalls.h"
#include "xpersif/GetFacts.h"
#include "xpersif/GetState.h"
#include "xpersif/MakePlan.h"
#include "xpersif/ResultCode.h"
#include "xpersif/StartRun.h"

using xpersif::ComponentEvent;
using xpersif::ResultCode;
using xpersif_test::waitFor;

namespace {

xpersif::GetCalls::Response getCalls(const std::string& component = "", const std::string& kind = "",
                                     double since = 0.0, std::uint32_t limit = 0, std::uint64_t run_id = 0) {
  xpersif::GetCalls call;
  call.request.run_id = run_id;
  call.request.component = component;
  call.request.kind = kind;
  call.request.since = since;
  call.request.limit = limit;
  EXPECT_TRUE(ros::service::call("/knowledge_base/get_calls", call));
  return call.response;
}

std::vector<std::string> facts() {
  xpersif::GetFacts call;
  EXPECT_TRUE(ros::service::call("/knowledge_base/get_facts", call));
  EXPECT_TRUE(call.response.success) << call.response.message;
  return call.response.facts;
}

bool contains(const std::vector<std::string>& list, const std::string& item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

void countTo(double target) {
  actionlib::SimpleActionClient<xpersif::CountToAction> client("/counter/count_to", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(20.0)));
  xpersif::CountToGoal goal;
  goal.target = target;
  goal.step = 1.0;
  client.sendGoal(goal);
  ASSERT_TRUE(client.waitForResult(ros::Duration(20.0)));
  ASSERT_EQ(client.getState(), actionlib::SimpleClientGoalState::SUCCEEDED) << client.getState().getText();
}

xpersif::MakePlan::Response makePlan(const std::string& goal, bool from_knowledge_base) {
  xpersif::MakePlan call;
  call.request.goal = {goal};
  call.request.state_from_knowledge_base = from_knowledge_base;
  EXPECT_TRUE(ros::service::call("/planner/make_plan", call));
  return call.response;
}

/// The counter's calls as the KB has them, once at least @p count have been written.
std::vector<xpersif::CallRecord> counterCalls(std::size_t count) {
  std::vector<xpersif::CallRecord> calls;
  waitFor([&] { return (calls = getCalls("counter").calls).size() >= count; }, 10.0);
  return calls;
}

}  // namespace

// One scenario in order: the planner's refusal needs the run not to exist yet, the facts need the calls before.
TEST(KbEffects, CallsAndFactsAreStoredQueriedAndPlannedFrom) {
  for (const char* service : {"/knowledge_base/get_calls", "/counter/add_values", "/planner/make_plan"}) {
    ASSERT_TRUE(ros::service::waitForService(service, ros::Duration(30.0))) << service;
  }
  // Services are offered before autostart has activated the component: wait for ACTIVE.
  for (const std::string component : {"/knowledge_base", "/counter", "/planner"}) {
    ASSERT_TRUE(waitFor(
        [&] {
          xpersif::GetState state;
          return ros::service::call(component + "/get_state", state) && state.response.state_name == "ACTIVE";
        },
        30.0))
        << component << " never became ACTIVE";
  }
  // The planner must have read the counter's contracts before it plans at all.
  ASSERT_TRUE(waitFor([] { return makePlan("total(counter, 1)", false).success; }, 20.0));

  // No run yet: the KB has no current run, so neither facts nor a plan from them.
  const auto no_run = makePlan("total(counter, 1)", true);
  EXPECT_FALSE(no_run.success);
  EXPECT_EQ(no_run.code, ResultCode::FAILED) << no_run.message;
  EXPECT_NE(no_run.message.find("get_facts refused"), std::string::npos) << no_run.message;

  // An event published before the KB's subscription has connected to the counter is lost (a topic keeps
  // nothing), and under load that connection can lag the services by more than this scenario takes (a CI run lost
  // count_to's outcome). A warm-up run proves the connection: the counter's get_state calls reach it.
  xpersif::StartRun warm_up;
  warm_up.request.name = "kb_effects_warm_up";
  warm_up.request.parameters = "{}";
  ASSERT_TRUE(ros::service::call("/knowledge_base/start_run", warm_up));
  ASSERT_TRUE(warm_up.response.success) << warm_up.response.message;
  const std::uint64_t warm_up_run = warm_up.response.run_id;
  ASSERT_TRUE(waitFor(
      [&] {
        xpersif::GetState state;
        ros::service::call("/counter/get_state", state);
        return !getCalls("counter", "", 0.0, 0, warm_up_run).calls.empty();
      },
      20.0))
      << "the counter's calls never reached the knowledge base";
  // One more, and wait for it: the counter's events arrive in order, so every warm-up call before it is stored in
  // the warm-up run too, and none lands in the scenario's run.
  const double marked = ros::Time::now().toSec();
  xpersif::GetState marker;
  ASSERT_TRUE(ros::service::call("/counter/get_state", marker));
  ASSERT_TRUE(waitFor([&] { return !getCalls("counter", "", marked, 0, warm_up_run).calls.empty(); }, 10.0));

  xpersif::StartRun start;
  start.request.name = "kb_effects";
  start.request.parameters = "{}";
  ASSERT_TRUE(ros::service::call("/knowledge_base/start_run", start));
  ASSERT_TRUE(start.response.success) << start.response.message;

  countTo(3.0);
  xpersif::AddValues add;
  add.request.values = {1.0, 2.0};
  ASSERT_TRUE(ros::service::call("/counter/add_values", add));
  ASSERT_TRUE(add.response.success);
  xpersif::AddValues bad;
  bad.request.values = {std::numeric_limits<double>::quiet_NaN()};
  ASSERT_TRUE(ros::service::call("/counter/add_values", bad));
  ASSERT_EQ(bad.response.code, ResultCode::INVALID);

  // Three calls of the counter (the acceptance of count_to is not a call of its own), in the order they ended.
  const auto calls = counterCalls(3);
  ASSERT_EQ(calls.size(), 3u);
  EXPECT_EQ(calls[0].component, "/counter");
  EXPECT_EQ(calls[0].kind, "command");
  EXPECT_EQ(calls[0].name, "count_to");
  EXPECT_EQ(calls[0].outcome, "succeeded");
  EXPECT_EQ(calls[0].code, ComponentEvent::NO_CODE);
  EXPECT_EQ(calls[0].effects, std::vector<std::string>{"total(counter, 3)"});
  EXPECT_EQ(calls[0].run_id, start.response.run_id);
  EXPECT_EQ(calls[1].name, "add_values");
  EXPECT_EQ(calls[1].outcome, "ok");
  EXPECT_EQ(calls[1].code, ResultCode::OK);
  EXPECT_EQ(calls[1].effects, std::vector<std::string>{"increased(total)"});
  EXPECT_EQ(calls[2].outcome, "refused");
  EXPECT_EQ(calls[2].code, ResultCode::INVALID);
  EXPECT_NE(calls[2].reason.find("values"), std::string::npos) << calls[2].reason;
  EXPECT_TRUE(calls[2].effects.empty());
  EXPECT_LE(calls[0].time, calls[2].time);

  // Filters: kind, since, limit; the KB's own start_run is a call of the run too.
  const auto commands = getCalls("counter", "command");
  ASSERT_EQ(commands.calls.size(), 1u);
  EXPECT_EQ(commands.calls[0].name, "count_to");
  const auto late = getCalls("counter", "", calls[2].time);
  ASSERT_FALSE(late.calls.empty());
  for (const auto& c : late.calls) EXPECT_GE(c.time, calls[2].time);
  EXPECT_EQ(late.calls.back().id, calls[2].id);
  EXPECT_LT(late.calls.size(), 3u);  // count_to ended before add_values was called
  const auto first = getCalls("counter", "", 0.0, 1);
  ASSERT_EQ(first.calls.size(), 1u);
  EXPECT_TRUE(first.truncated);
  EXPECT_EQ(first.calls[0].name, "count_to");
  // The KB's own start_run is among its calls with its effect (a get_calls of the warm-up may be stored before it).
  const auto kb_calls = getCalls("knowledge_base", "operation");
  const auto start_call = std::find_if(kb_calls.calls.begin(), kb_calls.calls.end(),
                                       [](const xpersif::CallRecord& c) { return c.name == "start_run"; });
  ASSERT_NE(start_call, kb_calls.calls.end());
  EXPECT_EQ(start_call->effects, std::vector<std::string>{"running(current_run)"});

  // Bad filters are refused with INVALID and a sentence naming the field; an unknown run is a precondition.
  const auto bad_kind = getCalls("counter", "lifecycle");
  EXPECT_FALSE(bad_kind.success);
  EXPECT_EQ(bad_kind.code, ResultCode::INVALID);
  EXPECT_NE(bad_kind.message.find("kind"), std::string::npos) << bad_kind.message;
  const auto too_many = getCalls("", "", 0.0, 100000);
  EXPECT_EQ(too_many.code, ResultCode::INVALID);
  EXPECT_NE(too_many.message.find("limit"), std::string::npos) << too_many.message;
  EXPECT_EQ(getCalls("", "", std::numeric_limits<double>::infinity()).code, ResultCode::INVALID);
  const auto no_such_run = getCalls("", "", 0.0, 0, 999);
  EXPECT_EQ(no_such_run.code, ResultCode::PRECONDITION_FAILED) << no_such_run.message;

  // Facts: the counter's total is one fact whatever how often it counted.
  EXPECT_TRUE(contains(facts(), "total(counter, 3)"));
  EXPECT_TRUE(contains(facts(), "increased(total)"));
  countTo(10.0);  // from 6: count_to's 3 and add_values' 1 + 2
  ASSERT_TRUE(waitFor([] { return contains(facts(), "total(counter, 10)"); }, 10.0));
  EXPECT_FALSE(contains(facts(), "total(counter, 3)"));

  // The planner: without the KB's facts the total must be counted to; with them it already holds.
  const auto blind = makePlan("total(counter, 10)", false);
  ASSERT_TRUE(blind.success) << blind.message;
  ASSERT_EQ(blind.steps.size(), 1u);
  EXPECT_EQ(blind.steps[0].operator_name, "count_to");
  const auto informed = makePlan("total(counter, 10)", true);
  ASSERT_TRUE(informed.success) << informed.message;
  EXPECT_TRUE(informed.steps.empty()) << informed.message;
  // A total the facts do not hold still needs the command.
  const auto further = makePlan("total(counter, 12)", true);
  ASSERT_TRUE(further.success) << further.message;
  EXPECT_EQ(further.steps.size(), 1u);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_kb_effects");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
