#include "xpersif/camera/sim_camera.h"

#include <opencv2/core.hpp>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/UInt64MultiArray.h>

namespace xpersif {

SimCamera::SimCamera(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/SimCameraNodelet") {}

void SimCamera::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  std::string camera, topic = "/xpersim/scene";
  double rate = 30.0;
  bool report = false;
  if (!pnh.getParam("camera", camera)) throw std::runtime_error("~camera is not set; name a camera of the scene");
  core::requireIdentifier("~camera", camera);
  pnh.param("rate", rate, rate);
  pnh.param("scene_topic", topic, topic);
  pnh.param("report_buffer_address", report, report);
  core::requireInRange("~rate", rate, 0.1, 1000.0);

  std::lock_guard<std::mutex> lock(mutex_);
  camera_ = core::CameraModel();
  camera_.name = camera;
  rate_ = rate;
  report_address_ = report;
  renderer_.reset();
  if (!image_pub_) {
    image_pub_ = pnh.advertise<sensor_msgs::Image>("image_raw", 2);
    info_pub_ = pnh.advertise<sensor_msgs::CameraInfo>("camera_info", 2);
    if (report_address_) address_pub_ = pnh.advertise<std_msgs::UInt64MultiArray>("buffer_address", 10);
  }
  // The scene arrives asynchronously (latched topic): waiting for it here could block a manager thread
  // that the simulator, loaded in the same manager, needs in order to answer.
  tracker_ = std::make_unique<SceneTracker>(nodeHandle());
  tracker_->follow(topic, [this] { onScene(); });
}

void SimCamera::onScene() {
  const core::SceneDescription scene = tracker_->scene();
  std::lock_guard<std::mutex> lock(mutex_);
  const core::CameraModel* model = scene.findCamera(camera_.name);
  if (!model) {
    std::vector<std::string> names;
    for (const auto& c : scene.cameras) names.push_back(c.name);
    reportError(core::checkKnownName("~camera", camera_.name, names));
    return;
  }
  camera_ = *model;
  renderer_ = std::make_unique<core::Renderer>(scene);
}

void SimCamera::onActivate() {
  // ROS time: the camera follows the simulated clock, so it renders at its rate in every clock mode.
  timer_ = privateNodeHandle().createTimer(ros::Duration(1.0 / rate_), [this](const ros::TimerEvent&) {
    renderAndPublish();
  });
}

void SimCamera::onDeactivate() { timer_.stop(); }

void SimCamera::onShutdown() {
  timer_.stop();
  std::lock_guard<std::mutex> lock(mutex_);
  renderer_.reset();
  tracker_.reset();
}

void SimCamera::renderAndPublish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!renderer_ || !tracker_) return;
  // Lazy: nobody listening, nothing rendered.
  if (image_pub_.getNumSubscribers() == 0 && info_pub_.getNumSubscribers() == 0) return;
  const core::FrameTransforms world = tracker_->worldTransforms();
  const auto camera_pose = world.find(camera_.frame);
  if (camera_pose == world.end()) return;

  auto image = boost::make_shared<sensor_msgs::Image>();
  image->header.stamp = tracker_->latestStamp();
  image->header.seq = ++seq_;
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
    reportError("the renderer reallocated the image buffer; it must draw into the given image");
    return;
  }

  sensor_msgs::CameraInfo info;
  info.header = image->header;
  info.width = image->width;
  info.height = image->height;
  info.distortion_model = "plumb_bob";
  info.D = {0, 0, 0, 0, 0};
  info.K = {camera_.fx, 0, camera_.cx, 0, camera_.fy, camera_.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {camera_.fx, 0, camera_.cx, 0, 0, camera_.fy, camera_.cy, 0, 0, 0, 1, 0};
  if (report_address_) {
    std_msgs::UInt64MultiArray address;  // [image seq, buffer address]
    address.data = {image->header.seq, reinterpret_cast<std::uintptr_t>(image->data.data())};
    address_pub_.publish(address);
  }
  image_pub_.publish(image);
  info_pub_.publish(info);
}

}  // namespace xpersif
