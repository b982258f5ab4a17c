#include "xpersif/embodiment/embodiment_setup.h"

#include <algorithm>

#include "xpersif/core/sim/world_spec.h"

namespace xpersif {

std::vector<std::string> EmbodimentSetup::objectNames() const {
  std::vector<std::string> names;
  for (const auto& [name, footprint] : object_footprints) names.push_back(name);
  return names;
}

EmbodimentSetup loadEmbodimentSetup(const ros::NodeHandle& nh) {
  std::string key, file;
  if (!nh.searchParam("world", key) || !nh.getParam(key, file)) {
    throw std::runtime_error("the 'world' parameter (XPERSim's world file) is not set in " + nh.getNamespace() +
                             " or above; the embodiment reads the arena and the objects from it");
  }
  core::WorldSpec spec;
  try {
    spec = core::loadWorldFile(file);
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("cannot read the set-up: ") + e.what());
  }
  EmbodimentSetup setup;
  setup.world_file = file;
  setup.arena.size_x = spec.arena.size_x;
  setup.arena.size_y = spec.arena.size_y;
  setup.max_wheel_speed = spec.robot.max_wheel_speed;
  setup.wheel_separation = spec.robot.wheel_separation;
  // The footprint: the widest collision shape of the root link (a cylinder or sphere for a round robot).
  double radius = 0;
  if (!spec.robot.links.empty()) {
    for (const auto& c : spec.robot.links.front().collisions) {
      if (c.shape.type == core::Shape::Type::Box) {
        radius = std::max(radius, 0.5 * std::hypot(c.shape.box_size.x(), c.shape.box_size.y()));
      } else {
        radius = std::max(radius, c.shape.radius);
      }
    }
  }
  if (radius <= 0) throw std::runtime_error("the robot in " + file + " has no collision shape on its root link");
  setup.robot_radius = radius;
  for (const auto& object : spec.objects) {
    setup.initial_poses[object.name] = {object.pose.translation().x(), object.pose.translation().y(),
                                        core::yawOf(object.pose)};
  }
  setup.robot_name = spec.robot.name;
  setup.initial_poses[spec.robot.name] = {spec.robot.pose.translation().x(), spec.robot.pose.translation().y(),
                                          core::yawOf(spec.robot.pose)};
  return setup;
}

void EmbodimentSetup::takeObjectsFrom(const core::SetupCatalogue& catalogue) {
  object_footprints.clear();
  for (const auto& object : catalogue.objects) object_footprints[object.name] = object.footprint;
}

}  // namespace xpersif
