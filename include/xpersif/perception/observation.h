/**
 * @file observation.h
 * @brief OBSERVATION (aggregate): the overhead camera as a service to the robot (where everything is,
 *        from the image alone) and to people (the image itself), with its own feature-extraction instance.
 *
 * Parts: `camera` (the scene's overhead camera, rendered on this side) and `feature_extraction`.
 * At `~rate` Hz of ROS time (at most `~max_wall_rate` Hz of wall time, so that a simulator running faster
 * than real time does not flood it) it renders the camera straight into an image message, extracts the
 * objects and the robot from that same buffer, and publishes `~image_raw`, `~camera_info` and `~features`
 * (xpersif/FeatureVector). Operation `get_features` returns the latest vector (latest_features.h).
 * `~report_buffer_address` (default false) publishes [image seq, buffer address] on `~buffer_address`
 * for the zero-copy test.
 */
#pragma once

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <mutex>

#include "xpersif/GetFeatures.h"
#include "xpersif/component/aggregate.h"
#include "xpersif/perception/camera_part.h"
#include "xpersif/perception/feature_extraction_part.h"
#include "xpersif/perception/frame_publishers.h"
#include "xpersif/perception/frame_schedule.h"
#include "xpersif/perception/latest_features.h"

namespace xpersif {

class Observation : public AggregateComponent {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  Observation(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;

 private:
  /// Render, extract and publish one frame; true when it published. @p lockstep_stamp: the tick being rendered.
  bool tick(const ros::Time& lockstep_stamp = ros::Time());

  CameraPart& camera_;
  FeatureExtractionPart& extraction_;
  std::mutex mutex_;
  double rate_ = 10.0, max_wall_rate_ = 30.0;
  bool periodic_frames_ = false;  // ~lockstep_frames periodic
  bool report_address_ = false;
  std::uint32_t seq_ = 0;
  LatestFeatures features_;
  FramePublishers frames_;
  ros::Publisher address_pub_;  // test hook: each image's buffer address
  FrameSchedule schedule_;  // renders tick() on a timer or at the lockstep clock's due ticks
};

}  // namespace xpersif
