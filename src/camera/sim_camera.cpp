#include "xpersif/camera/sim_camera.h"

#include "xpersif/component/parameter_reader.h"

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/UInt64MultiArray.h>

namespace xpersif {

SimCamera::SimCamera(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/SimCameraNodelet") {}

const core::ParameterTable& SimCamera::parameters() {
  static const core::ParameterTable table(
      "sim_camera",
      {core::textParameter("camera", "", "the scene's camera to render: its name, or fixed (the one camera the robot does not carry) or on_robot (the one it carries); required"),
       core::numberParameter("rate", 30.0, 0.1, 1000.0, "Hz of simulated time"),
       core::textParameter("scene_topic", "xpersim/scene", "XPERSim's scene"),
       core::flagParameter("report_buffer_address", false,
                           "test hook: publish each image's buffer address on ~buffer_address (zero-copy checks)")});
  return table;
}

void SimCamera::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, SimCamera::parameters());
  if (!parameters.has("camera")) throw std::runtime_error("~camera is not set; name a camera of the scene");
  const std::string camera = parameters.get<std::string>("camera");
  core::requireIdentifier("~camera", camera);
  const double rate = parameters.get<double>("rate");
  const std::string topic = parameters.get<std::string>("scene_topic");
  const bool report = parameters.get<bool>("report_buffer_address");

  std::lock_guard<std::mutex> lock(mutex_);
  rate_ = rate;
  report_address_ = report;
  if (!image_pub_) {
    image_pub_ = pnh.advertise<sensor_msgs::Image>("image_raw", 2);
    info_pub_ = pnh.advertise<sensor_msgs::CameraInfo>("camera_info", 2);
    if (report_address_) address_pub_ = pnh.advertise<std_msgs::UInt64MultiArray>("buffer_address", 10);
  }
  // The scene arrives asynchronously (latched topic): waiting for it here could block a manager thread
  // that the simulator, loaded in the same manager, needs in order to answer.
  camera_ = std::make_unique<RenderedCamera>(nodeHandle(), camera, topic,
                                          [this](const std::string& error) { reportError(error); });
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
  camera_.reset();
}

void SimCamera::renderAndPublish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!camera_) return;
  // Lazy: nobody listening, nothing rendered.
  if (image_pub_.getNumSubscribers() == 0 && info_pub_.getNumSubscribers() == 0) return;
  sensor_msgs::ImagePtr image;
  try {
    image = camera_->render(seq_ + 1);
  } catch (const std::exception& e) {
    reportError(e.what());
    return;
  }
  if (!image) return;
  ++seq_;
  if (report_address_) {
    std_msgs::UInt64MultiArray address;  // [image seq, buffer address]
    address.data = {image->header.seq, reinterpret_cast<std::uintptr_t>(image->data.data())};
    address_pub_.publish(address);
  }
  image_pub_.publish(image);
  info_pub_.publish(camera_->info(image->header));
}

}  // namespace xpersif
