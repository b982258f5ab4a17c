/**
 * @file feature_extraction.h
 * @brief FEATUREEXTRACTION as a component of its own: images of one of the scene's cameras in (`~image_topic`,
 *        default camera/image_raw), a feature vector out (`~features`), for any camera, e.g. a SimCamera.
 *        Images arriving as shared pointers from the same manager are read in place, never copied.
 *
 * Parameters: `~camera` (the scene camera the images come from; required), `~scene_topic` (xpersim/scene),
 * `~report_buffer_address` (false). The camera's pose is taken from the scene and /tf at the image's time.
 * Operation: `get_features`.
 */
#pragma once

#include <sensor_msgs/Image.h>

#include <memory>
#include <mutex>

#include "xpersif/GetFeatures.h"
#include "xpersif/component/component.h"
#include "xpersif/perception/feature_extraction_part.h"
#include "xpersif/perception/latest_features.h"
#include "xpersif/ros/scene_tracker.h"

namespace xpersif {

class FeatureExtraction : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  FeatureExtraction(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;

 private:
  void onImage(const sensor_msgs::Image::ConstPtr& image);
  void onScene();

  std::mutex mutex_;
  std::string camera_name_, image_topic_;
  core::CameraModel camera_;
  bool report_address_ = false;
  FeatureExtractionPart extraction_;
  LatestFeatures features_;
  std::unique_ptr<SceneTracker> tracker_;
  ros::Publisher features_pub_, address_pub_;
  ros::Subscriber image_sub_;
};

}  // namespace xpersif
