// The organizational base: loading, parametrizing and starting components through nodelet managers,
// noticing when a supervised component's manager dies, restarting it when the manager is back.
#include <gtest/gtest.h>
#include <ros/master.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <signal.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <cstdio>
#include <sys/wait.h>
#include <unistd.h>

#include "test_helpers.h"
#include "xpersif/GetState.h"
#include "xpersif/component/supervisor.h"

using xpersif::ComponentEvent;
using xpersif::ComponentStatus;
using xpersif_test::Recorder;
using xpersif_test::transition;
using xpersif_test::waitFor;

namespace {

// The process id of a node, asked through its XML-RPC API (as rosnode does).
int pidOf(const std::string& node) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = node;
  if (!ros::master::execute("lookupNode", args, result, payload, false)) return -1;
  std::string host;
  uint32_t port = 0;
  if (!ros::network::splitURI(static_cast<std::string>(payload), host, port)) return -1;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue pid_args, pid_result;
  pid_args[0] = ros::this_node::getName();
  if (!client.execute("getPid", pid_args, pid_result) || pid_result.size() < 3) return -1;
  return static_cast<int>(pid_result[2]);
}

bool partsActive(const ComponentStatus& s, std::size_t expected) {
  if (s.state != ComponentStatus::ACTIVE || s.parts.size() != expected) return false;
  for (const auto& p : s.parts) {
    if (p.state != ComponentStatus::ACTIVE || p.health != ComponentStatus::HEALTH_OK) return false;
  }
  return true;
}

std::uint8_t stateOf(const std::string& component) {
  xpersif::GetState call;
  if (!ros::service::call(component + "/get_state", call)) return 255;
  return call.response.state;
}

// Run the console client; return its exit code and put what it printed (stdout and stderr) in @p output.
int runConsole(const std::string& arguments, std::string* output) {
  // The console client is built next to this test, in the devel space's lib/xpersif.
  char self[4096] = {0};
  const ssize_t length = readlink("/proc/self/exe", self, sizeof self - 1);
  if (length <= 0) return -1;
  std::string directory(self, static_cast<std::size_t>(length));
  directory.resize(directory.rfind('/'));
  FILE* pipe = popen((directory + "/xpersif " + arguments + " 2>&1").c_str(), "r");
  if (!pipe) return -1;
  char buffer[512];
  output->clear();
  while (fgets(buffer, sizeof buffer, pipe)) *output += buffer;
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// A supervisor in this process, so that the test can ask what a command of its asks (Supervisor::waitUntilUp).
class InProcessSupervisor : public xpersif::Supervisor {
 public:
  InProcessSupervisor(const std::string& name, const std::string& component, const std::string& type,
                      const std::string& manager, double startup_timeout)
      : Supervisor(ros::NodeHandle(), ros::NodeHandle(name)) {
    XmlRpc::XmlRpcValue components;
    components[0]["name"] = component;
    components[0]["type"] = type;
    components[0]["manager"] = manager;
    ros::param::set(name + "/components", components);
    ros::param::set(name + "/startup_timeout", startup_timeout);
    start();
  }
  ~InProcessSupervisor() override { halt(); }
  using Supervisor::lastKnownState;
  using Supervisor::waitUntilUp;
};

// Start a nodelet manager named @p name as a process of its own; its pid.
pid_t startManager(const std::string& name) {
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string remap = "__name:=" + name;
    execlp("rosrun", "rosrun", "nodelet", "nodelet", "manager", remap.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

}  // namespace

class Supervision : public ::testing::Test {
 protected:
  ros::NodeHandle nh_;
};

TEST_F(Supervision, LoadsParametrizesAndStartsItsComponents) {
  Recorder<ComponentStatus> status(nh_, "/supervisor/status");
  ComponentStatus up;
  ASSERT_TRUE(status.waitForMatch([](const ComponentStatus& s) { return partsActive(s, 2); }, 60.0, &up))
      << "the supervisor and both supervised components become ACTIVE";
  EXPECT_EQ(up.parts[0].name, "/counter");
  EXPECT_EQ(up.parts[1].name, "/statistics");
  EXPECT_EQ(stateOf("/counter"), ComponentStatus::ACTIVE);
  double limit = 0;
  ASSERT_TRUE(ros::param::get("/counter/limit", limit));
  EXPECT_DOUBLE_EQ(limit, 50.0) << "the supervisor set the component's parameters before configuring it";
}

TEST_F(Supervision, SameClassRunsAsAStandaloneNode) {
  Recorder<ComponentStatus> status(nh_, "/standalone_counter/status");
  ComponentStatus s;
  ASSERT_TRUE(status.waitForMatch([](const ComponentStatus& m) { return m.state == ComponentStatus::ACTIVE; }, 30.0, &s));
  EXPECT_EQ(s.type, "xpersif/ExampleCounterNodelet");
}

TEST_F(Supervision, ConsoleClientShowsAndChangesStates) {
  std::string out;
  ASSERT_EQ(runConsole("wait --timeout 60 /supervisor", &out), 0) << out;
  ASSERT_EQ(runConsole("status", &out), 0) << out;
  EXPECT_NE(out.find("/counter"), std::string::npos) << out;
  EXPECT_NE(out.find("xpersif/ExampleStatisticsNodelet"), std::string::npos) << out;
  EXPECT_NE(out.find("extremes"), std::string::npos) << "parts are listed: " << out;

  EXPECT_EQ(runConsole("contracts /counter count_to", &out), 0) << out;
  EXPECT_NE(out.find("requires within_limit(?target)"), std::string::npos) << out;

  EXPECT_EQ(runConsole("deactivate /standalone_counter", &out), 0) << out;
  EXPECT_NE(out.find("INACTIVE"), std::string::npos) << out;
  EXPECT_EQ(runConsole("deactivate /standalone_counter", &out), 1);
  EXPECT_NE(out.find("only an ACTIVE component can be deactivated"), std::string::npos) << out;
  EXPECT_EQ(runConsole("activate /standalone_counter", &out), 0) << out;

  EXPECT_EQ(runConsole("wait --timeout 1 /nobody", &out), 1);
  EXPECT_NE(out.find("/nobody has not reported its status"), std::string::npos) << out;
  EXPECT_EQ(runConsole("fly /counter", &out), 2) << out;
}

TEST_F(Supervision, BadConfigurationIsRefusedWithTheReason) {
  ASSERT_TRUE(ros::service::waitForService("/bad_supervisor/configure", ros::Duration(30.0)));
  auto r = transition("/bad_supervisor", "configure");
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.state_name, "ERROR");
  EXPECT_NE(r.message.find("~components[0] has no 'manager'"), std::string::npos) << r.message;
}

TEST_F(Supervision, AComponentThatCannotBeStartedPutsTheSupervisorInErrorWithTheReason) {
  Recorder<ComponentStatus> status(nh_, "/broken_supervisor/status");
  ComponentStatus failed;
  ASSERT_TRUE(status.waitForMatch([](const ComponentStatus& s) { return s.state == ComponentStatus::ERROR; }, 60.0,
                                  &failed));
  EXPECT_NE(failed.last_error.find("could not start /ghost: manager /loop_manager could not load xpersif/NoSuchNodelet"),
            std::string::npos)
      << failed.last_error;
}

// A command of a supervisor just (re)started (LOOPMODEL's run, sent again by the console as soon as LOOPMODEL offers
// it) waits for the bring-up, however long its steps take, and otherwise says which component is not up and why.
TEST_F(Supervision, ACommandCanWaitUntilEveryComponentIsUpAndIsToldWhichIsNot) {
  InProcessSupervisor late("/waiting_supervisor", "late_counter", "xpersif/ExampleCounterNodelet", "late_manager", 120.0);
  EXPECT_NE(late.waitUntilUp(1.0, {}).find("is not supervising"), std::string::npos) << "not ACTIVE yet";
  ASSERT_TRUE(late.transition(xpersif::LifecycleTransition::Configure).success);
  ASSERT_TRUE(late.transition(xpersif::LifecycleTransition::Activate).success);
  // Its manager is not running yet: the bring-up waits for it (up to ~startup_timeout).
  std::string why = late.waitUntilUp(1.0, {});
  EXPECT_NE(why.find("/late_counter is still starting after 1 s"), std::string::npos) << why;
  why = late.waitUntilUp(60.0, [] { return true; });
  EXPECT_NE(why.find("stopped while /late_counter was starting"), std::string::npos) << why;

  const pid_t manager = startManager("late_manager");
  ASSERT_GT(manager, 0);
  why = late.waitUntilUp(90.0, {});
  EXPECT_EQ(why, "") << "the bring-up goes on once the manager answers";
  EXPECT_EQ(stateOf("/late_counter"), ComponentStatus::ACTIVE);
  kill(manager, SIGINT);
  waitpid(manager, nullptr, 0);

  InProcessSupervisor broken("/broken_waiting_supervisor", "ghost_too", "xpersif/NoSuchNodelet", "loop_manager", 5.0);
  ASSERT_TRUE(broken.transition(xpersif::LifecycleTransition::Configure).success);
  broken.transition(xpersif::LifecycleTransition::Activate);
  why = broken.waitUntilUp(90.0, {});
  EXPECT_NE(why.find("could not start /ghost_too: manager /loop_manager could not load xpersif/NoSuchNodelet"),
            std::string::npos)
      << why;
}

// A component whose configure never answers ends the bring-up after ~startup_timeout with its name, instead of holding
// it for good; and a supervisor supervising a supervisor is not up until the inner one's components are (seen live:
// ROBOTMODEL said ACTIVE while RELOCATION's configure hung, and LOOPMODEL's run waited for contracts that never came).
TEST_F(Supervision, AStuckConfigureFailsTheBringUpAndANestedBringUpIsWaitedFor) {
  InProcessSupervisor stuck("/stuck_supervisor", "stuck", "xpersif_test/StuckConfigureNodelet", "stuck_manager", 3.0);
  ASSERT_TRUE(stuck.transition(xpersif::LifecycleTransition::Configure).success);
  ASSERT_TRUE(stuck.transition(xpersif::LifecycleTransition::Activate).success);
  const ros::WallTime began = ros::WallTime::now();
  std::string why = stuck.waitUntilUp(60.0, {});
  EXPECT_NE(why.find("could not start /stuck: /stuck did not answer its configure within 3 s"), std::string::npos)
      << why;
  EXPECT_LT((ros::WallTime::now() - began).toSec(), 30.0) << "given up after ~startup_timeout, not the patience";

  // The inner supervisor is ACTIVE at once; its component's configure hangs; the outer one must not call that "up".
  XmlRpc::XmlRpcValue inner_components;
  inner_components[0]["name"] = "stuck_inner";
  inner_components[0]["type"] = "xpersif_test/StuckConfigureNodelet";
  inner_components[0]["manager"] = "stuck_manager";
  ros::param::set("/inner_supervisor/components", inner_components);
  ros::param::set("/inner_supervisor/startup_timeout", 3.0);
  InProcessSupervisor outer("/outer_supervisor", "inner_supervisor", "xpersif/SupervisorNodelet", "loop_manager", 20.0);
  ASSERT_TRUE(outer.transition(xpersif::LifecycleTransition::Configure).success);
  ASSERT_TRUE(outer.transition(xpersif::LifecycleTransition::Activate).success);
  why = outer.waitUntilUp(60.0, {});
  EXPECT_NE(why.find("/inner_supervisor is in ERROR: could not start /stuck_inner: /stuck_inner did not answer its "
                     "configure within 3 s"),
            std::string::npos)
      << why;
}

// A supervisor brought up again (LOOPMODEL restarted reconfigures ROBOTMODEL) finds its components ACTIVE or INACTIVE
// from before. Until its bring-up has passed them they are not up, and one supervising it must not call it up: a crash
// battery's take resumed its run 2 s into ROBOTMODEL's re-bring-up, and every push failed on an INACTIVE MANIPULATION.
TEST_F(Supervision, ASupervisorBroughtUpAgainIsNotUpUntilItsBringUpHasPassedEachComponent) {
  const auto set_inner_components = [](double configure_seconds) {
    XmlRpc::XmlRpcValue components;
    components[0]["name"] = "slow_again";
    components[0]["type"] = "xpersif_test/StuckConfigureNodelet";
    components[0]["manager"] = "loop_manager";  // (stuck_manager's threads are held by the stuck configures)
    components[0]["params"]["configure_seconds"] = configure_seconds;
    components[1]["name"] = "counter_again";
    components[1]["type"] = "xpersif/ExampleCounterNodelet";
    components[1]["manager"] = "loop_manager";
    ros::param::set("/again_inner/components", components);
    ros::param::set("/again_inner/startup_timeout", 20.0);
  };
  set_inner_components(0.0);
  InProcessSupervisor outer("/again_outer", "again_inner", "xpersif/SupervisorNodelet", "loop_manager", 20.0);
  ASSERT_TRUE(outer.transition(xpersif::LifecycleTransition::Configure).success);
  ASSERT_TRUE(outer.transition(xpersif::LifecycleTransition::Activate).success);
  ASSERT_EQ(outer.waitUntilUp(60.0, {}), "");

  // Again, with a first component whose configure now takes 4 s: the second waits, INACTIVE from the deactivate.
  Recorder<ComponentStatus> inner_status(nh_, "/again_inner/status");
  ASSERT_TRUE(inner_status.waitForConnection(5.0));
  set_inner_components(4.0);
  ASSERT_TRUE(outer.transition(xpersif::LifecycleTransition::Deactivate).success);
  ASSERT_TRUE(outer.transition(xpersif::LifecycleTransition::Configure).success);
  ASSERT_TRUE(outer.transition(xpersif::LifecycleTransition::Activate).success);
  ComponentStatus starting;
  ASSERT_TRUE(inner_status.waitForMatch(
      [](const ComponentStatus& s) {
        return s.state == ComponentStatus::ACTIVE && s.parts.size() == 2 && s.parts[0].state == ComponentStatus::INACTIVE;
      },
      3.0, &starting));
  EXPECT_EQ(starting.parts[1].state_name, "STARTING") << "its state: " << static_cast<int>(starting.parts[1].state);
  ros::WallDuration(0.5).sleep();  // the outer supervisor hears the same statuses
  const std::string why = outer.waitUntilUp(0.5, {});
  EXPECT_NE(why.find("/again_inner's /slow_again (STARTING)"), std::string::npos) << why;

  EXPECT_EQ(outer.waitUntilUp(60.0, {}), "") << "up once the bring-up has passed both";
  EXPECT_EQ(stateOf("/counter_again"), ComponentStatus::ACTIVE);
}

TEST_F(Supervision, NoticesAKilledManagerAndRestartsItsComponentsWhenTheManagerIsBack) {
  Recorder<ComponentStatus> status(nh_, "/supervisor/status");
  Recorder<ComponentEvent> events(nh_, "/supervisor/events");
  ASSERT_TRUE(status.waitForMatch([](const ComponentStatus& s) { return partsActive(s, 2); }, 60.0));
  ASSERT_TRUE(events.waitForConnection(10.0));

  const int pid = pidOf("/worker_manager");
  ASSERT_GT(pid, 0);
  const ros::WallTime killed = ros::WallTime::now();
  ASSERT_EQ(kill(pid, SIGKILL), 0);

  ComponentEvent lost;
  ASSERT_TRUE(events.waitForMatch(
      [](const ComponentEvent& e) {
        return e.kind == ComponentEvent::SUPERVISION && e.outcome == "lost" && e.name == "/counter";
      },
      10.0, &lost));
  const double noticed_after = (ros::WallTime::now() - killed).toSec();
  EXPECT_LT(noticed_after, 5.0) << "a 1 s heartbeat timeout notices within a second or two";
  EXPECT_NE(lost.reason.find("/counter sent no status for"), std::string::npos) << lost.reason;
  ROS_INFO_STREAM("noticed after " << noticed_after << " s: " << lost.reason);

  ComponentStatus reported;
  ASSERT_TRUE(status.waitForMatch(
      [](const ComponentStatus& s) {
        return s.health == ComponentStatus::HEALTH_WARN && s.parts.size() == 2 && s.parts[0].state_name == "LOST";
      },
      10.0, &reported));
  EXPECT_EQ(reported.parts[0].health, ComponentStatus::HEALTH_STALE);

  // roslaunch respawns the manager; the supervisor loads and starts the components again.
  for (const std::string name : {"/counter", "/statistics"}) {
    ASSERT_TRUE(events.waitForMatch(
        [&](const ComponentEvent& e) { return e.outcome == "restarted" && e.name == name; }, 60.0))
        << name << " was not restarted";
  }
  const ros::Time restarted = ros::Time(ros::WallTime::now().toSec());
  ASSERT_TRUE(status.waitForMatch(
      [&](const ComponentStatus& s) { return s.header.stamp > restarted && partsActive(s, 2); }, 30.0))
      << "after the restart the supervisor reports both components ACTIVE again";
  EXPECT_EQ(stateOf("/counter"), ComponentStatus::ACTIVE);
  double limit = 0;
  ASSERT_TRUE(ros::param::get("/counter/limit", limit));
  EXPECT_DOUBLE_EQ(limit, 50.0);
  EXPECT_NE(pidOf("/worker_manager"), pid);
}

// A manager that died and came back without its component (roslaunch's respawn) while the supervisor was ACTIVE:
// deactivating the supervisor must not wait ~startup_timeout for services that will never come (a crash-battery take:
// ROBOTMODEL's deactivate waited 30 s for OBSERVATION's, and the next components', and LOOPMODEL gave up after 60 s).
TEST_F(Supervision, ADeactivateDoesNotWaitForAComponentItsRespawnedManagerNoLongerHolds) {
  ros::param::set("/respawned_supervisor/restart", false);  // the monitor must not reload it first
  pid_t manager = startManager("respawned_manager");
  ASSERT_GT(manager, 0);
  InProcessSupervisor supervisor("/respawned_supervisor", "respawned_counter", "xpersif/ExampleCounterNodelet",
                                 "respawned_manager", 60.0);
  ASSERT_TRUE(supervisor.transition(xpersif::LifecycleTransition::Configure).success);
  ASSERT_TRUE(supervisor.transition(xpersif::LifecycleTransition::Activate).success);
  ASSERT_EQ(supervisor.waitUntilUp(90.0, {}), "");
  ASSERT_EQ(supervisor.lastKnownState("/respawned_counter"), xpersif::LifecycleState::Active);

  ASSERT_EQ(kill(manager, SIGKILL), 0);
  waitpid(manager, nullptr, 0);
  manager = startManager("respawned_manager");
  ASSERT_GT(manager, 0);
  ASSERT_TRUE(waitFor([] { return ros::service::exists("/respawned_manager/list", false); }, 60.0));

  const ros::WallTime began = ros::WallTime::now();
  EXPECT_TRUE(supervisor.transition(xpersif::LifecycleTransition::Deactivate).success);
  EXPECT_LT((ros::WallTime::now() - began).toSec(), 30.0) << "not ~startup_timeout (60 s) for a service never to come";

  // Activating again loads it into the new manager.
  ASSERT_TRUE(supervisor.transition(xpersif::LifecycleTransition::Activate).success);
  EXPECT_EQ(supervisor.waitUntilUp(90.0, {}), "");
  EXPECT_EQ(stateOf("/respawned_counter"), ComponentStatus::ACTIVE);
  kill(manager, SIGINT);
  waitpid(manager, nullptr, 0);
}

TEST_F(Supervision, ShutdownExitsAndUnloadsTheComponents) {
  Recorder<ComponentStatus> status(nh_, "/supervisor/status");
  ASSERT_TRUE(status.waitForMatch([](const ComponentStatus& s) { return partsActive(s, 2); }, 60.0));
  auto r = transition("/supervisor", "shutdown");
  EXPECT_TRUE(r.success) << r.message;
  EXPECT_TRUE(waitFor([] { return !ros::service::exists("/counter/get_state", false); }, 10.0))
      << "the supervised components were unloaded from their manager";
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_supervision");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
