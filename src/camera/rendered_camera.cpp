#include "xpersif/camera/rendered_camera.h"

#include <opencv2/core.hpp>


namespace xpersif {

RenderedCamera::RenderedCamera(ros::NodeHandle nh, std::string camera, const std::string& scene_topic,
                         std::function<void(const std::string&)> on_error, std::function<void()> on_ready)
    : name_(std::move(camera)), on_error_(std::move(on_error)), on_ready_(std::move(on_ready)) {
  tracker_ = std::make_unique<SceneTracker>(nh);
  tracker_->follow(scene_topic, [this] { onScene(); });
}

void RenderedCamera::onScene() {
  const core::SceneDescription scene = tracker_->scene();
  std::string problem;
  const core::CameraModel* model = core::chooseCamera(scene, name_, problem);
  if (!model) {
    if (on_error_) on_error_(problem);
    return;
  }
  auto renderer = std::make_unique<core::Renderer>(scene);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    camera_ = *model;
    scene_ = scene;
    renderer_ = std::move(renderer);
  }
  if (on_ready_) on_ready_();
}

std::string RenderedCamera::name() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return camera_.name.empty() ? name_ : camera_.name;
}

bool RenderedCamera::ready() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return renderer_ != nullptr;
}

core::CameraModel RenderedCamera::model() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return camera_;
}

core::SceneDescription RenderedCamera::scene() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return scene_;
}

Eigen::Isometry3d RenderedCamera::parentFromCamera() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const core::SceneNode* node = scene_.findNode(camera_.frame);
  return node ? node->parent_from_node : Eigen::Isometry3d::Identity();
}

std::string RenderedCamera::parentFrame() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const core::SceneNode* node = scene_.findNode(camera_.frame);
  return node ? node->parent : scene_.world_frame;
}

sensor_msgs::ImagePtr RenderedCamera::render(std::uint32_t seq, core::FrameTransforms* world_from_node) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!renderer_) return nullptr;
  const core::FrameTransforms world = tracker_->worldTransforms();
  const auto camera_pose = world.find(camera_.frame);
  if (camera_pose == world.end()) return nullptr;

  auto image = boost::make_shared<sensor_msgs::Image>();
  image->header.stamp = tracker_->latestStamp();
  image->header.seq = seq;
  image->header.frame_id = camera_.frame;
  image->width = static_cast<std::uint32_t>(camera_.width);
  image->height = static_cast<std::uint32_t>(camera_.height);
  image->encoding = "bgr8";
  image->step = image->width * 3;
  image->data.resize(static_cast<std::size_t>(image->step) * image->height);
  // Render straight into the message's buffer: no copy between renderer and subscribers.
  cv::Mat target(camera_.height, camera_.width, CV_8UC3, image->data.data(), image->step);
  renderer_->render(camera_, camera_pose->second, world, target);
  if (target.data != image->data.data()) {
    throw std::logic_error("the renderer reallocated the image buffer; it must draw into the given image");
  }
  if (world_from_node) *world_from_node = world;
  return image;
}

sensor_msgs::CameraInfo RenderedCamera::info(const std_msgs::Header& header) const {
  const core::CameraModel c = model();
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = static_cast<std::uint32_t>(c.width);
  info.height = static_cast<std::uint32_t>(c.height);
  info.distortion_model = "plumb_bob";
  info.D = {0, 0, 0, 0, 0};
  info.K = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0};
  return info;
}

}  // namespace xpersif
