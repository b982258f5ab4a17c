#include "xpersif/perception/feature_extraction.h"

#include "xpersif/component/parameter_reader.h"

#include <std_msgs/UInt64MultiArray.h>


namespace xpersif {

FeatureExtraction::FeatureExtraction(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/FeatureExtractionNodelet") {
  addOperation<GetFeatures>(
      features_.contract("feature extraction", "no image has been processed yet"), LatestFeatures::validate,
      [this](const GetFeatures::Request& request, GetFeatures::Response& response) { features_.answer(request, response); },
      true, nullptr, LatestFeatures::binder());
}

const core::ParameterTable& FeatureExtraction::parameters() {
  static const core::ParameterTable table = [] {
    core::ParameterTable own(
        "feature_extraction",
        {core::textParameter("camera", "", "the scene's camera the images come from: its name, or fixed (the one camera the robot does not carry) or on_robot (the one it carries); required"),
         core::textParameter("image_topic", "camera/image_raw", "the images to extract features from"),
         core::textParameter("scene_topic", "xpersim/scene", "XPERSim's scene"),
         core::flagParameter("report_buffer_address", false,
                             "test hook: publish each image's buffer address on ~buffer_address (zero-copy checks)")});
    own.include(FeatureExtractionPart::parameters(), "feature_extraction/");
    return own;
  }();
  return table;
}

void FeatureExtraction::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, FeatureExtraction::parameters());
  if (!parameters.has("camera")) throw std::runtime_error("~camera is not set; name the scene camera the images come from");
  const std::string camera = parameters.get<std::string>("camera");
  core::requireIdentifier("~camera", camera);
  const std::string image_topic = parameters.get<std::string>("image_topic");
  const std::string scene_topic = parameters.get<std::string>("scene_topic");
  const bool report = parameters.get<bool>("report_buffer_address");
  extraction_.configure(ros::NodeHandle(pnh, "feature_extraction"));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    camera_name_ = camera;
    image_topic_ = image_topic;
    report_address_ = report;
    features_.reset();
    if (!features_pub_) {
      features_pub_ = pnh.advertise<FeatureVector>("features", 10);
      if (report_address_) address_pub_ = pnh.advertise<std_msgs::UInt64MultiArray>("buffer_address", 10);
    }
  }
  tracker_ = std::make_unique<SceneTracker>(nodeHandle());
  tracker_->follow(scene_topic, [this] { onScene(); });
}

void FeatureExtraction::onScene() {
  const core::SceneDescription scene = tracker_->scene();
  std::string name;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    name = camera_name_;
  }
  std::string problem;
  const core::CameraModel* model = core::chooseCamera(scene, name, problem);
  if (!model) {
    reportError("~camera: " + problem);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    camera_ = *model;
  }
  extraction_.setCamera(scene, *model);
}

void FeatureExtraction::onActivate() {
  image_sub_ = nodeHandle().subscribe<sensor_msgs::Image>(image_topic_, 2, &FeatureExtraction::onImage, this);
}

void FeatureExtraction::onDeactivate() { image_sub_.shutdown(); }

void FeatureExtraction::onShutdown() {
  image_sub_.shutdown();
  tracker_.reset();
  extraction_.shutdown();
}

void FeatureExtraction::onImage(const sensor_msgs::Image::ConstPtr& image) {
  if (!extraction_.ready() || !tracker_) return;
  std::string frame;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    frame = camera_.frame;
  }
  const core::FrameTransforms world = tracker_->worldTransforms();
  const auto pose = world.find(frame);
  if (pose == world.end()) return;
  try {
    auto features = boost::make_shared<FeatureVector>(
        extraction_.extract(*image, pose->second, privateNodeHandle().getNamespace()));
    std::lock_guard<std::mutex> lock(mutex_);
    if (report_address_) {
      std_msgs::UInt64MultiArray address;  // [image seq, address of the buffer the features came from]
      address.data = {image->header.seq, reinterpret_cast<std::uintptr_t>(image->data.data())};
      address_pub_.publish(address);
    }
    features_.set(features);
    features_pub_.publish(features);
  } catch (const core::ValidationError& e) {
    // One bad image is the sender's fault, not ours: say so and go on.
    ROS_WARN_THROTTLE(5.0, "%s: skipping an image: %s", name().c_str(), e.what());
  } catch (const std::exception& e) {
    reportError(std::string("feature extraction failed: ") + e.what());
  }
}

}  // namespace xpersif
