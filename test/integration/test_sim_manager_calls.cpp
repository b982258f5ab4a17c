// A component in XPERSim's manager (one worker thread) calls XPERSim's get_scene from its configure callback and
// comes up: XPERSim's callbacks do not wait for the manager's worker that the caller holds.
#include <gtest/gtest.h>
#include <ros/ros.h>

#include "test_helpers.h"

using xpersif::ComponentStatus;
using xpersif_test::Recorder;

TEST(SimManagerCalls, AComponentBesideXPerSimGetsTheSceneFromItsConfigure) {
  ros::NodeHandle nh;
  Recorder<ComponentStatus> status(nh, "/scene_reader/status");
  ComponentStatus active;
  ASSERT_TRUE(status.waitForMatch([](const ComponentStatus& s) { return s.state == ComponentStatus::ACTIVE; }, 90.0,
                                  &active))
      << "scene_reader never became ACTIVE: its configure is waiting for XPERSim's get_scene";
  int nodes = 0;
  ASSERT_TRUE(ros::param::get("/scene_reader/scene_nodes", nodes));
  EXPECT_GT(nodes, 0) << "the scene has the arena, the robot and the objects";
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sim_manager_calls");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
