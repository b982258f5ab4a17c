/**
 * @file frame_publishers.h
 * @brief What a camera component (OBSERVATION, PERCEPTION) publishes for each frame: ~image_raw, ~camera_info and
 *        ~features, the features also kept as the latest for get_features. One copy for both components.
 */
#pragma once

#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "xpersif/FeatureVector.h"
#include "xpersif/perception/latest_features.h"

namespace xpersif {

class FramePublishers {
 public:
  /// Advertise the three topics under @p private_nh; a component configured again keeps the ones it has.
  void advertise(ros::NodeHandle& private_nh);
  /// Publish a frame, its camera's info and the features extracted from it, after keeping them in @p latest.
  void publish(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfo& info,
               const FeatureVector::ConstPtr& features, LatestFeatures& latest);

 private:
  ros::Publisher image_, info_, features_;
};

}  // namespace xpersif
