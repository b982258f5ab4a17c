/**
 * @file pose2d.h
 * @brief A planar pose, the robot's and the objects' currency on the arena floor (metres, radians, world frame).
 */
#pragma once

namespace xpersif::core {

struct Pose2D {
  double x = 0, y = 0, yaw = 0;
};

/// Angle wrapped into (-pi, pi].
double wrapAngle(double angle);

}  // namespace xpersif::core
