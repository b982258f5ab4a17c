// Small helpers shared by the rostest integration tests.
#pragma once

#include <ros/ros.h>

#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "xpersif/ComponentEvent.h"
#include "xpersif/ComponentStatus.h"
#include "xpersif/Transition.h"

namespace xpersif_test {

/// Poll @p condition (callbacks run on an AsyncSpinner) until it holds or @p timeout wall seconds pass.
inline bool waitFor(const std::function<bool()>& condition, double timeout) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::WallTime::now() < end) {
    if (condition()) return true;
    ros::WallDuration(0.01).sleep();
  }
  return condition();
}

/// Records every message of a topic.
template <class Message>
class Recorder {
 public:
  Recorder(ros::NodeHandle& nh, const std::string& topic) {
    sub_ = nh.subscribe<Message>(topic, 1000, [this](const typename Message::ConstPtr& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      messages_.push_back(*m);
    });
  }
  std::vector<Message> messages() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return messages_;
  }
  bool waitForConnection(double timeout) {
    return waitFor([this] { return sub_.getNumPublishers() > 0; }, timeout);
  }
  /// Wait for a message that satisfies @p match; return it (or a default message if none came).
  bool waitForMatch(const std::function<bool(const Message&)>& match, double timeout, Message* found = nullptr) {
    return waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          for (const auto& m : messages_) {
            if (match(m)) {
              if (found) *found = m;
              return true;
            }
          }
          return false;
        },
        timeout);
  }

 private:
  mutable std::mutex mutex_;
  std::vector<Message> messages_;
  ros::Subscriber sub_;  // last: destroyed first, so no callback runs on destroyed members
};

/// ros::service::call, asked again (up to @p attempts times) when the call fails in transport. roscpp's non-persistent
/// calls fail now and then when the server closes the connection as the client starts reading (ros/ros_comm#1976):
/// test_decision saw one in a CI run. Tests of what a service answers should not fail on that; what a refusal or an
/// error means is in the response, which this never hides.
template <class Service>
bool callService(const std::string& name, Service& service, int attempts = 3) {
  for (int attempt = 1; attempt <= attempts; ++attempt) {
    if (ros::service::call(name, service)) return true;
    ROS_WARN("call of %s failed in transport (attempt %d of %d)", name.c_str(), attempt, attempts);
    ros::WallDuration(0.1).sleep();
  }
  return false;
}

inline xpersif::Transition::Response transition(const std::string& component, const std::string& verb) {
  xpersif::Transition call;
  const std::string service = component + "/" + verb;
  if (!ros::service::waitForService(service, ros::Duration(20.0)) || !callService(service, call)) {
    call.response.success = false;
    call.response.message = "service " + service + " did not answer";
  }
  return call.response;
}

}  // namespace xpersif_test
