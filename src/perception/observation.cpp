#include "xpersif/perception/observation.h"

#include <std_msgs/UInt64MultiArray.h>

namespace xpersif {

core::Contract getFeaturesContract(const std::string& what) {
  core::Contract c;
  c.name = "get_features";
  c.kind = core::Contract::Kind::Operation;
  c.interface_type = "xpersif/GetFeatures";
  c.description = "the latest feature vector from " + what;
  c.preconditions = {{"perceived(scene)", "a feature vector must have been produced"}};
  c.effects = {"observed(scene)"};
  return c;
}

void answerGetFeatures(const FeatureVector::ConstPtr& latest, const GetFeatures::Request& request,
                       GetFeatures::Response& response) {
  if (!latest) throw std::runtime_error("no feature vector yet");
  if (request.max_age > 0) {
    const double age = (ros::Time::now() - latest->header.stamp).toSec();
    if (age > request.max_age) {
      throw std::runtime_error("the latest feature vector is " + core::describeNumber(age) + " s old, more than max_age " +
                               core::describeNumber(request.max_age) + " s");
    }
  }
  response.features = *latest;
}

Observation::Observation(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : AggregateComponent(nh, private_nh, "xpersif/ObservationNodelet"),
      camera_(addPart<CameraPart>("camera", nh, "overhead",
                                  [this](const RenderedCamera& camera) {
                                    extraction_.setCamera(camera.scene(), camera.model());
                                  })),
      extraction_(addPart<FeatureExtractionPart>("feature_extraction")) {
  ContractChecker<GetFeatures::Request> contract(getFeaturesContract("the overhead camera"));
  contract.check("perceived(scene)", [this](const GetFeatures::Request&) {
    std::lock_guard<std::mutex> lock(mutex_);
    return latest_ ? std::string() : "the overhead camera has produced no feature vector yet";
  });
  addOperation<GetFeatures>(
      contract, [](const GetFeatures::Request& r) { core::requireInRange("max_age", r.max_age, 0.0, 1e6); },
      [this](const GetFeatures::Request& request, GetFeatures::Response& response) {
        FeatureVector::ConstPtr latest;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          latest = latest_;
        }
        answerGetFeatures(latest, request, response);
      });
}

void Observation::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  double rate = 10.0, max_wall_rate = 30.0;
  bool report = false;
  pnh.param("rate", rate, rate);
  pnh.param("max_wall_rate", max_wall_rate, max_wall_rate);
  pnh.param("report_buffer_address", report, report);
  core::requireInRange("~rate", rate, 0.1, 1000.0);
  core::requireInRange("~max_wall_rate", max_wall_rate, 0.1, 1000.0);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    rate_ = rate;
    max_wall_rate_ = max_wall_rate;
    report_address_ = report;
    latest_.reset();
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
  timer_ = privateNodeHandle().createTimer(ros::Duration(1.0 / rate_), [this](const ros::TimerEvent&) { tick(); });
}

void Observation::onDeactivate() {
  timer_.stop();
  AggregateComponent::onDeactivate();
}

void Observation::tick() {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::WallTime now = ros::WallTime::now();
  if ((now - last_wall_).toSec() < 1.0 / max_wall_rate_) return;
  auto camera = camera_.camera();
  if (!camera || !extraction_.ready()) return;
  try {
    core::FrameTransforms world;
    sensor_msgs::ImagePtr image = camera->render(seq_ + 1, &world);
    if (!image) return;
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
    latest_ = features;
    features_pub_.publish(features);
  } catch (const std::exception& e) {
    reportError(std::string("observation failed: ") + e.what());
  }
}

}  // namespace xpersif
