// XPERSim through ROS: scene, tf, clock, lockstep stepping, driving, bad input, determinism, blow-ups.
#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <std_srvs/Trigger.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <cstring>

#include "test_helpers.h"
#include "xpersif/BodyPoses.h"
#include "xpersif/GetScene.h"
#include "xpersif/InjectFault.h"
#include "xpersif/IrRanges.h"
#include "xpersif/SetPose.h"
#include "xpersif/Step.h"

using xpersif::ComponentStatus;
using xpersif_test::Recorder;
using xpersif_test::waitFor;

namespace {

constexpr double kStep = 0.002;  // the default world's physics step

xpersif::Step::Response step(std::int64_t steps) {
  xpersif::Step call;
  call.request.steps = steps;
  EXPECT_TRUE(ros::service::call("/xpersim/step", call));
  return call.response;
}

bool trigger(const std::string& service, std::string* message = nullptr) {
  std_srvs::Trigger call;
  EXPECT_TRUE(ros::service::call(service, call));
  if (message) *message = call.response.message;
  return call.response.success;
}

xpersif::SetPose::Response setPose(const std::string& name, double x, double y, double qw = 1.0) {
  xpersif::SetPose call;
  call.request.name = name;
  call.request.pose.position.x = x;
  call.request.pose.position.y = y;
  call.request.pose.position.z = 0.02;
  call.request.pose.orientation.w = qw;
  EXPECT_TRUE(ros::service::call("/xpersim/set_pose", call));
  return call.response;
}

bool finite(const geometry_msgs::Transform& t) {
  return std::isfinite(t.translation.x) && std::isfinite(t.translation.y) && std::isfinite(t.translation.z) &&
         std::isfinite(t.rotation.x) && std::isfinite(t.rotation.y) && std::isfinite(t.rotation.z) &&
         std::isfinite(t.rotation.w);
}

class XPerSimTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(ros::service::waitForService("/xpersim/step", ros::Duration(60.0)));
    ASSERT_TRUE(waitFor([] {
      xpersif::GetScene call;
      return ros::service::call("/xpersim/get_scene", call) && call.response.success;
    }, 30.0));
    ASSERT_TRUE(trigger("/xpersim/reset"));
  }

  // The latest ground truth after stepping (sensor messages follow each step synchronously enough).
  xpersif::BodyPoses truthAfter(std::int64_t steps) {
    Recorder<xpersif::BodyPoses> truth(nh_, "/xpersim/ground_truth");
    EXPECT_TRUE(truth.waitForConnection(10.0));
    const double t = step(steps).time;
    xpersif::BodyPoses found;
    EXPECT_TRUE(truth.waitForMatch(
        [&](const xpersif::BodyPoses& m) { return std::fabs(m.header.stamp.toSec() - t) < 0.0105; }, 10.0, &found))
        << "no ground truth near t=" << t;
    return found;
  }

  ros::NodeHandle nh_;
};

}  // namespace

TEST_F(XPerSimTest, FetchTheSceneAndSeeFixedNodesOnTfStatic) {
  xpersif::GetScene call;
  ASSERT_TRUE(ros::service::call("/xpersim/get_scene", call));
  ASSERT_TRUE(call.response.success);
  const auto& scene = call.response.scene;
  EXPECT_EQ(scene.world_frame, "world");
  int dynamic = 0;
  for (const auto& n : scene.nodes) dynamic += n.dynamic;
  EXPECT_EQ(dynamic, 7);
  ASSERT_EQ(scene.cameras.size(), 2u);
  EXPECT_EQ(scene.cameras[0].width, 600u);
  EXPECT_EQ(scene.cameras[0].height, 416u);

  Recorder<tf2_msgs::TFMessage> tf_static(nh_, "/tf_static");
  tf2_msgs::TFMessage fixed;
  ASSERT_TRUE(tf_static.waitForMatch([](const tf2_msgs::TFMessage&) { return true; }, 10.0, &fixed));
  bool overhead = false;
  for (const auto& t : fixed.transforms) overhead = overhead || t.child_frame_id == "overhead_optical";
  EXPECT_TRUE(overhead);
  EXPECT_EQ(fixed.transforms.size(), scene.nodes.size() - 7);

  Recorder<visualization_msgs::MarkerArray> markers(nh_, "/xpersim/markers");
  visualization_msgs::MarkerArray m;
  ASSERT_TRUE(markers.waitForMatch([](const visualization_msgs::MarkerArray&) { return true; }, 10.0, &m));
  EXPECT_EQ(m.markers.size(), 5u + 4u) << "arena floor and 4 walls, 4 cubes";
  EXPECT_TRUE(m.markers.back().frame_locked);
  std::string description;
  EXPECT_TRUE(ros::param::get("/robot_description", description));
  EXPECT_NE(description.find("<robot name=\"khepera\">"), std::string::npos);
}

TEST_F(XPerSimTest, LockstepAdvancesTimeOnlyOnRequestAndPublishesOneTfMessagePerFrame) {
  Recorder<tf2_msgs::TFMessage> tf(nh_, "/tf");
  Recorder<rosgraph_msgs::Clock> clock(nh_, "/clock");
  ASSERT_TRUE(tf.waitForConnection(10.0));
  ASSERT_TRUE(clock.waitForConnection(10.0));
  ros::WallDuration(0.3).sleep();
  EXPECT_TRUE(tf.messages().empty()) << "in lockstep nothing moves by itself";
  const auto r = step(100);
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_NEAR(r.time, 100 * kStep, 1e-9);
  ASSERT_TRUE(waitFor([&] { return tf.messages().size() >= 100; }, 10.0)) << tf.messages().size();
  const auto frames = tf.messages();
  EXPECT_EQ(frames.size(), 100u) << "one TFMessage per frame";
  for (const auto& f : frames) {
    ASSERT_EQ(f.transforms.size(), 7u) << "only nodes that move on their own";
    for (const auto& t : f.transforms) EXPECT_TRUE(finite(t.transform));
  }
  EXPECT_NEAR(frames.back().transforms[0].header.stamp.toSec(), 100 * kStep, 1e-9);
  ASSERT_TRUE(waitFor(
      [&] { return !clock.messages().empty() && clock.messages().back().clock.toSec() > 100 * kStep - 1e-6; }, 5.0));
}

TEST_F(XPerSimTest, CmdVelDrivesTheRobot) {
  ros::Publisher cmd = nh_.advertise<geometry_msgs::Twist>("/cmd_vel", 1, true);
  geometry_msgs::Twist twist;
  twist.linear.x = 0.1;
  cmd.publish(twist);
  ros::WallDuration(0.5).sleep();  // latched; let it arrive
  const xpersif::BodyPoses truth = truthAfter(500);
  EXPECT_NEAR(truth.poses[0].position.x, -0.3 + 0.1, 0.02) << "1 s at 0.1 m/s from x = -0.3";
  twist.linear.x = NAN;
  cmd.publish(twist);
  ros::WallDuration(0.3).sleep();
  twist.linear.x = 0.0;
  cmd.publish(twist);
  ros::WallDuration(0.3).sleep();
}

TEST_F(XPerSimTest, BadRequestsGetClearErrorsAndLeaveTheWorldUntouched) {
  const xpersif::BodyPoses before = truthAfter(1);
  auto r = setPose("red_cube", NAN, 0.0);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.message, "invalid request: pose.position.x is NaN; it must be a finite number");
  r = setPose("purple_cube", 0.0, 0.0);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("name names 'purple_cube', which is unknown; known names: 'khepera', 'red_cube'"),
            std::string::npos)
      << r.message;
  r = setPose("red_cube", 0.0, 0.0, 0.5);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("pose.orientation is not a unit quaternion"), std::string::npos) << r.message;
  r = setPose("red_cube", 5.0, 0.0);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("outside the arena"), std::string::npos) << r.message;

  auto s = step(0);
  EXPECT_FALSE(s.success);
  EXPECT_EQ(s.message, "invalid request: steps is 0; it must lie in 1..100000");
  EXPECT_FALSE(step(-5).success);
  EXPECT_FALSE(step(1000000000).success);

  // In lockstep, resume lets the clock tick for its participants again; with none, time still stands still.
  std::string message;
  EXPECT_TRUE(trigger("/xpersim/resume", &message)) << message;
  ros::WallDuration(0.3).sleep();

  const xpersif::BodyPoses after = truthAfter(1);
  EXPECT_NEAR(after.header.stamp.toSec() - before.header.stamp.toSec(), kStep, 1e-9) << "refused steps did not run";
  EXPECT_NEAR(after.poses[1].position.x, before.poses[1].position.x, 1e-6) << "red_cube stayed where it was";

  r = setPose("red_cube", 0.1, -0.05);
  EXPECT_TRUE(r.success) << r.message;
  EXPECT_NEAR(truthAfter(1).poses[1].position.x, 0.1, 1e-3);
}

TEST_F(XPerSimTest, SameCommandsAfterResetGiveTheSameTrajectoryBitForBit) {
  ros::Publisher cmd = nh_.advertise<geometry_msgs::Twist>("/cmd_vel", 1, true);
  auto run = [&] {
    EXPECT_TRUE(trigger("/xpersim/reset"));
    geometry_msgs::Twist twist;
    twist.linear.x = 0.08;
    twist.angular.z = 0.5;
    cmd.publish(twist);
    ros::WallDuration(0.3).sleep();
    return truthAfter(750);
  };
  const xpersif::BodyPoses a = run(), b = run();
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (std::size_t i = 0; i < a.poses.size(); ++i) {
    EXPECT_EQ(std::memcmp(&a.poses[i].position.x, &b.poses[i].position.x, sizeof(double)), 0) << a.names[i];
    EXPECT_EQ(std::memcmp(&a.poses[i].orientation.z, &b.poses[i].orientation.z, sizeof(double)), 0) << a.names[i];
  }
  EXPECT_GT(std::fabs(a.poses[0].position.y), 0.01) << "the robot did move along an arc";
  geometry_msgs::Twist stop;
  cmd.publish(stop);
  ros::WallDuration(0.3).sleep();
}

TEST_F(XPerSimTest, BlowUpIsReportedAndNoNonFinitePoseIsEverPublished) {
  Recorder<tf2_msgs::TFMessage> tf(nh_, "/tf");
  Recorder<ComponentStatus> status(nh_, "/xpersim/status");
  ASSERT_TRUE(tf.waitForConnection(10.0));
  xpersif::InjectFault fault;
  fault.request.name = "green_cube";
  ASSERT_TRUE(ros::service::call("/xpersim/inject_fault", fault));
  ASSERT_TRUE(fault.response.success) << fault.response.message;
  step(50);
  ComponentStatus reported;
  ASSERT_TRUE(status.waitForMatch(
      [](const ComponentStatus& s) {
        return s.health == ComponentStatus::HEALTH_WARN && !s.parts.empty() &&
               s.parts[0].message.find("green_cube has a non-finite") != std::string::npos;
      },
      10.0, &reported));
  ASSERT_TRUE(waitFor([&] { return tf.messages().size() >= 49; }, 10.0));
  for (const auto& f : tf.messages()) {
    for (const auto& t : f.transforms) ASSERT_TRUE(finite(t.transform)) << t.child_frame_id;
  }
  fault.request.name = "nobody";
  ASSERT_TRUE(ros::service::call("/xpersim/inject_fault", fault));
  EXPECT_FALSE(fault.response.success);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_xpersim");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
