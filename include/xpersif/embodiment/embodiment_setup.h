/**
 * @file embodiment_setup.h
 * @brief What the embodiment's components know about the experimental set-up: the arena, the robot's
 *        footprint and speed limits, the objects and their footprints. Read from the same world file XPERSim
 *        runs (the `world` parameter of the component's namespace), so that nothing is configured twice;
 *        a physical set-up would give the same facts in a world file of its own.
 */
#pragma once

#include <ros/ros.h>

#include <map>
#include <string>
#include <vector>

#include "xpersif/core/motion/motion.h"
#include "xpersif/core/common/setup.h"

namespace xpersif {

struct EmbodimentSetup {
  std::string world_file;
  core::ArenaGeometry arena;
  double robot_radius = 0.035;
  double max_wheel_speed = 0.5;  ///< m/s at the rim
  double wheel_separation = 0.053;
  std::map<std::string, core::Footprint> object_footprints;  ///< name -> its footprint on the floor
  std::map<std::string, core::Pose2D> initial_poses;  ///< where the world file puts the objects and the robot
  std::string robot_name;                             ///< the robot's body name (XPERSim's set_pose)
  std::vector<std::string> objectNames() const;
  /// The objects come from XPERSim's scene (ros/setup_loader.h), never from the world file directly.
  void takeObjectsFrom(const core::SetupCatalogue& catalogue);
};

/**
 * @brief Read the set-up from the world file named by the `world` parameter (searched upwards from
 *        @p nh's namespace). @throws std::runtime_error with a sentence when it is not set or unusable
 */
EmbodimentSetup loadEmbodimentSetup(const ros::NodeHandle& nh);

}  // namespace xpersif
