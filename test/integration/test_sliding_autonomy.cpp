// Sliding autonomy end to end (issue 14, item 2): the console client (`xpersif`) drives LOOPMODEL through
// confirm-each in both phases, `next`, pause and resume mid-experiment, `stop`, a good and a malformed
// `--plan` file, and `--resume`; the knowledge base is checked after each step. Object names come from the
// simulator's scene, never from a world file. Then a component put in ERROR between two confirmed experiments: the
// run stops before the next one naming it, and `--resume` goes on once it is configured again; put in ERROR during
// the last experiment, that experiment is stored failed with ROBOTMODEL's error first in its reason, cut in the middle
// when longer than the knowledge base keeps.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "ground_truth.h"
#include "test_helpers.h"
#include "xpersif/ComponentStatus.h"
#include "xpersif/GetExperiments.h"
#include "xpersif/GetScene.h"
#include "xpersif/RunLoopAction.h"

using xpersif_test::Recorder;
using xpersif_test::transition;
using xpersif_test::waitFor;

namespace {

const std::string ns = "/xpersif/";

/// Run the console with @p args to its end; its exit status, its output in @p out.
int console(const std::string& args, std::string* out = nullptr) {
  FILE* pipe = ::popen((std::string(XPERSIF_CONSOLE) + " " + args + " 2>&1").c_str(), "r");
  if (!pipe) return -1;
  std::string text;
  char buffer[512];
  while (std::fgets(buffer, sizeof buffer, pipe)) text += buffer;
  const int status = ::pclose(pipe);
  if (out) *out = text;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::vector<pid_t> spawned;  // ended at exit: a left-over run would keep rostest's output pipe open

/// Start `xpersif run ...` in the background, its output into @p log.
pid_t spawnRun(const std::string& args, const std::string& log) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::execl("/bin/sh", "sh", "-c", ("exec " + std::string(XPERSIF_CONSOLE) + " run " + args + " >" + log + " 2>&1 </dev/null").c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  spawned.push_back(pid);
  return pid;
}

/// The exit status of @p pid once it ends (-1 after @p timeout s).
int waitExit(pid_t pid, double timeout) {
  int status = 0;
  const bool ended = waitFor([&] { return ::waitpid(pid, &status, WNOHANG) == pid; }, timeout);
  if (!ended) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    return -1;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::vector<xpersif::ExperimentRecord> experiments(std::uint64_t run_id = 0) {
  xpersif::GetExperiments call;
  call.request.run_id = run_id;
  if (!ros::service::call(ns + "knowledge_base/get_experiments", call) || !call.response.success) return {};
  return call.response.experiments;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

class SlidingAutonomy : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string which;
    ASSERT_TRUE(waitFor([&] { return xpersif_test::allActive(ns, {"loop_model", "knowledge_base", "design_of_experiments",
                                                                    "execution", "manipulation", "xpersim"}, &which); },
                        180.0))
        << which << " did not become ACTIVE";
    xpersif::GetScene scene;
    ASSERT_TRUE(ros::service::call(ns + "xpersim/get_scene", scene) && scene.response.success);
    ASSERT_FALSE(scene.response.scene.objects.empty());
    objects_ = scene.response.scene.objects;
  }

  /// Wait until LOOPMODEL's progress says @p state.
  bool waitForState(Recorder<xpersif::RunLoopFeedback>& progress, const std::string& state, double timeout = 120.0) {
    return waitFor(
        [&] {
          const auto all = progress.messages();
          return !all.empty() && all.back().state == state;
        },
        timeout);
  }

  /// Wait until LOOPMODEL asks for confirmation with @p done experiments of its run done.
  bool waitForConfirmationAfter(Recorder<xpersif::RunLoopFeedback>& progress, std::uint32_t done, double timeout = 180.0) {
    return waitFor(
        [&] {
          const auto all = progress.messages();
          return !all.empty() && all.back().state == "waiting_for_confirmation" && all.back().experiment == done;
        },
        timeout);
  }

  std::vector<std::string> objects_;
};

}  // namespace

TEST_F(SlidingAutonomy, ConfirmNextPauseResumeStopPlanAndResumeThroughTheConsole) {
  ros::NodeHandle nh;
  Recorder<xpersif::RunLoopFeedback> progress(nh, ns + "loop_model/progress");
  const std::string object = objects_.front(), other = objects_.back();

  // ---- confirm-each: nothing happens until confirmed; `next` replaces the designed experiment ----
  const pid_t run = spawnRun("hands --experiments 3 --goals 1 --design random --seed 4 --confirm-each", "/tmp/xpersif_sa_1.log");
  ASSERT_TRUE(waitForState(progress, "waiting_for_confirmation")) << readFile("/tmp/xpersif_sa_1.log");
  ros::WallDuration(1.0).sleep();
  EXPECT_TRUE(experiments().empty()) << "an experiment ran before it was confirmed";
  ASSERT_EQ(console("next " + object + " -x 0.0 0.03"), 0);
  ASSERT_EQ(console("confirm"), 0);
  ASSERT_TRUE(waitFor([&] { return experiments().size() == 1; }, 60.0));
  auto stored = experiments();
  EXPECT_EQ(stored[0].design, "hand");
  EXPECT_EQ(stored[0].experiment.object, object);
  EXPECT_EQ(stored[0].experiment.side, "-x");
  EXPECT_DOUBLE_EQ(stored[0].experiment.distance, 0.03);
  // ---- pause mid-experiment: the running experiment finishes, the next one waits until resume ----
  ASSERT_TRUE(waitForState(progress, "waiting_for_confirmation"));
  ASSERT_EQ(console("confirm"), 0);
  ASSERT_EQ(console("pause"), 0);
  ASSERT_TRUE(waitFor([&] { return experiments().size() == 2; }, 60.0));
  ASSERT_TRUE(waitForState(progress, "paused", 30.0));
  std::string said;
  EXPECT_NE(console("confirm", &said), 0) << "a confirm while nothing waits must be refused: " << said;
  ros::WallDuration(2.0).sleep();
  EXPECT_EQ(experiments().size(), 2u) << "the loop went on while paused";
  EXPECT_EQ(experiments()[1].design, "random");
  ASSERT_EQ(console("resume"), 0);
  ASSERT_TRUE(waitForState(progress, "waiting_for_confirmation"));

  // ---- a hand-chosen experiment queued and then `stop`: the run ends stopped, the queue with it ----
  ASSERT_EQ(console("next " + other + " +y 0.0 0.02"), 0);
  ASSERT_EQ(console("stop"), 0);
  EXPECT_NE(waitExit(run, 60.0), 0) << "a stopped run ends unsuccessfully: " << readFile("/tmp/xpersif_sa_1.log");
  const auto run_id = experiments().empty() ? 0 : experiments().front().run_id;
  EXPECT_EQ(experiments(run_id).size(), 2u);

  // ---- --resume continues it (the console says so); confirm-each holds in the goal-directed phase too ----
  const pid_t resumed = spawnRun("hands --experiments 3 --goals 1 --design random --seed 4 --confirm-each --resume",
                                 "/tmp/xpersif_sa_2.log");
  ASSERT_TRUE(waitForState(progress, "waiting_for_confirmation"));
  ASSERT_EQ(console("confirm"), 0);
  ASSERT_TRUE(waitFor([&] { return experiments(run_id).size() == 3; }, 60.0));
  EXPECT_EQ(experiments(run_id)[2].design, "random") << "the hand-chosen experiment of the stopped run carried over";
  ASSERT_TRUE(waitForState(progress, "waiting_for_confirmation")) << "no confirmation asked before the goal";
  ASSERT_EQ(console("confirm"), 0);
  EXPECT_EQ(waitExit(resumed, 180.0), 0) << readFile("/tmp/xpersif_sa_2.log");
  const std::string resumed_log = readFile("/tmp/xpersif_sa_2.log");
  EXPECT_NE(resumed_log.find("resumed run " + std::to_string(run_id)), std::string::npos) << resumed_log;
  EXPECT_GE(experiments(run_id).size(), 3u);

  // ---- a plan file: its experiments first, in order; a malformed one is refused before anything starts ----
  const std::string plan = "/tmp/xpersif_sa_plan.txt", bad = "/tmp/xpersif_sa_bad_plan.txt";
  std::ofstream(plan) << "# object side offset distance\n" << other << " +x 0.0 0.02\n" << object << " -y 0.0 0.025\n";
  std::ofstream(bad) << object << " -x zero 0.02\n";
  EXPECT_EQ(console("run planned --experiments 2 --goals 0 --plan " + bad, &said), 2);
  EXPECT_NE(said.find(bad + ":1"), std::string::npos) << said;
  EXPECT_EQ(console("run planned --experiments 2 --goals 0 --plan " + plan, &said), 0) << said;
  stored = experiments();
  ASSERT_EQ(stored.size(), 2u);
  EXPECT_NE(stored[0].run_id, run_id);
  EXPECT_EQ(stored[0].experiment.object, other);
  EXPECT_EQ(stored[0].experiment.side, "+x");
  EXPECT_EQ(stored[1].experiment.object, object);
  EXPECT_EQ(stored[1].experiment.side, "-y");
  for (const auto& e : stored) EXPECT_EQ(e.design, "hand");
}

// Runs after the test above (gtest keeps their order): it leaves ROBOTMODEL configured again as it found it.
TEST_F(SlidingAutonomy, AComponentInErrorStopsTheRunWithItsCauseAndResumeGoesOnOnceItIsConfiguredAgain) {
  ros::NodeHandle nh;
  Recorder<xpersif::RunLoopFeedback> progress(nh, ns + "loop_model/progress");
  Recorder<xpersif::ComponentStatus> loop_status(nh, ns + "loop_model/status");
  const std::string log = "/tmp/xpersif_sa_3.log", args = "failing --experiments 3 --goals 0 --design random --seed 6 --confirm-each";
  const pid_t run = spawnRun(args, log);
  ASSERT_TRUE(waitForState(progress, "waiting_for_confirmation")) << readFile(log);
  ASSERT_EQ(console("confirm"), 0);
  ASSERT_TRUE(waitFor([&] { return experiments().size() == 1 && experiments()[0].design == "random"; }, 60.0)) << readFile(log);
  const std::uint64_t run_id = experiments()[0].run_id;
  ASSERT_TRUE(waitForConfirmationAfter(progress, 1)) << readFile(log);
  // A pause while it waits for a confirmation holds at once (it refuses a confirm then) and asks again once resumed.
  ASSERT_EQ(console("pause"), 0);
  ASSERT_TRUE(waitForState(progress, "paused", 30.0)) << "a pause while waiting for a confirmation was not honoured";
  std::string refused;
  EXPECT_NE(console("confirm", &refused), 0) << "a confirm while paused must be refused: " << refused;
  ASSERT_EQ(console("resume"), 0);
  ASSERT_TRUE(waitForConfirmationAfter(progress, 1)) << readFile(log);
  EXPECT_EQ(experiments(run_id).size(), 1u) << "an experiment ran while paused";

  // ROBOTMODEL taken down and configured with a part to omit that it does not have: it lands in ERROR, and its
  // parts stay INACTIVE. Each push would then be refused by MANIPULATION, downstream of the cause.
  const std::string omit = ns + "robot_model/omit";
  XmlRpc::XmlRpcValue omitted_before;
  const bool had_omit = ros::param::get(omit, omitted_before);
  const auto take_down_omitting = [&](const std::string& part) {
    ros::param::set(omit, std::vector<std::string>{part});
    ASSERT_TRUE(transition(ns + "robot_model", "deactivate").success);
  };
  take_down_omitting("no_such_part");
  const auto failed = transition(ns + "robot_model", "configure");
  ASSERT_FALSE(failed.success);
  ASSERT_EQ(failed.state, xpersif::ComponentStatus::ERROR) << failed.message;
  ASSERT_TRUE(waitFor(
      [&] {
        const auto all = loop_status.messages();
        if (all.empty()) return false;
        for (const auto& part : all.back().parts) {
          if (part.name == ns + "robot_model") return part.state == xpersif::ComponentStatus::ERROR;
        }
        return false;
      },
      30.0))
      << "LOOPMODEL never saw ROBOTMODEL in ERROR";
  ASSERT_EQ(console("confirm"), 0);
  EXPECT_EQ(waitExit(run, 60.0), 5) << "a failed component is a cause that repeats: " << readFile(log);
  const std::string said = readFile(log);
  EXPECT_NE(said.find(ns + "robot_model is in ERROR: configure failed: ~omit names no_such_part"), std::string::npos) << said;
  EXPECT_NE(said.find("the run stops before experiment 2"), std::string::npos) << said;
  EXPECT_EQ(said.find("needs component"), std::string::npos) << "the sentence names a refusal downstream: " << said;
  EXPECT_EQ(experiments(run_id).size(), 1u) << "an experiment ran, or one was lost, while ROBOTMODEL was in ERROR";

  // Configured again as it was, ROBOTMODEL brings its parts up, and the run resumes where it stopped.
  const auto configure_as_found = [&] {
    if (had_omit) {
      ros::param::set(omit, omitted_before);
    } else {
      ros::param::del(omit);
    }
    const auto mended = transition(ns + "robot_model", "configure");
    ASSERT_TRUE(mended.success) << mended.message;
    ASSERT_TRUE(transition(ns + "robot_model", "activate").success);
  };
  configure_as_found();
  const std::string resumed_log = "/tmp/xpersif_sa_4.log";
  const pid_t resumed = spawnRun(args + " --resume", resumed_log);
  ASSERT_TRUE(waitForConfirmationAfter(progress, 1)) << readFile(resumed_log);
  ASSERT_EQ(console("confirm"), 0);
  ASSERT_TRUE(waitFor([&] { return experiments(run_id).size() == 2u; }, 60.0)) << readFile(resumed_log);
  EXPECT_EQ(experiments(run_id)[1].status, "done") << experiments(run_id)[1].reason;

  // ROBOTMODEL goes to ERROR during experiment 3: the simulator's clock held once the loop is past its check, so
  // that the experiment cannot end before. It fails downstream, and its stored reason names the cause first. The
  // part's name is longer than the knowledge base keeps of a reason (4,096 bytes): the reason is stored cut in
  // the middle, its beginning and end kept, and the run goes on rather than ending on a refused record.
  ASSERT_TRUE(waitForConfirmationAfter(progress, 2)) << readFile(resumed_log);
  ASSERT_EQ(console("confirm"), 0);
  std_srvs::Trigger hold, go_on;
  ASSERT_TRUE(ros::service::call(ns + "xpersim/pause", hold) && hold.response.success) << hold.response.message;
  const std::string long_name = "no_such_part_" + std::string(5000, 'x');
  take_down_omitting(long_name);
  ASSERT_EQ(transition(ns + "robot_model", "configure").state, xpersif::ComponentStatus::ERROR);
  ASSERT_TRUE(ros::service::call(ns + "xpersim/resume", go_on) && go_on.response.success) << go_on.response.message;
  ASSERT_TRUE(waitFor([&] { return experiments(run_id).size() == 3u; }, 60.0)) << readFile(resumed_log);
  const auto third = experiments(run_id)[2];
  EXPECT_EQ(third.status, "failed");
  EXPECT_EQ(third.reason.rfind(ns + "robot_model is in ERROR: configure failed: ~omit names no_such_part", 0), 0u)
      << "the stored reason does not name the failed component first: " << third.reason;
  EXPECT_LE(third.reason.size(), 4096u);
  EXPECT_NE(third.reason.find("bytes left out"), std::string::npos) << third.reason.substr(0, 200);
  EXPECT_NE(third.reason.find("needs component"), std::string::npos)
      << "the downstream failure, at the reason's end, is kept: " << third.reason.substr(third.reason.size() - 300);
  EXPECT_NE(waitExit(resumed, 120.0), -1) << readFile(resumed_log);
  configure_as_found();
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "sliding_autonomy_tester");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  for (const pid_t pid : spawned) {
    ::kill(pid, SIGINT);
    waitExit(pid, 10.0);
  }
  ros::shutdown();
  return result;
}
