/**
 * @file conversions.h
 * @brief Between the ROS-free core types (Eigen, SceneDescription) and ROS messages.
 */
#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>

#include <Eigen/Geometry>

#include "xpersif/Scene.h"
#include "xpersif/core/common/scene.h"

namespace xpersif {

geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& t);
geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& t);
/// The caller validates the message first (see message_checks.h); the quaternion is normalized.
Eigen::Isometry3d fromPoseMsg(const geometry_msgs::Pose& pose);
Eigen::Isometry3d fromTransformMsg(const geometry_msgs::Transform& t);

xpersif::Scene toSceneMsg(const core::SceneDescription& scene);
/// @throws std::invalid_argument for a shape type it does not know
core::SceneDescription fromSceneMsg(const xpersif::Scene& msg);

}  // namespace xpersif
