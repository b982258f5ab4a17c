// Why an experiment failed, decided on codes and on the overhead camera's vector, and the streak of experiments
// failing for the same cause that ends LOOPMODEL's experimentation phase (issue 36, item 4). No roscore.
#include <gtest/gtest.h>

#include "xpersif/core/common/experiment_failure.h"

using namespace xpersif::core;

namespace {

constexpr std::uint8_t kUnavailable = 4, kFailed = 5;  // xpersif/ResultCode

/// An experiment whose push failed (EXECUTION's FAILED) while the camera's latest vector said @p robot_found.
FailureEvidence failedPush(bool robot_found, const std::string& object = "red_cube", bool missing = false) {
  FailureEvidence e;
  e.failed = true;
  e.stage = ExperimentStage::Execution;
  e.code = kFailed;
  e.tried_and_failed = true;
  e.robot_pose_observed = true;
  e.have_vector = true;
  e.robot_found = robot_found;
  e.object = object;
  e.object_missing = missing;
  return e;
}

}  // namespace

TEST(FailureCause, DoneIsNoCause) {
  FailureEvidence e;
  EXPECT_EQ(classifyFailure(e).kind, FailureCause::Kind::None);
  EXPECT_FALSE(classifyFailure(e).repeats());
}

TEST(FailureCause, RobotNotFoundByTheCameraIsTheCause) {
  const FailureCause cause = classifyFailure(failedPush(false));
  EXPECT_EQ(cause.kind, FailureCause::Kind::RobotNotSeen);
  EXPECT_TRUE(cause.repeats());
  EXPECT_EQ(describeCause(cause),
            "the overhead camera did not find the robot in its latest image (the robot's pose comes from it)");
}

TEST(FailureCause, RobotNotFoundDoesNotMatterWithOdometry) {
  FailureEvidence e = failedPush(false);
  e.robot_pose_observed = false;
  EXPECT_EQ(classifyFailure(e).kind, FailureCause::Kind::Unexplained);
}

TEST(FailureCause, MissingObjectIsTheCause) {
  const FailureCause cause = classifyFailure(failedPush(true, "grey_cylinder", true));
  EXPECT_EQ(cause.kind, FailureCause::Kind::ObjectNotSeen);
  EXPECT_EQ(cause.object, "grey_cylinder");
  EXPECT_EQ(describeCause(cause), "the overhead camera did not find grey_cylinder in its latest image");
}

TEST(FailureCause, APushThatTriedAndFailedIsUnexplained) {
  const FailureCause cause = classifyFailure(failedPush(true));
  EXPECT_EQ(cause.kind, FailureCause::Kind::Unexplained);
  EXPECT_FALSE(cause.repeats());
}

TEST(FailureCause, ARefusalIsDecidedOnTheCode) {
  FailureEvidence e;
  e.failed = true;
  e.stage = ExperimentStage::Plan;
  e.code = kUnavailable;
  e.have_vector = true;
  e.robot_found = false;  // planning does not look through the camera
  e.robot_pose_observed = true;
  const FailureCause cause = classifyFailure(e);
  EXPECT_EQ(cause.kind, FailureCause::Kind::Refused);
  EXPECT_EQ(cause.code, kUnavailable);
  EXPECT_TRUE(cause.repeats());
  EXPECT_EQ(describeCause(cause, "UNAVAILABLE"), "the planning was refused (UNAVAILABLE)");
}

TEST(FailureStreak, EndsAfterTheLimitOfTheSameCause) {
  FailureStreak streak(3);
  EXPECT_FALSE(streak.add(classifyFailure(failedPush(false))));
  EXPECT_FALSE(streak.add(classifyFailure(failedPush(false, "blue_cube"))));  // the object does not matter here
  EXPECT_TRUE(streak.add(classifyFailure(failedPush(false))));
  EXPECT_EQ(streak.length(), 3u);
  EXPECT_EQ(streak.cause().kind, FailureCause::Kind::RobotNotSeen);
}

TEST(FailureStreak, ASuccessOrAnotherCauseStartsAgain) {
  FailureStreak streak(3);
  streak.add(classifyFailure(failedPush(false)));
  streak.add(classifyFailure(failedPush(false)));
  EXPECT_FALSE(streak.add(FailureCause()));  // done
  EXPECT_EQ(streak.length(), 0u);
  streak.add(classifyFailure(failedPush(false)));
  streak.add(classifyFailure(failedPush(false)));
  EXPECT_FALSE(streak.add(classifyFailure(failedPush(true, "red_cube", true))));  // another cause: a streak of 1
  EXPECT_EQ(streak.length(), 1u);
  EXPECT_EQ(streak.cause().kind, FailureCause::Kind::ObjectNotSeen);
  EXPECT_FALSE(streak.add(classifyFailure(failedPush(true, "blue_cube", true))));  // another object: another cause
  EXPECT_EQ(streak.length(), 1u);
}

TEST(FailureStreak, UnexplainedFailuresNeverEndThePhase) {
  FailureStreak streak(2);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(streak.add(classifyFailure(failedPush(true))));
  EXPECT_EQ(streak.length(), 0u);
}

TEST(FailureStreak, ZeroNeverEnds) {
  FailureStreak streak(0);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(streak.add(classifyFailure(failedPush(false))));
  EXPECT_EQ(streak.length(), 10u);
}
