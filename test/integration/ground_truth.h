// The simulator's ground truth for integration tests: the components never read it, the tests check them
// against it.
#pragma once

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cmath>
#include <mutex>
#include <string>

#include <vector>

#include "xpersif/BodyPoses.h"
#include "xpersif/ComponentStatus.h"
#include "xpersif/GetFeatures.h"
#include "xpersif/GetState.h"
#include "xpersif/SetPose.h"

namespace xpersif_test {

struct Planar {
  double x = 0, y = 0, yaw = 0;
};

inline double wrap(double a) { return std::remainder(a, 2 * M_PI); }
inline double yawOf(const geometry_msgs::Quaternion& q) {
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

class GroundTruth {
 public:
  explicit GroundTruth(ros::NodeHandle& nh, const std::string& topic = "/xpersif/xpersim/ground_truth") {
    sub_ = nh.subscribe<xpersif::BodyPoses>(topic, 10, [this](const xpersif::BodyPoses::ConstPtr& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      latest_ = m;
    });
  }
  bool ready() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return latest_ != nullptr;
  }
  Planar pose(const std::string& body) const {
    std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = 0; latest_ && i < latest_->names.size(); ++i) {
      if (latest_->names[i] != body) continue;
      const auto& p = latest_->poses[i];
      return {p.position.x, p.position.y, yawOf(p.orientation)};
    }
    ADD_FAILURE() << "no ground truth for " << body;
    return {};
  }
  double speed(const std::string& body) const {
    std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = 0; latest_ && i < latest_->names.size(); ++i) {
      if (latest_->names[i] == body) return std::hypot(latest_->velocities[i].linear.x, latest_->velocities[i].linear.y);
    }
    return NAN;
  }

 private:
  mutable std::mutex mutex_;
  xpersif::BodyPoses::ConstPtr latest_;
  ros::Subscriber sub_;
};

/// True when every component under @p ns answers get_state with ACTIVE; else @p which names the first that does not.
inline bool allActive(const std::string& ns, const std::vector<std::string>& components, std::string* which) {
  for (const auto& c : components) {
    xpersif::GetState state;
    if (!ros::service::call(ns + c + "/get_state", state) || state.response.state != xpersif::ComponentStatus::ACTIVE) {
      *which = c;
      return false;
    }
  }
  return true;
}

/// @p service (a get_features operation) answers with a vector at most a second old.
inline bool featuresFresh(const std::string& service) {
  xpersif::GetFeatures f;
  f.request.max_age = 1.0;
  return ros::service::call(service, f) && f.response.success;
}

/// Put the robot (or an object) somewhere through XPERSim's set_pose operation, then let the overhead camera see
/// the new scene. "" or what went wrong.
inline std::string place(const std::string& ns, const std::string& body, double x, double y, double yaw) {
  xpersif::SetPose call;
  call.request.name = body;
  call.request.pose.position.x = x;
  call.request.pose.position.y = y;
  call.request.pose.orientation.z = std::sin(yaw / 2);
  call.request.pose.orientation.w = std::cos(yaw / 2);
  call.request.on_floor = true;
  if (!ros::service::call(ns + "xpersim/set_pose", call)) return ns + "xpersim/set_pose did not answer";
  if (!call.response.success) return call.response.message;
  ros::Duration(0.5).sleep();
  return "";
}

}  // namespace xpersif_test
