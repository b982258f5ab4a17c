// The simulator's ground truth for integration tests: the components never read it, the tests check them
// against it.
#pragma once

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cmath>
#include <mutex>
#include <string>

#include "xpersif/BodyPoses.h"

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

}  // namespace xpersif_test
