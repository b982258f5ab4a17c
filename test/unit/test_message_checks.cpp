// The message checks need only message headers: no roscore.
#include <gtest/gtest.h>

#include <cmath>

#include "xpersif/component/message_checks.h"

TEST(MessageChecks, PosesAreFiniteWithUnitQuaternions) {
  geometry_msgs::Pose pose;
  pose.orientation.w = 1.0;
  EXPECT_EQ(xpersif::checkPose("target", pose), "");
  pose.position.y = std::nan("");
  EXPECT_EQ(xpersif::checkPose("target", pose), "target.position.y is NaN; it must be a finite number");
  pose.position.y = 0;
  pose.orientation.w = 2.0;
  EXPECT_NE(xpersif::checkPose("target", pose).find("target.orientation is not a unit quaternion (its norm is 2)"),
            std::string::npos);
  EXPECT_THROW(xpersif::requirePose("target", pose), xpersif::core::ValidationError);
  geometry_msgs::Vector3 v;
  v.z = INFINITY;
  EXPECT_EQ(xpersif::checkVector3("velocity", v), "velocity.z is +inf; it must be a finite number");
}
