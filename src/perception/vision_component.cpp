#include "xpersif/perception/vision_component.h"

#include "xpersif/component/parameter_reader.h"

#include <std_msgs/UInt64MultiArray.h>

#include "xpersif/embodiment/embodiment_setup.h"
#include "xpersif/perception/feature_extraction_part.h"

namespace xpersif {

namespace {
constexpr std::size_t kPending = 8;  // images or vectors waiting for their partner
}

Vision::Vision(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/VisionNodelet") {
  addOperation<GetFeatures>(
      features_.contract("vision (with the selected features)", "no image and feature vector pair has been processed yet"),
      LatestFeatures::validate,
      [this](const GetFeatures::Request& request, GetFeatures::Response& response) { features_.answer(request, response); },
      true, nullptr, LatestFeatures::binder());
}

const core::ParameterTable& Vision::parameters() {
  static const core::ParameterTable table(
      "vision",
      {core::textParameter("image_topic", "observation/image_raw", "the images VISION measures in"),
       core::textParameter("features_topic", "observation/features", "FEATUREEXTRACTION's detections in those images"),
       core::textParameter("selection_topic", "feature_selection/selection",
                           "FEATURESELECTION's choice of features (until one arrives, the defaults)"),
       core::flagParameter("report_buffer_address", false,
                           "test hook: publish each image's buffer address on ~buffer_address (zero-copy checks)")});
  return table;
}

void Vision::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, Vision::parameters());
  const std::string image_topic = parameters.get<std::string>("image_topic");
  const std::string features_topic = parameters.get<std::string>("features_topic");
  const std::string selection_topic = parameters.get<std::string>("selection_topic");
  const bool report = parameters.get<bool>("report_buffer_address");
  const EmbodimentSetup setup = loadEmbodimentSetup(nodeHandle());
  std::lock_guard<std::mutex> lock(mutex_);
  image_topic_ = image_topic;
  features_topic_ = features_topic;
  selection_topic_ = selection_topic;
  report_address_ = report;
  arena_.size_x = setup.arena.size_x;
  arena_.size_y = setup.arena.size_y;
  selection_.reset();
  images_.clear();
  vectors_.clear();
  features_.reset();
  if (!features_pub_) {
    features_pub_ = pnh.advertise<FeatureVector>("features", 10);
    if (report_address_) address_pub_ = pnh.advertise<std_msgs::UInt64MultiArray>("buffer_address", 10);
  }
}

void Vision::onActivate() {
  ros::NodeHandle& nh = nodeHandle();
  selection_sub_ = nh.subscribe<FeatureNames>(selection_topic_, 1, &Vision::onSelection, this);
  image_sub_ = nh.subscribe<sensor_msgs::Image>(image_topic_, 4, &Vision::onImage, this);
  features_sub_ = nh.subscribe<FeatureVector>(features_topic_, 4, &Vision::onFeatures, this);
}

void Vision::onDeactivate() {
  image_sub_.shutdown();
  features_sub_.shutdown();
  selection_sub_.shutdown();
}

void Vision::onSelection(const FeatureNames::ConstPtr& names) {
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    if (names->names.empty()) {
      selection_.reset();
    } else {
      selection_.set(names->names);
    }
  } catch (const std::exception& e) {
    ROS_WARN("%s: ignoring a selection: %s", name().c_str(), e.what());
  }
}

void Vision::onImage(const sensor_msgs::Image::ConstPtr& image) {
  std::lock_guard<std::mutex> lock(mutex_);
  images_.push_back(image);
  if (images_.size() > kPending) images_.pop_front();
  matchPending();
}

void Vision::onFeatures(const FeatureVector::ConstPtr& features) {
  std::lock_guard<std::mutex> lock(mutex_);
  vectors_.push_back(features);
  if (vectors_.size() > kPending) vectors_.pop_front();
  matchPending();
}

void Vision::matchPending() {
  for (auto v = vectors_.begin(); v != vectors_.end();) {
    auto i = std::find_if(images_.begin(), images_.end(), [&](const sensor_msgs::Image::ConstPtr& image) {
      return image->header.seq == (*v)->header.seq && image->header.stamp == (*v)->header.stamp;
    });
    if (i == images_.end()) {
      ++v;
      continue;
    }
    process(**i, **v);
    images_.erase(i);
    v = vectors_.erase(v);
  }
}

void Vision::process(const sensor_msgs::Image& image, const FeatureVector& features) {
  try {
    const core::Detections detections = fromFeatureVector(features);
    const auto values = vision_.compute(viewOf(image), detections, selection_, arena_);
    auto out = boost::make_shared<FeatureVector>(features);
    out->source = privateNodeHandle().getNamespace();
    for (auto& object : out->objects) {
      const auto found = values.find(object.name);
      if (found == values.end()) continue;
      for (const auto& name : selection_.names()) {
        const auto value = found->second.find(name);
        if (value == found->second.end()) continue;
        object.feature_names.push_back(name);
        object.feature_values.push_back(value->second);
      }
    }
    if (report_address_) {
      std_msgs::UInt64MultiArray address;  // [image seq, address of the buffer the features came from]
      address.data = {image.header.seq, reinterpret_cast<std::uintptr_t>(image.data.data())};
      address_pub_.publish(address);
    }
    features_.set(out);
    features_pub_.publish(out);
  } catch (const core::ValidationError& e) {
    ROS_WARN_THROTTLE(5.0, "%s: skipping an image: %s", name().c_str(), e.what());
  } catch (const std::exception& e) {
    reportError(std::string("vision failed: ") + e.what());
  }
}

}  // namespace xpersif
