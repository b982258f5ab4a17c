#include "xpersif/perception/observation.h"

#include "xpersif/component/parameter_reader.h"

#include <std_msgs/UInt64MultiArray.h>

namespace xpersif {

Observation::Observation(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : AggregateComponent(nh, private_nh, "xpersif/ObservationNodelet"),
      camera_(addPart<CameraPart>("camera", nh, core::kFixedCamera,
                                  [this](const RenderedCamera& camera) {
                                    extraction_.setCamera(camera.scene(), camera.model());
                                  })),
      extraction_(addPart<FeatureExtractionPart>("feature_extraction")),
      schedule_(camera_, [this](const ros::Time& lockstep_stamp) { return tick(lockstep_stamp); }) {
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
        {core::numberParameter("rate", 10.0, 0.1, 1000.0, "Hz of simulated time at which the overhead camera is rendered (realtime and fast; lockstep with lockstep_frames periodic)"),
         core::numberParameter("max_wall_rate", 30.0, 0.1, 1000.0, "realtime and fast modes: at most this many frames per wall second"),
         FrameSchedule::modeParameter(),
         core::flagParameter("report_buffer_address", false,
                             "test hook: publish each image's buffer address on ~buffer_address (zero-copy checks)"),
         core::textParameter("camera/name", core::kFixedCamera, "part camera: the scene's camera to render: its name, or fixed (the one camera the robot does not carry)"),
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
  const bool periodic_frames = parameters.get<std::string>("lockstep_frames") == "periodic";
  const bool report = parameters.get<bool>("report_buffer_address");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    rate_ = rate;
    max_wall_rate_ = max_wall_rate;
    periodic_frames_ = periodic_frames;
    report_address_ = report;
    features_.reset();
    frames_.advertise(pnh);
    if (report_address_ && !address_pub_) {
      address_pub_ = pnh.advertise<std_msgs::UInt64MultiArray>("buffer_address", 10);
    }
  }
  AggregateComponent::onConfigure();
}

void Observation::onActivate() {
  AggregateComponent::onActivate();
  schedule_.start(nodeHandle(), privateNodeHandle(), rate_, max_wall_rate_, periodic_frames_);
}

void Observation::onDeactivate() {
  schedule_.stop();
  AggregateComponent::onDeactivate();
}

bool Observation::tick(const ros::Time& lockstep_stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto camera = camera_.camera();
  if (!camera || !extraction_.ready()) return false;
  try {
    core::FrameTransforms world;
    sensor_msgs::ImagePtr image = camera->render(seq_ + 1, &world);
    if (!image) return false;
    ++seq_;
    const Eigen::Isometry3d world_from_camera = world.at(camera->model().frame);
    auto features = boost::make_shared<FeatureVector>(
        extraction_.extract(*image, world_from_camera, privateNodeHandle().getNamespace()));
    if (report_address_) {
      std_msgs::UInt64MultiArray address;  // [image seq, buffer address the features were extracted from]
      address.data = {image->header.seq, reinterpret_cast<std::uintptr_t>(image->data.data())};
      address_pub_.publish(address);
    }
    frames_.publish(image, camera->info(image->header), features, features_);
    return true;
  } catch (const std::exception& e) {
    reportError(std::string("observation failed: ") + e.what());
  }
  return false;
}

}  // namespace xpersif
