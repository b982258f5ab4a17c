// The whole system: LOOPMODEL brings up XPERSim, the embodiment, the knowledge base and the loop's
// components; a short run goes through every state; with --kill, the knowledge base's manager is killed
// (SIGKILL) mid-run, respawned and restarted by LOOPMODEL, and the run still completes with nothing lost.
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <csignal>
#include <set>

#include "ground_truth.h"
#include "test_helpers.h"
#include "xpersif/ComponentEvent.h"
#include "xpersif/ExperimentRecord.h"
#include "xpersif/GetExperiments.h"
#include "xpersif/GetNotions.h"
#include "xpersif/GetState.h"
#include "xpersif/LearnedModel.h"
#include "xpersif/Motivation.h"
#include "xpersif/RunLoopAction.h"

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
  goal.experiments = kill_mid_run ? 4 : 3;
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
  if (kill_mid_run) {
    ASSERT_TRUE(waitFor([&] { return !records.messages().empty(); }, 300.0)) << "no experiment recorded";
    const int pid = pidOf(ns + "kb_manager");
    ASSERT_GT(pid, 0);
    ASSERT_EQ(::kill(pid, SIGKILL), 0);
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
  if (goal.goals == 0) EXPECT_EQ(stored.response.experiments.size(), goal.experiments);
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
  EXPECT_TRUE(waitFor([&] { return xpersif_test::allActive(ns, kComponents, &which); }, 60.0)) << which << " is not ACTIVE after the run";
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
