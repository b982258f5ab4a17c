#include "xpersif/embodiment/robot_pose_source.h"

#include <cmath>
#include <limits>

#include "xpersif/core/common/validation.h"

namespace xpersif {

namespace {
double yawOf(const geometry_msgs::Quaternion& q) {
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}
}  // namespace

RobotPoseSource::RobotPoseSource(ros::NodeHandle nh, const std::string& odom_topic,
                                 const std::string& observation_topic) {
  nh.setCallbackQueue(&queue_);
  const auto hints = ros::TransportHints().tcpNoDelay();
  odom_sub_ = nh.subscribe(odom_topic, 50, &RobotPoseSource::onOdometry, this, hints);
  observation_sub_ = nh.subscribe(observation_topic, 5, &RobotPoseSource::onObservation, this, hints);
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
}

RobotPoseSource::~RobotPoseSource() {
  spinner_->stop();  // no callback runs while the subscribers go
  odom_sub_.shutdown();
  observation_sub_.shutdown();
}

void RobotPoseSource::onOdometry(const nav_msgs::Odometry::ConstPtr& odom) {
  const auto& p = odom->pose.pose;
  const core::Pose2D pose{p.position.x, p.position.y, yawOf(p.orientation)};
  std::lock_guard<std::mutex> lock(mutex_);
  if (odom->header.stamp < odometry_stamp_) {
    // Time went backwards (a restarted or reset simulator): what was seen on the old clock is no fix and no
    // observation of the world on the new one, and a fix waiting for its odometry would wait for ever.
    pending_fix_.reset();
    observation_.reset();
    correction_.reset();
    last_sighting_.reset();
  }
  try {
    correction_.addOdometry(odom->header.stamp.toSec(), pose);
  } catch (const std::exception& e) {
    ROS_WARN_THROTTLE(5.0, "ignoring odometry: %s", e.what());
    return;
  }
  linear_ = odom->twist.twist.linear.x;
  angular_ = odom->twist.twist.angular.z;
  last_odometry_ = ros::Time::now();
  odometry_stamp_ = odom->header.stamp;
  if (pending_fix_ && odometry_stamp_ >= pending_fix_->header.stamp) applyFix(*pending_fix_);
  arrived_.notify_all();
}

void RobotPoseSource::applyFix(const FeatureVector& features) {
  pending_fix_.reset();
  try {
    const core::Pose2D seen{features.robot.x, features.robot.y, features.robot.theta};
    if (correction_.addFix(features.header.stamp.toSec(), seen).empty()) {
      last_sighting_ = std::make_pair(features.header.stamp, seen);
    }
  } catch (const std::exception& e) {
    ROS_WARN_THROTTLE(5.0, "ignoring a robot fix: %s", e.what());
  }
}

bool RobotPoseSource::waitFor(const ros::Time& stamp, bool observation, double timeout) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return arrived_.wait_for(lock, std::chrono::duration<double>(timeout), [&] {
    return odometry_stamp_ >= stamp &&
           (!observation || (observation_ && observation_->header.stamp >= stamp && !pending_fix_));
  });
}

void RobotPoseSource::onObservation(const FeatureVector::ConstPtr& features) {
  std::lock_guard<std::mutex> lock(mutex_);
  observation_ = features;
  if (features->robot_found) {
    // A fix is matched with the odometry of its own instant: when that has not come yet (the two arrive on
    // separate connections), it waits for it, so the estimate never depends on which came first.
    if (odometry_stamp_ >= features->header.stamp) {
      applyFix(*features);
    } else {
      pending_fix_ = *features;
    }
  }
  arrived_.notify_all();
}

std::string RobotPoseSource::checkSource(const std::string& source) {
  if (source.empty() || source == "odometry" || source == "observation") return "";
  return "pose_source '" + source + "' is not one of: odometry, observation";
}

std::string RobotPoseSource::pose(const std::string& source, core::Pose2D* pose) const {
  const std::string bad = checkSource(source);
  if (!bad.empty()) return bad;
  std::lock_guard<std::mutex> lock(mutex_);
  if (!correction_.hasOdometry()) return "no odometry has arrived yet";
  if (source == "observation") {
    if (!correction_.corrected()) return "the overhead camera has not seen the robot yet: " + whyNotSeen();
    *pose = correction_.estimate();
  } else {
    *pose = correction_.odometry();
  }
  return "";
}

std::string RobotPoseSource::whyNotSeen() const {
  if (!observation_) return "no feature vector of the overhead camera has arrived";
  const FeatureVector& seen = *observation_;
  const std::string from = (seen.source.empty() ? std::string("the overhead camera") : seen.source) + "'s latest " +
                           "feature vector (image of t = " + core::describeNumber(seen.header.stamp.toSec()) + " s)";
  if (!seen.robot_found) {
    return from + " lists the robot as not found (" + std::to_string(seen.objects.size()) + " objects found, " +
           std::to_string(seen.missing.size()) + " missing)";
  }
  if (pending_fix_) return from + " found the robot; that sighting waits for the odometry of its instant";
  return from + " found the robot, but no sighting could be matched with the odometry";
}

std::string RobotPoseSource::poseForCommand(const std::string& source, core::Pose2D* pose_out,
                                            double patience) const {
  if (source == "observation") {
    std::unique_lock<std::mutex> lock(mutex_);
    if (correction_.hasOdometry() && !correction_.corrected()) {
      arrived_.wait_for(lock, std::chrono::duration<double>(patience), [&] { return correction_.corrected(); });
    }
  }
  return pose(source, pose_out);
}

std::optional<std::pair<ros::Time, core::Pose2D>> RobotPoseSource::lastSighting() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_sighting_;
}

void RobotPoseSource::velocity(double* linear, double* angular) const {
  std::lock_guard<std::mutex> lock(mutex_);
  *linear = linear_;
  *angular = angular_;
}

bool RobotPoseSource::hasOdometry() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return correction_.hasOdometry();
}

double RobotPoseSource::odometryAge() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (last_odometry_.isZero()) return std::numeric_limits<double>::infinity();
  return (ros::Time::now() - last_odometry_).toSec();
}

std::optional<FeatureVector> RobotPoseSource::observation(double max_age) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!observation_) return std::nullopt;
  if (max_age > 0 && (ros::Time::now() - observation_->header.stamp).toSec() > max_age) return std::nullopt;
  return *observation_;
}

std::vector<core::Obstacle> sceneObstacles(const FeatureVector& scene,
                                           const std::map<std::string, core::Footprint>& footprints) {
  std::vector<core::Obstacle> result;
  for (const auto& object : scene.objects) {
    const auto footprint = footprints.find(object.name);
    if (footprint == footprints.end()) continue;
    result.push_back({object.name, object.position.x, object.position.y, object.yaw, footprint->second});
  }
  return result;
}

std::vector<core::Obstacle> sceneObstacles(const std::vector<std::string>& names,
                                           const std::vector<geometry_msgs::Pose2D>& poses,
                                           const std::map<std::string, core::Footprint>& footprints) {
  std::vector<core::Obstacle> result;
  for (std::size_t i = 0; i < names.size() && i < poses.size(); ++i) {
    const auto footprint = footprints.find(names[i]);
    if (footprint == footprints.end()) continue;
    result.push_back({names[i], poses[i].x, poses[i].y, poses[i].theta, footprint->second});
  }
  return result;
}

std::vector<core::Obstacle> RobotPoseSource::obstacles(const std::map<std::string, core::Footprint>& footprints,
                                                       double max_age) const {
  const auto seen = observation(max_age);
  return seen ? sceneObstacles(*seen, footprints) : std::vector<core::Obstacle>{};
}

}  // namespace xpersif
