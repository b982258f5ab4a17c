/**
 * @file perception.h (ROS side)
 * @brief PERCEPTION (aggregate): the robot's own senses — the IR proximity ring, wheel odometry and the
 *        on-board camera — and its own feature-extraction instance, behind one interface.
 *
 * Parts: `ir_ring` (follows `ir`), `odometry` (follows `odom`), `camera` (the scene's robot_camera,
 * rendered on this side) and `feature_extraction`. The camera's pose for measuring comes from odometry
 * (what the robot knows), not from the simulator. At `~rate` Hz of ROS time (at most `~max_wall_rate` of
 * wall time) it publishes `~image_raw`, `~camera_info` and `~features` (objects in the robot's view, world
 * frame, orientation unknown). Operations: `read_ir` (the latest IR reading) and `get_features`.
 */
#pragma once

#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Image.h>

#include <mutex>

#include "xpersif/GetFeatures.h"
#include "xpersif/IrRanges.h"
#include "xpersif/ReadIr.h"
#include "xpersif/component/aggregate.h"
#include "xpersif/perception/camera_part.h"
#include "xpersif/perception/feature_extraction_part.h"
#include "xpersif/perception/frame_publishers.h"
#include "xpersif/perception/frame_schedule.h"
#include "xpersif/perception/latest_features.h"

namespace xpersif {

/// Keeps the newest message of one topic; a problem when none came for `timeout` seconds of ROS time.
template <class Message>
class LatestMessagePart : public ComponentPart {
 public:
  LatestMessagePart(std::string name, ros::NodeHandle nh, std::string topic)
      : ComponentPart(std::move(name)), nh_(std::move(nh)), topic_(std::move(topic)) {}

  void configure(const ros::NodeHandle& parameters) override {
    parameters.param("topic", topic_, topic_);
    parameters.param("timeout", timeout_, timeout_);
    core::requirePositive(parameters.resolveName("timeout"), timeout_);
    sub_ = nh_.subscribe<Message>(topic_, 10, [this](const typename Message::ConstPtr& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      latest_ = m;
      received_ = ros::Time::now();
    });
  }
  void shutdown() override { sub_.shutdown(); }
  std::string problem() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!latest_) return "nothing heard on " + nh_.resolveName(topic_) + " yet";
    if ((ros::Time::now() - received_).toSec() > timeout_) {
      return "nothing heard on " + nh_.resolveName(topic_) + " for more than " + core::describeNumber(timeout_) + " s";
    }
    return "";
  }
  typename Message::ConstPtr latest() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return latest_;
  }

 private:
  ros::NodeHandle nh_;
  std::string topic_;
  double timeout_ = 2.0;
  mutable std::mutex mutex_;
  typename Message::ConstPtr latest_;
  ros::Time received_;
  ros::Subscriber sub_;
};

class Perception : public AggregateComponent {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  Perception(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;

 private:
  void onScene(const RenderedCamera& camera);
  /// Render, extract and publish one frame; true when it published. @p lockstep_stamp: the tick being rendered.
  bool tick(const ros::Time& lockstep_stamp = ros::Time());

  LatestMessagePart<IrRanges>& ir_ring_;
  LatestMessagePart<nav_msgs::Odometry>& odometry_;
  CameraPart& camera_;
  FeatureExtractionPart& extraction_;
  std::mutex mutex_;
  double rate_ = 10.0, max_wall_rate_ = 30.0;
  bool periodic_frames_ = false;  // ~lockstep_frames periodic
  Eigen::Isometry3d base_from_camera_ = Eigen::Isometry3d::Identity();  // fixed mount, from the scene
  double base_height_ = 0;
  bool have_mount_ = false;
  std::uint32_t seq_ = 0;
  LatestFeatures features_;
  FramePublishers frames_;
  FrameSchedule schedule_;  // renders tick() on a timer or at the lockstep clock's due ticks
};

}  // namespace xpersif
