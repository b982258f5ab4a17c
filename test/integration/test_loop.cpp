// The whole system: LOOPMODEL brings up XPERSim, the embodiment, the knowledge base and the loop's
// components; a short run goes through every state; with --kill, the knowledge base's manager is killed
// (SIGKILL) mid-run, respawned and restarted by LOOPMODEL, and the run still completes with nothing lost, although
// a lockstep participant of the test's own wants time (the world is moving) while LOOPMODEL puts the world back
// and looks at the scene.
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <algorithm>
#include <optional>
#include <csignal>
#include <functional>
#include <set>
#include <thread>

#include "ground_truth.h"
#include "test_helpers.h"
#include "xpersif/ComponentEvent.h"
#include "xpersif/ChooseFeatures.h"
#include "xpersif/ExecutePlanAction.h"
#include "xpersif/ExperimentRecord.h"
#include "xpersif/GetCalls.h"
#include "xpersif/GetExperiments.h"
#include "xpersif/GetFacts.h"
#include "xpersif/GetNotions.h"
#include "xpersif/GetState.h"
#include "xpersif/LearnedModel.h"
#include "xpersif/Motivation.h"
#include "xpersif/ResultCode.h"
#include "xpersif/RunLoopAction.h"
#include "xpersif/UseFeatures.h"
#include "xpersif/component/lockstep_client.h"

using xpersif_test::Recorder;
using xpersif_test::waitFor;

namespace {

const std::string ns = "/xpersif/";
bool kill_mid_run = false;
const std::vector<std::string> kComponents = {"loop_model", "xpersim", "robot_model", "knowledge_base",
                                              "machine_learning", "motivation", "design_of_experiments",
                                              "planner", "execution", "goal_design", "relocation",
                                              "manipulation", "observation", "vision", "perception"};

/// The process id of a node, through its own XML-RPC API.
int pidOf(const std::string& node) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = node;
  if (!ros::master::execute("lookupNode", args, result, payload, true)) return -1;
  std::string uri = payload;
  const std::string host = uri.substr(7, uri.rfind(':') - 7);
  const int port = std::stoi(uri.substr(uri.rfind(':') + 1));
  XmlRpc::XmlRpcClient client(host.c_str(), port, "/");
  XmlRpc::XmlRpcValue request, response;
  request[0] = ros::this_node::getName();
  if (!client.execute("getPid", request, response) || response.size() < 3) return -1;
  return static_cast<int>(response[2]);
}

/// A lockstep participant of the test's own that wants simulated time until @p done (the world keeps moving, as a
/// user's controller makes it), on a thread joined however the test ends.
class BusyParticipant {
 public:
  explicit BusyParticipant(std::function<bool()> done)
      : thread_([done] {
          try {
            xpersif::LockstepClient participant(ros::NodeHandle(ns), ros::NodeHandle("~"), "loop_tester_busy", false);
            participant.sleepFor(ros::Duration(1e6), done);
          } catch (const std::exception& e) {
            ADD_FAILURE() << "the test's participant could not take part: " << e.what();
          }
        }) {}
  ~BusyParticipant() { thread_.join(); }

 private:
  std::thread thread_;
};

/// The arguments of a ground literal "p(a, (b, c), d)": {"a", "(b, c)", "d"}.
std::vector<std::string> argumentsOf(const std::string& literal) {
  std::vector<std::string> args(1);
  int depth = 0;
  for (std::size_t i = literal.find('(') + 1; i + 1 < literal.size(); ++i) {
    const char c = literal[i];
    depth += c == '(' ? 1 : c == ')' ? -1 : 0;
    if (c == ',' && depth == 0) {
      args.emplace_back();
    } else if (!(c == ' ' && args.back().empty())) {
      args.back() += c;
    }
  }
  return args;
}

/// The items of a tuple argument "(a, b)"; none for "none".
std::vector<std::string> itemsOf(const std::string& tuple) {
  if (tuple == "none") return {};
  return argumentsOf("t" + tuple);
}

/// The fact of @p predicate (and, if given, @p subject) among @p facts, or "".
std::string factOf(const std::vector<std::string>& facts, const std::string& predicate, const std::string& subject = "") {
  for (const auto& f : facts) {
    if (f.rfind(predicate + "(", 0) == 0 && (subject.empty() || argumentsOf(f).front() == subject)) return f;
  }
  return "";
}

}  // namespace

TEST(Loop, AShortRunLearnsAndIsRecorded) {
  ros::NodeHandle nh;
  std::string which;
  ASSERT_TRUE(waitFor([&] { return xpersif_test::allActive(ns, kComponents, &which); }, 180.0)) << which << " did not become ACTIVE";
  Recorder<xpersif::ExperimentRecord> records(nh, ns + "knowledge_base/experiments");
  Recorder<xpersif::Motivation> motivation(nh, ns + "motivation/motivation");
  Recorder<xpersif::ComponentEvent> events(nh, ns + "loop_model/events");
  Recorder<xpersif::LearnedModel> models(nh, ns + "machine_learning/model");

  actionlib::SimpleActionClient<xpersif::RunLoopAction> client(ns + "loop_model/run", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(30.0)));
  xpersif::RunLoopGoal goal;
  goal.name = kill_mid_run ? "survives" : "short";
  // FEATURESELECTION chooses once the run has its first 4 experiments (loop.test's ~select_features_after): the
  // short run's fifth experiment and its goal use the choice. The run of 4 with --kill goes no further: no choice.
  goal.experiments = kill_mid_run ? 4 : 5;
  goal.goals = kill_mid_run ? 0 : 1;
  goal.design = "random";
  goal.seed = 5;
  // A bad goal is rejected with the unmet precondition, and changes nothing.
  xpersif::RunLoopGoal bad = goal;
  bad.design = "astrology";
  client.sendGoal(bad);
  ASSERT_TRUE(client.waitForResult(ros::Duration(20.0)));
  EXPECT_EQ(client.getState(), actionlib::SimpleClientGoalState::REJECTED);
  EXPECT_NE(client.getState().getText().find("valid_run"), std::string::npos) << client.getState().getText();

  client.sendGoal(goal);
  std::optional<BusyParticipant> busy;  // --kill: a participant that wants time while the world is put back
  if (kill_mid_run) {
    ASSERT_TRUE(waitFor([&] { return !records.messages().empty(); }, 300.0)) << "no experiment recorded";
    const int pid = pidOf(ns + "kb_manager");
    ASSERT_GT(pid, 0);
    ASSERT_EQ(::kill(pid, SIGKILL), 0);
    // While LOOPMODEL waits for the knowledge base and then puts the world back for the experiment again, another
    // participant wants time (as a paused XPERSim or a slow controller makes one do): XPERSim refuses to restore a
    // moving world, and no frame comes until it stands; the loop must wait for that rather than end the run.
    const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(20.0);
    busy.emplace([until] { return ros::WallTime::now() > until; });
  }
  ASSERT_TRUE(client.waitForResult(ros::Duration(600.0)));
  ASSERT_EQ(client.getState(), actionlib::SimpleClientGoalState::SUCCEEDED) << client.getState().getText();
  const auto result = client.getResult();
  EXPECT_EQ(result->experiments_done + result->experiments_failed, goal.experiments);
  EXPECT_GE(result->experiments_done, 2u) << result->message;

  // The knowledge base has every experiment once, in order, with the world before and after.
  xpersif::GetExperiments stored;
  stored.request.run_id = result->run_id;
  ASSERT_TRUE(waitFor([&] { return ros::service::call(ns + "knowledge_base/get_experiments", stored) && stored.response.success; }, 30.0));
  std::set<std::uint32_t> seqs;
  for (const auto& r : stored.response.experiments) {
    EXPECT_TRUE(seqs.insert(r.seq).second) << "experiment " << r.seq << " stored twice";
    if (r.status == "done") {
      EXPECT_FALSE(r.before.objects.empty());
      EXPECT_FALSE(r.after.objects.empty());
      EXPECT_EQ(r.predicted_mean.size(), 3u);
    }
  }
  // Designed experiments first (seq 1..N), then the goal-directed pushes; none lost, none twice.
  EXPECT_GE(stored.response.experiments.size(), goal.experiments);
  for (std::uint32_t seq = 1; seq <= goal.experiments; ++seq) EXPECT_TRUE(seqs.count(seq)) << "experiment " << seq << " lost";
  if (goal.goals == 0) {
    EXPECT_EQ(stored.response.experiments.size(), goal.experiments);
  }
  // MOTIVATION spoke after the experiments it saw (those before a kill may have been missed by this recorder).
  EXPECT_FALSE(motivation.messages().empty());
  // The run's command went through: events mirror it.
  EXPECT_TRUE(waitFor(
      [&] {
        for (const auto& e : events.messages()) {
          if (e.kind == xpersif::ComponentEvent::COMMAND && e.name == "run" && e.outcome == "succeeded") return true;
        }
        return false;
      },
      5.0));
  // Something was learned: MACHINELEARNING's model of this run has seen every successful experiment, and its
  // predictions changed as it learned (the first experiment was predicted by an empty model).
  std::size_t done_records = 0;
  for (const auto& r : stored.response.experiments) done_records += r.status == "done";
  EXPECT_TRUE(waitFor(
      [&] {
        for (const auto& m : models.messages()) {
          if (m.run_id == result->run_id && m.samples >= done_records) return true;
        }
        return false;
      },
      30.0))
      << "no model of run " << result->run_id << " has learned its " << done_records << " experiments";
  std::set<std::vector<double>> predictions;
  for (const auto& r : stored.response.experiments) {
    if (r.status == "done") predictions.insert(r.predicted_mean);
  }
  EXPECT_GE(predictions.size(), 2u) << "every experiment was predicted the same: nothing was learned";
  xpersif::GetNotions notions;
  notions.request.run_id = result->run_id;
  EXPECT_TRUE(ros::service::call(ns + "knowledge_base/get_notions", notions));
  EXPECT_TRUE(notions.response.success) << notions.response.message;

  // FEATURESELECTION's choice, through the running components, as the knowledge base keeps it.
  const std::uint32_t after = 4;
  std::size_t rankable = 0;  // done experiments among the first ones (every candidate is measured by the camera)
  for (const auto& r : stored.response.experiments) rankable += r.seq <= after && r.status == "done";
  xpersif::GetFacts facts;
  facts.request.run_id = result->run_id;
  ASSERT_TRUE(ros::service::call(ns + "knowledge_base/get_facts", facts) && facts.response.success)
      << facts.response.message;
  const std::string learns = factOf(facts.response.facts, "learns_from", "machine_learning");
  const std::string selected = factOf(facts.response.facts, "selected", "vision");
  ASSERT_FALSE(learns.empty()) << "MACHINELEARNING was never told what to learn from";
  ASSERT_FALSE(selected.empty()) << "VISION's selection was never set";
  const std::vector<std::string> selection = itemsOf(argumentsOf(selected)[1]);
  if (kill_mid_run) {
    // A run that ends with its 4th experiment has nothing to use a choice for: it learned from ~features.
    EXPECT_EQ(factOf(facts.response.facts, "features_chosen", std::to_string(result->run_id)), "");
    EXPECT_EQ(learns, "learns_from(machine_learning, (hue, size))");
  } else if (rankable >= 4) {
    const std::string chosen = factOf(facts.response.facts, "features_chosen", std::to_string(result->run_id));
    const std::string scores = factOf(facts.response.facts, "feature_scores", std::to_string(result->run_id));
    ASSERT_FALSE(chosen.empty()) << "no choice stored although " << rankable << " experiments could be ranked on";
    ASSERT_FALSE(scores.empty());
    EXPECT_EQ(argumentsOf(chosen)[2], std::to_string(after)) << chosen;
    const std::vector<std::string> names = itemsOf(argumentsOf(chosen)[1]);
    EXPECT_LE(names.size(), 2u) << chosen;  // FEATURESELECTION's ~count
    // Every candidate scored (the object's own features: hue, saturation, colours, size, area, elongation).
    EXPECT_EQ(itemsOf(argumentsOf(scores)[1]).size(), 8u) << scores;
    // MACHINELEARNING learns from exactly the choice; VISION extracts it beside its ~features.
    EXPECT_EQ(itemsOf(argumentsOf(learns)[1]), names) << learns << " vs " << chosen;
    for (const auto& n : names) {
      EXPECT_NE(std::find(selection.begin(), selection.end(), n), selection.end()) << n << " not in " << selected;
    }
    // The experiments after the choice carry VISION's new selection; the last model learns from the choice.
    for (const auto& r : stored.response.experiments) {
      if (r.seq <= after || r.status != "done") continue;
      // (The knowledge base keeps an object's features by name: compare as sets.)
      const std::set<std::string> wanted(selection.begin(), selection.end());
      for (const auto& o : r.before.objects) {
        EXPECT_EQ(std::set<std::string>(o.feature_names.begin(), o.feature_names.end()), wanted) << "experiment " << r.seq;
      }
    }
    bool modelled = false;
    for (const auto& m : models.messages()) {
      if (m.run_id == result->run_id) modelled = m.features == names;
    }
    EXPECT_TRUE(modelled) << "the last model of the run does not learn from " << chosen;
  } else {
    // Too few experiments to rank on: the call failed with its code and sentence, the run kept its features.
    xpersif::GetCalls calls;
    calls.request.run_id = result->run_id;
    calls.request.component = "feature_selection";
    ASSERT_TRUE(ros::service::call(ns + "knowledge_base/get_calls", calls) && calls.response.success);
    bool failed = false;
    for (const auto& c : calls.response.calls) {
      failed = failed || (c.name == "choose_features" && c.code == xpersif::ResultCode::FAILED &&
                          c.reason.find("ranking needs at least 4") != std::string::npos);
    }
    EXPECT_TRUE(failed) << "only " << rankable << " experiments to rank on, and no failed choose_features stored";
    EXPECT_EQ(learns, "learns_from(machine_learning, (hue, size))");
  }
  // Bad input gets a code and a sentence, and changes nothing.
  xpersif::ChooseFeatures bad_choice;
  bad_choice.request.run_id = result->run_id;
  bad_choice.request.experiments = after;
  bad_choice.request.candidates = {"hue", "x"};
  ASSERT_TRUE(ros::service::call(ns + "feature_selection/choose_features", bad_choice));
  EXPECT_EQ(bad_choice.response.code, xpersif::ResultCode::INVALID);
  EXPECT_NE(bad_choice.response.message.find("candidates[1] 'x' is not a candidate"), std::string::npos)
      << bad_choice.response.message;
  bad_choice.request.candidates = {};
  bad_choice.request.run_id = 0;
  ASSERT_TRUE(ros::service::call(ns + "feature_selection/choose_features", bad_choice));
  EXPECT_EQ(bad_choice.response.code, xpersif::ResultCode::INVALID) << bad_choice.response.message;
  xpersif::UseFeatures bad_use;
  bad_use.request.names = {"hue", "weight"};
  ASSERT_TRUE(ros::service::call(ns + "machine_learning/use_features", bad_use));
  EXPECT_EQ(bad_use.response.code, xpersif::ResultCode::INVALID);
  EXPECT_NE(bad_use.response.message.find("weight"), std::string::npos) << bad_use.response.message;
  facts.response = {};
  ASSERT_TRUE(ros::service::call(ns + "knowledge_base/get_facts", facts) && facts.response.success);
  EXPECT_EQ(factOf(facts.response.facts, "learns_from", "machine_learning"), learns);
  EXPECT_EQ(factOf(facts.response.facts, "selected", "vision"), selected);

  EXPECT_TRUE(waitFor([&] { return xpersif_test::allActive(ns, kComponents, &which); }, 60.0)) << which << " is not ACTIVE after the run";
}

// EXECUTION runs no command while it observes: in lockstep, simulated time that moves then is another participant's,
// and no frame comes until the world stands. An observation step waits for that (the world moves for many times
// ~fresh_timeout of simulated time here) rather than fail a step nobody did wrong.
TEST(Loop, AnObservationStepWaitsWhileAnotherParticipantMovesTheWorld) {
  if (kill_mid_run) GTEST_SKIP() << "loop.test covers it";
  ASSERT_TRUE(waitFor([] { return ros::Time::now().toSec() > 0; }, 60.0));
  actionlib::SimpleActionClient<xpersif::ExecutePlanAction> client(ns + "execution/execute_plan", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(60.0)));
  const double fresh_timeout = ros::param::param(ns + "execution/fresh_timeout", 5.0);  // s of simulated time
  const ros::Time before = ros::Time::now();
  const double moves = 3 * fresh_timeout;  // s of simulated time the participant moves the world for
  xpersif::ExecutePlanGoal goal;
  xpersif::PlanStep observe;
  observe.component = "vision";
  observe.operator_name = "get_features";
  observe.interface_type = "xpersif/GetFeatures";
  goal.steps = {observe};
  goal.retries = 0;  // one attempt: a step that gives up fails the goal
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(120.0);
  {
    BusyParticipant busy([&] { return (ros::Time::now() - before).toSec() > moves || ros::WallTime::now() > give_up; });
    ASSERT_TRUE(waitFor([&] { return (ros::Time::now() - before).toSec() > 2.0; }, 30.0)) << "the world does not move";
    client.sendGoal(goal);  // VISION's latest vector is older than EXECUTION's ~max_age (1 s) now
  }
  ASSERT_GT((ros::Time::now() - before).toSec(), moves) << "the participant gave up before the world moved enough";
  ASSERT_TRUE(client.waitForResult(ros::Duration(120.0)));
  ASSERT_EQ(client.getState(), actionlib::SimpleClientGoalState::SUCCEEDED) << client.getState().getText();
  ASSERT_EQ(client.getResult()->observations.size(), 1u);
  EXPECT_GT(client.getResult()->observations[0].header.stamp.toSec(), before.toSec() + moves)
      << "the observation is older than the world the participant left";
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "loop_tester");
  for (int i = 1; i < argc; ++i) kill_mid_run = kill_mid_run || std::string(argv[i]) == "--kill";
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
