/**
 * @file world_generator.h
 * @brief Worlds drawn from a seed (`xpersif generate-world`): an arena, the Khepera-like robot and objects drawn
 *        from roles, so that studies and tests run on worlds nobody tuned anything to. ROS-free.
 *
 * Each object plays a role, which decides how it answers a push:
 *  - `light`: a small cube or puck that slides (15-40 g, friction 0.3-0.6);
 *  - `elongated`: a bar 8-12 cm long that slides along and resists across (anisotropic friction), so it turns;
 *  - `immovable`: a block of 1.5-3 kg that the robot cannot move;
 *  - `redrawn`: a cube whose friction the simulator redraws before every push (nothing the loop sees predicts it).
 * Colours are spread around the hue circle (saturated, so perception tells them from the floor, the walls and each
 * other); sizes, masses, frictions, poses and the arena's size come from the seed. The overhead camera is placed
 * high enough to see the arena and its walls. The same options give the same text.
 */
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace xpersif::core {

struct WorldGeneratorOptions {
  std::uint32_t seed = 1;
  int objects = 5;                 ///< 1..8
  std::vector<std::string> roles;  ///< drawn from; empty: all of worldGeneratorRoles()
  std::string robot_urdf;          ///< the robot's URDF as written into the file (package://, relative to it, or absolute)
};

/// The roles an object can play, in the order documented above.
const std::vector<std::string>& worldGeneratorRoles();

/// The world file's YAML text. Throws std::invalid_argument for an unknown role or a count out of range, and
/// std::runtime_error when the objects cannot be placed (not expected within the limits).
std::string generateWorld(const WorldGeneratorOptions& options);

}  // namespace xpersif::core
