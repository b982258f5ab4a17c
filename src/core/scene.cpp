#include "xpersif/core/scene.h"

#include <stdexcept>

namespace xpersif::core {

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
