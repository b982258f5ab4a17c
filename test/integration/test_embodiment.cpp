// The embodiment, driven through its real interfaces: XPERSim and ROBOTMODEL's components in their managers
// (launch/embodiment.launch), every command and operation, cancels and rejected goals, checked against the
// simulator's ground truth (which the components themselves never read).
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_msgs/UInt64MultiArray.h>
#include <std_srvs/Trigger.h>

#include <cmath>
#include <map>

#include "ground_truth.h"
#include "test_helpers.h"
#include "xpersif/BodyPoses.h"
#include "xpersif/GetFeatures.h"
#include "xpersif/GetRobotState.h"
#include "xpersif/GetState.h"
#include "xpersif/GoToPoseAction.h"
#include "xpersif/PushAction.h"
#include "xpersif/ReadIr.h"
#include "xpersif/SelectFeatures.h"
#include "xpersif/SetMaxVelocity.h"
#include "xpersif/SetPose.h"
#include "xpersif/TurnToAction.h"

using xpersif_test::Recorder;
using xpersif_test::waitFor;
using xpersif_test::GroundTruth;
using xpersif_test::Planar;
using xpersif_test::wrap;

namespace {

const std::string ns = "/xpersif/";
const std::vector<std::string> kComponents = {"robot_model", "feature_selection", "observation", "vision",
                                              "perception", "relocation", "manipulation", "feature_extraction"};

template <class Action>
using Client = actionlib::SimpleActionClient<Action>;

class Embodiment : public ::testing::Test {
 protected:
  // A failed ASSERT in SetUpTestSuite would only skip the tests, and skipped tests pass: the wait's verdict is
  // kept and every test's SetUp fails on it.
  static void SetUpTestSuite() {
    std::string which;
    if (!waitFor([&] { return xpersif_test::allActive(ns, kComponents, &which); }, 90.0)) {
      not_active_ = which + " did not become ACTIVE within 90 s";
    }
  }
  static inline std::string not_active_;

  void SetUp() override {
    ASSERT_TRUE(not_active_.empty()) << not_active_;
    truth_ = std::make_unique<GroundTruth>(nh_);
    ASSERT_TRUE(waitFor([&] { return truth_->ready(); }, 20.0));
    // A fresh observation must exist before goals are sent (the commands' preconditions need it).
    ASSERT_TRUE(waitFor([&] { return xpersif_test::featuresFresh(ns + "observation/get_features"); }, 30.0));
  }

  /// Put the robot (or an object) somewhere, through XPERSim's set_pose operation.
  void place(const std::string& body, double x, double y, double yaw) {
    const std::string why = xpersif_test::place(ns, body, x, y, yaw);
    ASSERT_TRUE(why.empty()) << why;
  }

  template <class Action, class Goal>
  actionlib::SimpleClientGoalState run(Client<Action>& client, const Goal& goal, double timeout = 120.0) {
    EXPECT_TRUE(client.waitForServer(ros::Duration(20.0)));
    client.sendGoal(goal);
    EXPECT_TRUE(client.waitForResult(ros::Duration(timeout))) << "no result in " << timeout << " s";
    return client.getState();
  }

  ros::NodeHandle nh_;
  std::unique_ptr<GroundTruth> truth_;
};

xpersif::GoToPoseGoal goTo(double x, double y, double yaw, const std::string& source = "") {
  xpersif::GoToPoseGoal g;
  g.target.x = x;
  g.target.y = y;
  g.target.theta = yaw;
  g.pose_source = source;
  return g;
}

xpersif::PushGoal push(const std::string& object, const std::string& side, double offset, double distance) {
  xpersif::PushGoal g;
  g.object = object;
  g.side = side;
  g.offset = offset;
  g.distance = distance;
  return g;
}

}  // namespace

TEST_F(Embodiment, GoToPoseReachesPosesWithin1cmAnd3Degrees) {
  Client<xpersif::GoToPoseAction> client(ns + "relocation/go_to_pose", true);
  const std::vector<Planar> targets = {{-0.3, -0.2, 1.2}, {-0.1, 0.2, -2.5}, {-0.35, 0.0, 0.0}};
  for (const auto& t : targets) {
    const auto state = run(client, goTo(t.x, t.y, t.yaw));
    ASSERT_EQ(state, actionlib::SimpleClientGoalState::SUCCEEDED) << state.getText();
    ros::Duration(0.2).sleep();
    const Planar p = truth_->pose("khepera");
    EXPECT_LT(std::hypot(p.x - t.x, p.y - t.y), 0.01) << "at " << p.x << ", " << p.y;
    EXPECT_LT(std::abs(wrap(p.yaw - t.yaw)), 3 * M_PI / 180) << "yaw " << p.yaw;
  }
}

TEST_F(Embodiment, GoToPoseOnTheOverheadCameraAlsoArrives) {
  Client<xpersif::GoToPoseAction> client(ns + "relocation/go_to_pose", true);
  const auto state = run(client, goTo(-0.25, 0.15, 0.5, "observation"));
  ASSERT_EQ(state, actionlib::SimpleClientGoalState::SUCCEEDED) << state.getText();
  ros::Duration(0.2).sleep();
  const Planar p = truth_->pose("khepera");
  EXPECT_LT(std::hypot(p.x + 0.25, p.y - 0.15), 0.01);
  EXPECT_LT(std::abs(wrap(p.yaw - 0.5)), 3 * M_PI / 180);
}

TEST_F(Embodiment, BadGoalsAreRejectedWithTheUnmetPreconditionAndNothingMoves) {
  Client<xpersif::GoToPoseAction> client(ns + "relocation/go_to_pose", true);
  ros::Duration(0.3).sleep();
  const Planar before = truth_->pose("khepera");
  struct Case {
    xpersif::GoToPoseGoal goal;
    std::string says;
  };
  const std::vector<Case> cases = {{goTo(NAN, 0, 0), "finite"},
                                   {goTo(0, 0, INFINITY), "finite"},
                                   {goTo(2.0, 0, 0), "in_arena"},
                                   {goTo(0.25, 0.0, 0), "reachable"},  // the blue cube stands there
                                   {goTo(0, 0, 0, "gps"), "pose_source"}};
  for (const auto& c : cases) {
    const auto state = run(client, c.goal, 20.0);
    EXPECT_EQ(state, actionlib::SimpleClientGoalState::REJECTED) << c.says;
    EXPECT_NE(state.getText().find(c.says), std::string::npos) << state.getText();
  }
  const Planar after = truth_->pose("khepera");
  EXPECT_LT(std::hypot(after.x - before.x, after.y - before.y), 1e-3);
}

TEST_F(Embodiment, CancelStopsTheRobotAtOnce) {
  Client<xpersif::GoToPoseAction> client(ns + "relocation/go_to_pose", true);
  ASSERT_EQ(run(client, goTo(-0.35, -0.2, 0.0)), actionlib::SimpleClientGoalState::SUCCEEDED);
  client.sendGoal(goTo(-0.35, 0.2, M_PI / 2));
  ASSERT_TRUE(waitFor([&] { return truth_->speed("khepera") > 0.03; }, 20.0)) << "the robot did not start";
  client.cancelGoal();
  ASSERT_TRUE(client.waitForResult(ros::Duration(5.0)));
  EXPECT_EQ(client.getState(), actionlib::SimpleClientGoalState::PREEMPTED);
  // One control period (20 ms) plus the motors' own deceleration: at rest within a fraction of a second.
  EXPECT_TRUE(waitFor([&] { return truth_->speed("khepera") < 0.005; }, 1.0)) << truth_->speed("khepera");
}

TEST_F(Embodiment, StopOperationEndsTheRunningCommand) {
  Client<xpersif::GoToPoseAction> client(ns + "relocation/go_to_pose", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(20.0)));
  client.sendGoal(goTo(-0.1, -0.2, 0.0));
  ASSERT_TRUE(waitFor([&] { return truth_->speed("khepera") > 0.03; }, 20.0));
  std_srvs::Trigger stop;
  ASSERT_TRUE(ros::service::call(ns + "relocation/stop", stop));
  EXPECT_TRUE(stop.response.success) << stop.response.message;
  ASSERT_TRUE(client.waitForResult(ros::Duration(5.0)));
  EXPECT_EQ(client.getState(), actionlib::SimpleClientGoalState::ABORTED);
  EXPECT_NE(client.getState().getText().find("stop operation"), std::string::npos) << client.getState().getText();
  EXPECT_TRUE(waitFor([&] { return truth_->speed("khepera") < 0.005; }, 1.0));
}

TEST_F(Embodiment, TurnToAndSetMaxVelocity) {
  xpersif::SetMaxVelocity limit;
  limit.request.linear = NAN;
  limit.request.angular = 1.0;
  ASSERT_TRUE(ros::service::call(ns + "relocation/set_max_velocity", limit));
  EXPECT_FALSE(limit.response.success);
  EXPECT_NE(limit.response.message.find("linear"), std::string::npos) << limit.response.message;
  limit.request.linear = -0.1;
  ASSERT_TRUE(ros::service::call(ns + "relocation/set_max_velocity", limit));
  EXPECT_FALSE(limit.response.success);
  limit.request.linear = 0.08;
  limit.request.angular = 1.5;
  ASSERT_TRUE(ros::service::call(ns + "relocation/set_max_velocity", limit));
  EXPECT_TRUE(limit.response.success) << limit.response.message;
  EXPECT_DOUBLE_EQ(limit.response.linear, 0.08);

  Client<xpersif::TurnToAction> client(ns + "relocation/turn_to", true);
  xpersif::TurnToGoal goal;
  goal.heading = -1.2;
  const auto state = run(client, goal);
  ASSERT_EQ(state, actionlib::SimpleClientGoalState::SUCCEEDED) << state.getText();
  ros::Duration(0.2).sleep();
  EXPECT_LT(std::abs(wrap(truth_->pose("khepera").yaw + 1.2)), 3 * M_PI / 180);
  goal.heading = NAN;
  EXPECT_EQ(run(client, goal, 20.0), actionlib::SimpleClientGoalState::REJECTED);
  limit.request.linear = 0.1;
  limit.request.angular = 2.5;
  ASSERT_TRUE(ros::service::call(ns + "relocation/set_max_velocity", limit));
}

TEST_F(Embodiment, PushMovesALightCubeInThePushedDirection) {
  place("khepera", -0.3, 0.0, 0.0);
  place("red_cube", -0.05, 0.1, 0.0);
  Client<xpersif::PushAction> client(ns + "manipulation/push", true);
  const auto state = run(client, push("red_cube", "-x", 0.0, 0.06));  // push on the -x face: along +x
  ASSERT_EQ(state, actionlib::SimpleClientGoalState::SUCCEEDED) << state.getText();
  ros::Duration(0.3).sleep();
  const Planar after = truth_->pose("red_cube");
  EXPECT_GT(after.x - (-0.05), 0.04) << "the cube moved only " << after.x + 0.05 << " m along the push";
  EXPECT_LT(std::abs(after.y - 0.1), 0.015);
  const auto result = client.getResult();
  EXPECT_FALSE(result->blocked) << result->message;
  EXPECT_NEAR(result->pushed, 0.06, 0.01);
  EXPECT_TRUE(result->observed_after);
  EXPECT_NEAR(result->object_after.x, after.x, 0.005);  // what the camera says vs the truth
  EXPECT_NEAR(result->object_before.x, -0.05, 0.005);
}

TEST_F(Embodiment, TheHeavyCubeDoesNotMove) {
  place("khepera", -0.1, 0.0, 0.0);
  const Planar before = truth_->pose("blue_cube");
  Client<xpersif::PushAction> client(ns + "manipulation/push", true);
  // On the overhead camera's poses (as the loop pushes): wheel odometry cannot see the wheels slip.
  xpersif::PushGoal goal = push("blue_cube", "-x", 0.0, 0.04);
  goal.pose_source = "observation";
  const auto state = run(client, goal);
  // A push against an object that does not move is an outcome, not a failure: it succeeds, blocked.
  ASSERT_EQ(state, actionlib::SimpleClientGoalState::SUCCEEDED) << state.getText();
  const auto result = client.getResult();
  EXPECT_TRUE(result->blocked) << result->message;
  EXPECT_LT(result->pushed, 0.01) << "the robot advanced " << result->pushed << " m against the heavy cube";
  ros::Duration(0.3).sleep();
  const Planar after = truth_->pose("blue_cube");
  EXPECT_LT(std::hypot(after.x - before.x, after.y - before.y), 0.003);
  EXPECT_TRUE(result->observed_after);
  EXPECT_NEAR(result->object_after.x, result->object_before.x, 0.003);
}

TEST_F(Embodiment, BadPushesAreRejectedWithReasonsAndChangeNothing) {
  place("khepera", -0.3, 0.0, 0.0);
  const Planar red = truth_->pose("red_cube"), robot = truth_->pose("khepera");
  Client<xpersif::PushAction> client(ns + "manipulation/push", true);
  struct Case {
    xpersif::PushGoal goal;
    std::string says;
  };
  const std::vector<Case> cases = {{push("purple_cube", "-x", 0, 0.05), "known"},
                                   {push("red_cube", "-z", 0, 0.05), "valid_push"},
                                   {push("red_cube", "-x", NAN, 0.05), "valid_push"},
                                   {push("red_cube", "-x", 0, -0.05), "valid_push"},
                                   {push("red_cube", "-x", 0.5, 0.05), "valid_push"},
                                   {push("red_cube", "-x", 0, INFINITY), "valid_push"}};
  for (const auto& c : cases) {
    const auto state = run(client, c.goal, 20.0);
    EXPECT_EQ(state, actionlib::SimpleClientGoalState::REJECTED) << c.says;
    EXPECT_NE(state.getText().find(c.says), std::string::npos) << state.getText();
  }
  const Planar red_after = truth_->pose("red_cube"), robot_after = truth_->pose("khepera");
  EXPECT_LT(std::hypot(red_after.x - red.x, red_after.y - red.y), 1e-3);
  EXPECT_LT(std::hypot(robot_after.x - robot.x, robot_after.y - robot.y), 1e-3);
}

TEST_F(Embodiment, PerceptionObservationAndTheRobotsState) {
  xpersif::ReadIr ir;
  ASSERT_TRUE(ros::service::call(ns + "perception/read_ir", ir));
  ASSERT_TRUE(ir.response.success) << ir.response.message;
  EXPECT_EQ(ir.response.reading.ranges.size(), 8u);
  ir.request.max_age = NAN;
  ASSERT_TRUE(ros::service::call(ns + "perception/read_ir", ir));
  EXPECT_FALSE(ir.response.success);

  // The overhead camera sees all four cubes and the robot, within 5 mm of the truth.
  xpersif::GetFeatures seen;
  seen.request.max_age = 1.0;
  ros::Duration(0.3).sleep();
  ASSERT_TRUE(ros::service::call(ns + "observation/get_features", seen));
  ASSERT_TRUE(seen.response.success) << seen.response.message;
  EXPECT_EQ(seen.response.features.objects.size(), 4u);
  for (const auto& o : seen.response.features.objects) {
    const Planar t = truth_->pose(o.name);
    EXPECT_LT(std::hypot(o.position.x - t.x, o.position.y - t.y), 0.005) << o.name;
  }
  ASSERT_TRUE(seen.response.features.robot_found);
  const Planar robot = truth_->pose("khepera");
  EXPECT_LT(std::hypot(seen.response.features.robot.x - robot.x, seen.response.features.robot.y - robot.y), 0.01);

  xpersif::GetRobotState state;
  ASSERT_TRUE(ros::service::call(ns + "robot_model/get_robot_state", state));
  ASSERT_TRUE(state.response.success) << state.response.message;
  EXPECT_LT(std::hypot(state.response.state.pose.x - robot.x, state.response.state.pose.y - robot.y), 0.02);
  EXPECT_EQ(state.response.state.ir_ranges.size(), 8u);
  EXPECT_FALSE(state.response.state.has_gripper);
  EXPECT_TRUE(state.response.state.holding.empty());
}

TEST_F(Embodiment, FeatureSelectionDrivesVision) {
  xpersif::SelectFeatures select;
  select.request.names = {"hue", "no_such_feature"};
  ASSERT_TRUE(ros::service::call(ns + "feature_selection/select_features", select));
  EXPECT_FALSE(select.response.success);
  EXPECT_NE(select.response.message.find("no_such_feature"), std::string::npos) << select.response.message;
  select.request.names = {"hue", "size", "distance_to_robot"};
  ASSERT_TRUE(ros::service::call(ns + "feature_selection/select_features", select));
  ASSERT_TRUE(select.response.success) << select.response.message;
  ros::Duration(0.5).sleep();
  xpersif::GetFeatures vision;
  vision.request.max_age = 1.0;
  ASSERT_TRUE(waitFor(
      [&] {
        return ros::service::call(ns + "vision/get_features", vision) && vision.response.success &&
               !vision.response.features.objects.empty() &&
               vision.response.features.objects[0].feature_names == select.request.names;
      },
      10.0));
  for (const auto& o : vision.response.features.objects) {
    ASSERT_EQ(o.feature_values.size(), 3u);
    EXPECT_NEAR(o.feature_values[1], 0.04, 0.004) << o.name << " size";  // the cubes are 4 cm
  }
}

TEST_F(Embodiment, ImagesReachFeatureExtractionAndVisionWithoutACopy) {
  // The observation renders into an image message, extracts from that buffer, and publishes it; the stand-alone
  // FEATUREEXTRACTION and VISION in the same manager must read the very same buffer for the same image.
  using Addresses = Recorder<std_msgs::UInt64MultiArray>;
  Addresses observation(nh_, ns + "observation/buffer_address");
  Addresses extraction(nh_, ns + "feature_extraction/buffer_address");
  Addresses vision(nh_, ns + "vision/buffer_address");
  ASSERT_TRUE(waitFor([&] { return vision.messages().size() >= 5 && extraction.messages().size() >= 5; }, 20.0));
  ros::Duration(0.5).sleep();
  std::map<std::uint64_t, std::uint64_t> published;
  for (const auto& m : observation.messages()) published[m.data[0]] = m.data[1];
  int paired_extraction = 0, paired_vision = 0;
  for (const auto& m : extraction.messages()) {
    if (!published.count(m.data[0])) continue;
    EXPECT_EQ(m.data[1], published[m.data[0]]) << "feature extraction copied image " << m.data[0];
    ++paired_extraction;
  }
  for (const auto& m : vision.messages()) {
    if (!published.count(m.data[0])) continue;
    EXPECT_EQ(m.data[1], published[m.data[0]]) << "vision copied image " << m.data[0];
    ++paired_vision;
  }
  EXPECT_GE(paired_extraction, 3);
  EXPECT_GE(paired_vision, 3);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "embodiment_tester");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
