/**
 * @file message_checks.h
 * @brief The core's input checks applied to common ROS messages (points, quaternions, poses), so every
 *        component words a bad pose the same way. Each returns "" when the message is fine.
 */
#pragma once

#include <geometry_msgs/Point.h>
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Quaternion.h>
#include <geometry_msgs/Vector3.h>

#include <string>

#include "xpersif/core/common/validation.h"

namespace xpersif {

inline std::string checkPoint(const std::string& field, const geometry_msgs::Point& p) {
  for (const auto& [axis, value] : {std::pair<const char*, double>{"x", p.x}, {"y", p.y}, {"z", p.z}}) {
    std::string why = core::checkFinite(field + "." + axis, value);
    if (!why.empty()) return why;
  }
  return "";
}

inline std::string checkVector3(const std::string& field, const geometry_msgs::Vector3& v) {
  geometry_msgs::Point p;
  p.x = v.x;
  p.y = v.y;
  p.z = v.z;
  return checkPoint(field, p);
}

inline std::string checkQuaternion(const std::string& field, const geometry_msgs::Quaternion& q) {
  return core::checkUnitQuaternion(field, q.x, q.y, q.z, q.w);
}

inline std::string checkPose(const std::string& field, const geometry_msgs::Pose& pose) {
  std::string why = checkPoint(field + ".position", pose.position);
  return why.empty() ? checkQuaternion(field + ".orientation", pose.orientation) : why;
}

inline void requirePose(const std::string& field, const geometry_msgs::Pose& pose) {
  core::throwIfInvalid(checkPose(field, pose));
}

}  // namespace xpersif
