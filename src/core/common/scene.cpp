#include "xpersif/core/common/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace xpersif::core {

const std::vector<std::string>& arucoDictionaryNames() {
  static const std::vector<std::string> names = {
      "4x4_50", "4x4_100", "4x4_250", "4x4_1000", "5x5_50", "5x5_100", "5x5_250", "5x5_1000", "6x6_50", "6x6_100",
      "6x6_250", "6x6_1000", "7x7_50", "7x7_100", "7x7_250", "7x7_1000", "aruco_original", "apriltag_16h5",
      "apriltag_25h9", "apriltag_36h10", "apriltag_36h11"};
  return names;
}

int arucoDictionaryCode(const std::string& name) {
  const auto& names = arucoDictionaryNames();
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

const SceneNode* SceneDescription::findNode(const std::string& name) const {
  for (const auto& node : nodes) {
    if (node.name == name) return &node;
  }
  return nullptr;
}

const CameraModel* SceneDescription::findCamera(const std::string& name) const {
  for (const auto& camera : cameras) {
    if (camera.name == name) return &camera;
  }
  return nullptr;
}

bool carriedByRobot(const SceneDescription& scene, const CameraModel& camera) {
  if (scene.robot_root.empty()) return false;
  std::size_t steps = 0;  // a malformed scene (a cycle) must not hang the question
  for (const SceneNode* node = scene.findNode(camera.frame); node && steps <= scene.nodes.size(); ++steps) {
    if (node->name == scene.robot_root) return true;
    node = scene.findNode(node->parent);
  }
  return false;
}

const CameraModel* chooseCamera(const SceneDescription& scene, const std::string& wanted, std::string& problem) {
  problem.clear();
  if (const CameraModel* named = scene.findCamera(wanted)) return named;
  std::string cameras;
  for (const auto& c : scene.cameras) {
    cameras += (cameras.empty() ? "" : ", ") + c.name + (carriedByRobot(scene, c) ? " (on the robot)" : " (fixed)");
  }
  if (cameras.empty()) cameras = "none";
  const std::string world = scene.world_file.empty() ? "the scene" : scene.world_file;
  if (wanted != kFixedCamera && wanted != kCameraOnRobot) {
    problem = "camera '" + wanted + "' is not one of " + world + "'s cameras (" + cameras + "), nor '" +
              kFixedCamera + "' or '" + kCameraOnRobot + "' (the one camera with that mount)";
    return nullptr;
  }
  const bool on_robot = wanted == kCameraOnRobot;
  const CameraModel* chosen = nullptr;
  int fitting = 0;
  for (const auto& c : scene.cameras) {
    if (carriedByRobot(scene, c) != on_robot) continue;
    if (!chosen) chosen = &c;
    ++fitting;
  }
  if (fitting == 1) return chosen;
  const std::string mount = on_robot ? "carried by the robot" : "fixed in the arena (not carried by the robot)";
  problem = fitting == 0 ? world + " has no camera " + mount + "; its cameras: " + cameras
                         : world + " has " + std::to_string(fitting) + " cameras " + mount + " (" + cameras +
                               "): name the one to use in the component's ~camera/name";
  return nullptr;
}

double lowestPoint(const Shape& shape, const Eigen::Isometry3d& t) {
  const Eigen::Vector3d c = t.translation();
  switch (shape.type) {
    case Shape::Type::Sphere: return c.z() - shape.radius;
    case Shape::Type::Cylinder: {
      const Eigen::Vector3d axis = t.rotation().col(2);
      const double radial = shape.radius * std::sqrt(std::max(0.0, 1.0 - axis.z() * axis.z()));
      return c.z() - std::fabs(axis.z()) * shape.length / 2 - radial;
    }
    case Shape::Type::Box: {
      double low = std::numeric_limits<double>::infinity();
      for (int i = 0; i < 8; ++i) {
        const Eigen::Vector3d corner((i & 1 ? 0.5 : -0.5) * shape.box_size.x(), (i & 2 ? 0.5 : -0.5) * shape.box_size.y(),
                                     (i & 4 ? 0.5 : -0.5) * shape.box_size.z());
        low = std::min(low, (t * corner).z());
      }
      return low;
    }
  }
  return c.z();
}

FrameTransforms worldTransforms(const SceneDescription& scene, const FrameTransforms& current) {
  FrameTransforms world;
  world[scene.world_frame] = Eigen::Isometry3d::Identity();
  for (const auto& node : scene.nodes) {
    const auto parent = world.find(node.parent);
    if (parent == world.end()) {
      throw std::invalid_argument("scene node '" + node.name + "' has parent '" + node.parent +
                                  "', which is neither the world frame nor an earlier node");
    }
    const auto override_it = current.find(node.name);
    const Eigen::Isometry3d& local = override_it != current.end() ? override_it->second : node.parent_from_node;
    world[node.name] = parent->second * local;
  }
  return world;
}

}  // namespace xpersif::core
