#include "xpersif/core/perception/background.h"

#include <set>

namespace xpersif::core {

SceneDescription RenderedBackground::emptyArena(const SceneDescription& scene) {
  std::set<std::string> gone(scene.objects.begin(), scene.objects.end());
  if (!scene.robot_root.empty()) gone.insert(scene.robot_root);
  SceneDescription empty = scene;
  empty.nodes.clear();
  for (const SceneNode& node : scene.nodes) {  // parents come first: a node below a removed one goes too
    if (gone.count(node.name) || gone.count(node.parent)) {
      gone.insert(node.name);
      continue;
    }
    empty.nodes.push_back(node);
  }
  return empty;
}

RenderedBackground::RenderedBackground(const SceneDescription& scene, const RenderOptions& options)
    : empty_(emptyArena(scene)), world_from_node_(worldTransforms(empty_)), renderer_(empty_, options) {}

cv::Mat RenderedBackground::imageFor(const CameraModel& camera, const Eigen::Isometry3d& world_from_camera) const {
  std::lock_guard<std::mutex> lock(mutex_);
  Cached& cached = cache_[camera.name];
  if (!cached.image.empty() && cached.image.cols == camera.width && cached.image.rows == camera.height &&
      cached.pose.matrix() == world_from_camera.matrix()) {
    return cached.image;
  }
  cv::Mat image;  // a new buffer: images handed out earlier stay as they were
  renderer_.render(camera, world_from_camera, world_from_node_, image);
  cached = {world_from_camera, image};
  return image;
}

}  // namespace xpersif::core
