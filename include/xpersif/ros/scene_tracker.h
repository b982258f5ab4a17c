/**
 * @file scene_tracker.h
 * @brief What every client of XPERSim needs to render the scene itself: the scene description and the
 *        latest transforms of its dynamic nodes (from /tf). Thread-safe.
 *
 * Two ways to get the scene: fetch() calls the simulator's get_scene operation and waits (for separate
 * processes such as telesim_view); follow() listens to the latched scene topic and never blocks (for
 * nodelets: a nodelet that blocked a manager thread waiting for another nodelet of the same manager
 * could deadlock it).
 */
#pragma once

#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>

#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>

#include "xpersif/Scene.h"
#include "xpersif/core/common/scene.h"

namespace xpersif {

/// XPERSim's scene from its get_scene operation @p service: waits up to @p timeout s for the operation, then asks
/// again until the same deadline while it is refused NOT_ACTIVE or UNAVAILABLE or does not answer (the simulator
/// offers get_scene before its configure has made the world). Throws std::runtime_error with a sentence (ending
/// in @p hint when the operation never appeared).
xpersif::Scene fetchScene(const std::string& service, double timeout, const std::string& hint = "");

class SceneTracker {
 public:
  /// Subscribes to /tf at once.
  explicit SceneTracker(ros::NodeHandle& nh);

  /// Fetch the scene from @p get_scene_service, waiting up to @p timeout s. @throws std::runtime_error
  void fetch(const std::string& get_scene_service, double timeout);
  /// Take the scene from the latched @p scene_topic whenever it comes; @p on_scene runs after each one.
  void follow(const std::string& scene_topic, std::function<void()> on_scene);

  bool hasScene() const;
  core::SceneDescription scene() const;
  /// world_from_node of every node, with the latest dynamic transforms heard on /tf (empty without a scene).
  core::FrameTransforms worldTransforms() const;
  /// Stamp of the newest /tf frame applied (zero before the first).
  ros::Time latestStamp() const;
  std::uint64_t framesReceived() const;
  /// Wait until a /tf frame stamped at least @p stamp has been applied (lockstep: render the tick's scene).
  /// False after @p timeout wall seconds.
  bool waitForStamp(const ros::Time& stamp, double timeout) const;
  /// Called (in the subscriber's callback thread) after each /tf frame has been applied.
  void onFrame(std::function<void()> callback);

 private:
  void setScene(const xpersif::Scene& message);
  void onTf(const tf2_msgs::TFMessage::ConstPtr& message);

  ros::NodeHandle nh_;
  mutable std::mutex mutex_;
  mutable std::condition_variable framed_;
  bool has_scene_ = false;
  core::SceneDescription scene_;
  core::FrameTransforms current_;  // parent_from_node of dynamic nodes
  ros::Time latest_;
  std::uint64_t frames_ = 0;
  std::function<void()> on_frame_;
  std::function<void()> on_scene_;
  ros::Subscriber scene_sub_;  // handles last: destroyed first
  ros::Subscriber tf_sub_;
};

}  // namespace xpersif
