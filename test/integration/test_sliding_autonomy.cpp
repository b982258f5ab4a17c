// Sliding autonomy end to end (issue 14, item 2): the console client (`xpersif`) drives LOOPMODEL through
// confirm-each in both phases, `next`, pause and resume mid-experiment, `stop`, a good and a malformed
// `--plan` file, and `--resume`; the knowledge base is checked after each step. Object names come from the
// simulator's scene, never from a world file.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "ground_truth.h"
#include "test_helpers.h"
#include "xpersif/GetExperiments.h"
#include "xpersif/GetScene.h"
#include "xpersif/RunLoopAction.h"

using xpersif_test::Recorder;
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
