#include "xpersif/core/common/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
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
