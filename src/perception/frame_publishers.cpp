#include "xpersif/perception/frame_publishers.h"

namespace xpersif {

void FramePublishers::advertise(ros::NodeHandle& private_nh) {
  if (image_) return;
  image_ = private_nh.advertise<sensor_msgs::Image>("image_raw", 2);
  info_ = private_nh.advertise<sensor_msgs::CameraInfo>("camera_info", 2);
  features_ = private_nh.advertise<FeatureVector>("features", 10);
}

void FramePublishers::publish(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfo& info,
                              const FeatureVector::ConstPtr& features, LatestFeatures& latest) {
  image_.publish(image);
  info_.publish(info);
  latest.set(features);
  features_.publish(features);
}

}  // namespace xpersif
