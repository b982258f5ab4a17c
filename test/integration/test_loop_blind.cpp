// A run that cannot perceive says why (test/loop_blind.test, issue 36 item 4). With a robot the overhead camera never
// finds, the experimentation phase stops after ~max_same_failures (3) experiments failing for that cause, not after
// the whole budget; with a cube FEATUREEXTRACTION refuses, the run names OBSERVATION's refusal and the cube, not
// VISION's timeout. Both end ABORTED with RunLoop's code REPEATING_CAUSE (exit code 5 of the tools).
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include "ground_truth.h"
#include "test_helpers.h"
#include "xpersif/GetExperiments.h"
#include "xpersif/RunLoopAction.h"

using xpersif_test::waitFor;

namespace {

const std::string ns = "/xpersif/";
const std::vector<std::string> kComponents = {"loop_model", "xpersim", "robot_model", "knowledge_base",
                                              "machine_learning", "design_of_experiments", "planner", "execution",
                                              "manipulation", "observation", "vision"};

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST(LoopBlind, EndsWithTheCause) {
  ros::NodeHandle nh;
  std::string expect;
  ASSERT_TRUE(ros::param::get("/test_loop_blind/expect", expect));
  std::string which;
  ASSERT_TRUE(waitFor([&] { return xpersif_test::allActive(ns, kComponents, &which); }, 180.0))
      << which << " did not become ACTIVE";
  actionlib::SimpleActionClient<xpersif::RunLoopAction> client(ns + "loop_model/run", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(30.0)));
  xpersif::RunLoopGoal goal;
  goal.name = "blind";
  goal.experiments = 10;
  goal.design = "random";
  goal.seed = 3;
  client.sendGoal(goal);
  ASSERT_TRUE(client.waitForResult(ros::Duration(400.0)));
  ASSERT_EQ(client.getState(), actionlib::SimpleClientGoalState::ABORTED) << client.getState().getText();
  const auto result = client.getResult();
  ASSERT_TRUE(result);
  EXPECT_EQ(result->code, xpersif::RunLoopResult::REPEATING_CAUSE) << result->message;
  EXPECT_EQ(result->experiments_done, 0u) << result->message;
  if (expect == "robot") {
    // Three experiments stored as failed, then the phase stops with the cause and the last one's reason.
    EXPECT_EQ(result->experiments_failed, 3u) << result->message;
    EXPECT_TRUE(contains(result->message, "experiments 1 to 3 failed for the same cause, the overhead camera did not "
                                          "find the robot"))
        << result->message;
    EXPECT_TRUE(contains(result->message, "lists the robot as not found")) << result->message;
    xpersif::GetExperiments stored;
    stored.request.run_id = result->run_id;
    ASSERT_TRUE(ros::service::call(ns + "knowledge_base/get_experiments", stored) && stored.response.success);
    EXPECT_EQ(stored.response.experiments.size(), 3u);
  } else {
    // Before any experiment: OBSERVATION's part and the cube it cannot tell from the floor, VISION's wait behind.
    EXPECT_EQ(result->experiments_failed, 0u) << result->message;
    EXPECT_TRUE(contains(result->message, "OBSERVATION's feature_extraction refuses to work: cannot extract features "
                                          "from camera 'overhead': the colour of object 'red_cube'"))
        << result->message;
    EXPECT_TRUE(contains(result->message, "VISION did not take up the selection")) << result->message;
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_loop_blind");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
