#include <gtest/gtest.h>

#include <cmath>

#include "xpersif/core/common/pose_estimate.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

TEST(PoseMath, ComposeWithInverseIsIdentity) {
  const Pose2D a{0.3, -0.2, 2.5};
  const Pose2D i = compose(a, inverse(a));
  EXPECT_NEAR(i.x, 0, 1e-12);
  EXPECT_NEAR(i.y, 0, 1e-12);
  EXPECT_NEAR(i.yaw, 0, 1e-12);
  EXPECT_NEAR(wrapAngle(3 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrapAngle(-M_PI), M_PI, 1e-12);
}

TEST(OdometryCorrection, WithoutFixesTheEstimateIsOdometry) {
  OdometryCorrection c;
  EXPECT_FALSE(c.hasOdometry());
  c.addOdometry(1.0, {0.1, 0.2, 0.3});
  EXPECT_FALSE(c.corrected());
  EXPECT_NEAR(c.estimate().x, 0.1, 1e-12);
  EXPECT_NEAR(c.estimate().yaw, 0.3, 1e-12);
}

TEST(OdometryCorrection, ALateFixCorrectsDriftAndMotionSinceIsKept) {
  // The robot truly drives along +x at 0.1 m/s from the origin; odometry believes it is 2 cm to the left
  // and 0.05 rad off (drift). A fix of the truth at t = 1 arrives when odometry is already at t = 1.5.
  OdometryCorrection c;
  const Pose2D drift{0.0, 0.02, 0.05};
  for (int i = 0; i <= 15; ++i) {
    const double t = i * 0.1;
    c.addOdometry(t, compose(drift, Pose2D{0.1 * t, 0, 0}));
  }
  EXPECT_EQ(c.addFix(1.0, {0.1, 0.0, 0.0}), "");
  ASSERT_TRUE(c.corrected());
  const Pose2D e = c.estimate();
  EXPECT_NEAR(e.x, 0.15, 1e-9);
  EXPECT_NEAR(e.y, 0.0, 1e-9);
  EXPECT_NEAR(e.yaw, 0.0, 1e-9);
}

TEST(OdometryCorrection, InterpolatesBetweenOdometrySamples) {
  OdometryCorrection c;
  c.addOdometry(0.0, {0.0, 0.0, 0.0});
  c.addOdometry(1.0, {1.0, 0.0, 0.0});
  EXPECT_EQ(c.addFix(0.25, {0.25, 0.0, 0.0}), "");
  EXPECT_NEAR(c.estimate().x, 1.0, 1e-12);
}

TEST(OdometryCorrection, FixesOutsideTheHistoryAreRefusedWithAReason) {
  OdometryCorrection c(1.0);
  EXPECT_EQ(c.addFix(0.0, {0, 0, 0}), "no odometry yet");
  for (int i = 0; i <= 30; ++i) c.addOdometry(i * 0.1, {0, 0, 0});
  EXPECT_NE(c.addFix(0.5, {1, 1, 0}), "");   // older than the kept history
  EXPECT_NE(c.addFix(10.0, {1, 1, 0}), "");  // far newer than the latest odometry
  EXPECT_FALSE(c.corrected());
  EXPECT_THROW(c.addFix(2.9, {NAN, 0, 0}), ValidationError);
  EXPECT_THROW(c.addOdometry(3.1, {0, INFINITY, 0}), ValidationError);
  EXPECT_FALSE(c.corrected());
}

TEST(OdometryCorrection, TimeGoingBackwardsStartsANewHistory) {
  OdometryCorrection c;
  c.addOdometry(5.0, {1, 0, 0});
  c.addOdometry(0.0, {0, 0, 0});  // simulator reset
  EXPECT_NE(c.addFix(4.0, {0, 0, 0}), "");
  EXPECT_EQ(c.addFix(0.0, {0, 0.1, 0}), "");
  EXPECT_NEAR(c.estimate().y, 0.1, 1e-12);
}
