#include "xpersif/perception/observation.h"

#include "xpersif/component/parameter_reader.h"

#include <cmath>
#include <std_msgs/UInt64MultiArray.h>

namespace xpersif {

Observation::Observation(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : AggregateComponent(nh, private_nh, "xpersif/ObservationNodelet"),
      camera_(addPart<CameraPart>("camera", nh, "overhead",
                                  [this](const RenderedCamera& camera) {
                                    extraction_.setCamera(camera.scene(), camera.model());
                                  })),
      extraction_(addPart<FeatureExtractionPart>("feature_extraction")) {
  addOperation<GetFeatures>(
      features_.contract("the overhead camera", "the overhead camera has produced no feature vector yet"),
      LatestFeatures::validate,
      [this](const GetFeatures::Request& request, GetFeatures::Response& response) { features_.answer(request, response); },
      true, nullptr, LatestFeatures::binder());
}

const core::ParameterTable& Observation::parameters() {
  static const core::ParameterTable table = [] {
    core::ParameterTable own(
        "observation",
        {core::numberParameter("rate", 10.0, 0.1, 1000.0, "Hz of simulated time at which the overhead camera is rendered"),
         core::numberParameter("max_wall_rate", 30.0, 0.1, 1000.0, "realtime and fast modes: at most this many frames per wall second"),
         core::flagParameter("report_buffer_address", false,
                             "test hook: publish each image's buffer address on ~buffer_address (zero-copy checks)"),
         core::textParameter("camera/name", "overhead", "part camera: the scene's camera to render"),
         core::textParameter("camera/scene_topic", "xpersim/scene", "part camera: XPERSim's scene")});
    own.include(FeatureExtractionPart::parameters(), "feature_extraction/").include(LockstepClient::parameters());
    return own;
  }();
  return table;
}

void Observation::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, Observation::parameters());
  const double rate = parameters.get<double>("rate");
  const double max_wall_rate = parameters.get<double>("max_wall_rate");
  const bool report = parameters.get<bool>("report_buffer_address");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    rate_ = rate;
    max_wall_rate_ = max_wall_rate;
    report_address_ = report;
    features_.reset();
    if (!image_pub_) {
      image_pub_ = pnh.advertise<sensor_msgs::Image>("image_raw", 2);
      info_pub_ = pnh.advertise<sensor_msgs::CameraInfo>("camera_info", 2);
      features_pub_ = pnh.advertise<FeatureVector>("features", 10);
      if (report_address_) address_pub_ = pnh.advertise<std_msgs::UInt64MultiArray>("buffer_address", 10);
    }
  }
  AggregateComponent::onConfigure();
}

void Observation::onActivate() {
  AggregateComponent::onActivate();
  lockstep_ = std::make_unique<LockstepClient>(nodeHandle(), privateNodeHandle(), privateNodeHandle().getNamespace(), true);
  if (!lockstep_->enabled()) {
    timer_ = privateNodeHandle().createTimer(ros::Duration(1.0 / rate_), [this](const ros::TimerEvent&) { tick(); });
    return;
  }
  // Lockstep: render at the ticks where a frame is due, from the tick's own /tf frame, then report.
  next_due_ = 0;
  lockstep_->onTick([this](LockstepClient& client, const LockstepClient::Tick& t) {
    // Frames are due on the physics' own time, so idle ticks never shift when the moving world is seen; an
    // idle tick shows the standing world again (to whoever waits for a new frame).
    // The clock waits for a camera only at its frames (the same rule, core::LockstepCoordinator::startTick).
    if (t.epoch != epoch_) {  // the world's state was restored: start the schedule again, as a fresh sensor does
      epoch_ = t.epoch;
      next_due_ = 0;
    }
    if (!t.idle && t.physics_time + 1e-9 < next_due_) return;
    bool published = false;
    auto camera = camera_.camera();
    if (camera && camera->tracker().waitForStamp(t.stamp, 2.0)) published = tick(t.stamp);  // well within the clock's patience
    if (!t.idle) next_due_ = (std::floor(t.physics_time * rate_ + 1e-6) + 1) / rate_;
    client.report(t, false, published, {}, next_due_);
  });
  lockstep_->join();
}

void Observation::onDeactivate() {
  timer_.stop();
  lockstep_.reset();  // leaves the clock
  AggregateComponent::onDeactivate();
}

bool Observation::tick(const ros::Time& lockstep_stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::WallTime now = ros::WallTime::now();
  // The wall-rate cap is for free-running clocks; in lockstep every due frame is rendered.
  if (lockstep_stamp.isZero() && (now - last_wall_).toSec() < 1.0 / max_wall_rate_) return false;
  auto camera = camera_.camera();
  if (!camera || !extraction_.ready()) return false;
  try {
    core::FrameTransforms world;
    sensor_msgs::ImagePtr image = camera->render(seq_ + 1, &world);
    if (!image) return false;
    last_wall_ = now;
    ++seq_;
    const Eigen::Isometry3d world_from_camera = world.at(camera->model().frame);
    auto features = boost::make_shared<FeatureVector>(
        extraction_.extract(*image, world_from_camera, privateNodeHandle().getNamespace()));
    if (report_address_) {
      std_msgs::UInt64MultiArray address;  // [image seq, buffer address the features were extracted from]
      address.data = {image->header.seq, reinterpret_cast<std::uintptr_t>(image->data.data())};
      address_pub_.publish(address);
    }
    image_pub_.publish(image);
    info_pub_.publish(camera->info(image->header));
    features_.set(features);
    features_pub_.publish(features);
    return true;
  } catch (const std::exception& e) {
    reportError(std::string("observation failed: ") + e.what());
  }
  return false;
}

}  // namespace xpersif
