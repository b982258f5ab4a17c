// The whole loop on any world file, with no setting but world:= (test/loop_world.test): a short run of the
// grid design (it visits the objects in turn) and two goals. Checks what the world file alone must give:
// experiments stored for every object of the world, the immovable ones named in a notion, no run aborted
// over names. Which objects cannot move is read from the world file's masses (ground truth the loop never sees).
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <iostream>
#include <map>
#include <set>

#include "ground_truth.h"
#include "test_helpers.h"
#include "xpersif/GetExperiments.h"
#include "xpersif/GetNotions.h"
#include "xpersif/RunLoopAction.h"
#include "xpersif/core/sim/world_spec.h"

using xpersif_test::waitFor;

namespace {

const std::string ns = "/xpersif/";
const std::vector<std::string> kComponents = {"loop_model", "xpersim", "robot_model", "knowledge_base",
                                              "machine_learning", "motivation", "design_of_experiments",
                                              "planner", "execution", "goal_design", "relocation",
                                              "manipulation", "observation", "vision", "perception"};
constexpr int kPushesPerObject = 3;  // the "does not move" notion needs three pushes of an object
constexpr double kImmovableMass = 1.0;  // kg: the Khepera-like robot's motors cannot shift this (worlds/*.yaml)

}  // namespace

TEST(LoopOnAnyWorld, ExperimentsOnEveryObjectAndTheImmovableNamed) {
  ros::NodeHandle nh;
  std::string world_file;
  ASSERT_TRUE(nh.getParam(ns + "world", world_file));
  const xpersif::core::WorldSpec world = xpersif::core::loadWorldFile(world_file);
  SCOPED_TRACE(world_file);
  std::string which;
  ASSERT_TRUE(waitFor([&] { return xpersif_test::allActive(ns, kComponents, &which); }, 180.0))
      << which << " did not become ACTIVE";

  actionlib::SimpleActionClient<xpersif::RunLoopAction> client(ns + "loop_model/run", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(30.0)));
  xpersif::RunLoopGoal goal;
  goal.name = "any_world";
  goal.experiments = kPushesPerObject * world.objects.size();
  goal.goals = 2;
  goal.design = "grid";
  goal.seed = 3;
  client.sendGoal(goal);
  ASSERT_TRUE(client.waitForResult(ros::Duration(1200.0)));
  ASSERT_EQ(client.getState(), actionlib::SimpleClientGoalState::SUCCEEDED) << client.getState().getText();
  const auto result = client.getResult();
  EXPECT_EQ(result->experiments_done + result->experiments_failed, goal.experiments) << result->message;
  // A world the cameras and the embodiment can handle runs nearly every experiment it designs.
  EXPECT_GE(result->experiments_done, 0.9 * goal.experiments)
      << result->experiments_failed << " of " << goal.experiments << " experiments failed: " << result->message;

  xpersif::GetExperiments stored;
  stored.request.run_id = result->run_id;
  ASSERT_TRUE(waitFor([&] { return ros::service::call(ns + "knowledge_base/get_experiments", stored) && stored.response.success; }, 30.0));
  std::map<std::string, int> done;
  for (const auto& r : stored.response.experiments) {
    if (r.status == "done") ++done[r.experiment.object];
  }
  for (const auto& object : world.objects) EXPECT_GE(done[object.name], 1) << object.name << " was never pushed";

  xpersif::GetNotions notions;
  notions.request.run_id = result->run_id;
  ASSERT_TRUE(waitFor([&] { return ros::service::call(ns + "knowledge_base/get_notions", notions) && notions.response.success; }, 30.0));
  std::set<std::string> immobile;
  for (const auto& n : notions.response.notions) {
    if (n.predicate == "does_not_move_when_pushed") immobile.insert(n.subject);
  }
  for (const auto& object : world.objects) {
    std::cout << world.name << ": " << object.name << " pushed " << done[object.name] << " times"
              << (immobile.count(object.name) ? ", named immovable" : "") << "\n";
  }
  for (const auto& object : world.objects) {
    if (object.mass >= kImmovableMass && done[object.name] >= kPushesPerObject) {
      EXPECT_TRUE(immobile.count(object.name)) << object.name << " (" << object.mass << " kg) is not named immovable";
    }
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "loop_world_tester");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
