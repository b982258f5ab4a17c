/**
 * @file vision_component.h (ROS side)
 * @brief VISION: the further features FEATURESELECTION asks for, computed for every object of a feature
 *        vector from the image it came from. Images (`~image_topic`, default observation/image_raw) and
 *        vectors (`~features_topic`, default observation/features) are paired by image sequence number and
 *        stamp; images from the same manager arrive as shared pointers and are read in place. The enriched
 *        vector goes out on `~features`; `get_features` returns the latest.
 *
 * Parameters: `~selection_topic` (feature_selection/selection; until a selection arrives, the defaults),
 * `~report_buffer_address` (false), and the `world` file for the arena's extents (distance_to_wall).
 */
#pragma once

#include <sensor_msgs/Image.h>

#include <deque>
#include <mutex>

#include "xpersif/FeatureNames.h"
#include "xpersif/FeatureVector.h"
#include "xpersif/GetFeatures.h"
#include "xpersif/component/component.h"
#include "xpersif/core/perception/vision.h"
#include "xpersif/perception/latest_features.h"

namespace xpersif {

class Vision : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  Vision(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;

 private:
  void onImage(const sensor_msgs::Image::ConstPtr& image);
  void onFeatures(const FeatureVector::ConstPtr& features);
  void onSelection(const FeatureNames::ConstPtr& names);
  /// Pair waiting images and vectors; process each pair once. Caller holds mutex_.
  void matchPending();
  void process(const sensor_msgs::Image& image, const FeatureVector& features);

  std::mutex mutex_;
  core::Vision vision_;
  core::FeatureSelection selection_;
  core::ArenaExtents arena_;
  std::string image_topic_, features_topic_, selection_topic_;
  bool report_address_ = false;
  std::deque<sensor_msgs::Image::ConstPtr> images_;  // shared pointers: no copies
  std::deque<FeatureVector::ConstPtr> vectors_;
  LatestFeatures features_;
  ros::Publisher features_pub_, address_pub_;
  ros::Subscriber image_sub_, features_sub_, selection_sub_;
};

}  // namespace xpersif
