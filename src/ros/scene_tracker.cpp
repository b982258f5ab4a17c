#include "xpersif/ros/scene_tracker.h"

#include <stdexcept>

#include "xpersif/GetScene.h"
#include "xpersif/ResultCode.h"
#include "xpersif/component/message_checks.h"
#include "xpersif/ros/conversions.h"

namespace xpersif {

SceneTracker::SceneTracker(ros::NodeHandle& nh) : nh_(nh) {
  tf_sub_ = nh_.subscribe<tf2_msgs::TFMessage>("/tf", 100, &SceneTracker::onTf, this, ros::TransportHints().tcpNoDelay());
}

xpersif::Scene fetchScene(const std::string& service, double timeout, const std::string& hint) {
  if (!ros::service::waitForService(service, ros::Duration(timeout))) {
    throw std::runtime_error("no scene: " + service + " did not appear within " + core::describeNumber(timeout) +
                             " s" + hint);
  }
  // A viewer started beside the system (as on a multi-host view host) often asks before XPERSim's configure.
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout);
  GetScene call;
  while (!ros::service::call(service, call) || !call.response.success) {
    const bool not_yet = call.response.code == ResultCode::NOT_ACTIVE || call.response.code == ResultCode::UNAVAILABLE;
    if (!not_yet || ros::WallTime::now() > deadline || !ros::ok()) {
      throw std::runtime_error("no scene from " + service + ": " +
                               (call.response.message.empty() ? "it did not answer" : call.response.message));
    }
    ros::WallDuration(0.1).sleep();
    call = GetScene();
  }
  return call.response.scene;
}

void SceneTracker::fetch(const std::string& get_scene_service, double timeout) {
  setScene(fetchScene(get_scene_service, timeout, " (is xpersim running?)"));
}

void SceneTracker::follow(const std::string& scene_topic, std::function<void()> on_scene) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    on_scene_ = std::move(on_scene);
  }
  scene_sub_ = nh_.subscribe<xpersif::Scene>(scene_topic, 1, [this](const xpersif::Scene::ConstPtr& message) {
    try {
      setScene(*message);
    } catch (const std::exception& e) {
      ROS_ERROR_STREAM("scene from " << scene_sub_.getTopic() << " ignored: " << e.what());
      return;
    }
    std::function<void()> callback;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      callback = on_scene_;
    }
    if (callback) callback();
  });
}

void SceneTracker::setScene(const xpersif::Scene& message) {
  core::SceneDescription scene = fromSceneMsg(message);
  core::worldTransforms(scene);  // throws if the node tree is broken
  std::lock_guard<std::mutex> lock(mutex_);
  scene_ = std::move(scene);
  current_.clear();
  has_scene_ = true;
}

bool SceneTracker::hasScene() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return has_scene_;
}

core::SceneDescription SceneTracker::scene() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return scene_;
}

void SceneTracker::onFrame(std::function<void()> callback) {
  std::lock_guard<std::mutex> lock(mutex_);
  on_frame_ = std::move(callback);
}

void SceneTracker::onTf(const tf2_msgs::TFMessage::ConstPtr& message) {
  std::function<void()> callback;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& t : message->transforms) {
      // A client never renders from a non-finite transform, whoever sent it.
      if (!checkVector3("transform", t.transform.translation).empty() ||
          !checkQuaternion("rotation", t.transform.rotation).empty()) {
        continue;
      }
      const core::SceneNode* node = scene_.findNode(t.child_frame_id);
      if (!node || !node->dynamic) continue;
      current_[t.child_frame_id] = fromTransformMsg(t.transform);
      if (t.header.stamp > latest_) latest_ = t.header.stamp;
    }
    ++frames_;
    callback = on_frame_;
  }
  framed_.notify_all();
  if (callback) callback();
}

bool SceneTracker::waitForStamp(const ros::Time& stamp, double timeout) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return framed_.wait_for(lock, std::chrono::duration<double>(timeout), [&] { return latest_ >= stamp; });
}

core::FrameTransforms SceneTracker::worldTransforms() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!has_scene_) return {};
  return core::worldTransforms(scene_, current_);
}

ros::Time SceneTracker::latestStamp() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return latest_;
}

std::uint64_t SceneTracker::framesReceived() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return frames_;
}

}  // namespace xpersif
