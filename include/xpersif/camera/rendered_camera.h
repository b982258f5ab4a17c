/**
 * @file rendered_camera.h
 * @brief One camera of the simulated scene, rendered on the client side (the paper's CAMERA
 *        subcomponent): it follows the latched scene topic and /tf, and renders straight into the buffer
 *        of a new sensor_msgs::Image, so that whoever receives the shared pointer in the same manager
 *        (feature extraction, vision) works on that very buffer.
 *
 * Used by SimCamera (a camera on its own), OBSERVATION (the overhead camera) and PERCEPTION (the robot's
 * camera). Never blocks: the scene arrives asynchronously, and render() returns null until it has.
 * Thread-safe.
 */
#pragma once

#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "xpersif/core/render/renderer.h"
#include "xpersif/ros/scene_tracker.h"

namespace xpersif {

class RenderedCamera {
 public:
  /// @param camera a camera's name, or a mount word (core::kFixedCamera, core::kCameraOnRobot; core::chooseCamera)
  /// @param on_error called (from a callback thread) when the scene has no camera that @p camera chooses
  /// @param on_ready called (from a callback thread) each time a scene with the camera has arrived
  RenderedCamera(ros::NodeHandle nh, std::string camera, const std::string& scene_topic,
              std::function<void(const std::string&)> on_error, std::function<void()> on_ready = nullptr);

  /// The scene and this camera are known (the first scene message has arrived).
  bool ready() const;
  /// Render the camera now (stamp: the newest tf frame); null while not ready or the camera's pose is unknown.
  /// @p world_from_node receives the transforms rendered (may be null).
  sensor_msgs::ImagePtr render(std::uint32_t seq, core::FrameTransforms* world_from_node = nullptr) const;
  sensor_msgs::CameraInfo info(const std_msgs::Header& header) const;

  /// The camera's name in the scene once it is known; until then the name or mount word it was asked for.
  std::string name() const;
  core::CameraModel model() const;
  core::SceneDescription scene() const;
  /// The camera's optical frame, as it hangs from its parent node (fixed: cameras are rigidly mounted).
  Eigen::Isometry3d parentFromCamera() const;
  std::string parentFrame() const;
  const SceneTracker& tracker() const { return *tracker_; }

 private:
  void onScene();

  std::string name_;
  std::function<void(const std::string&)> on_error_;
  std::function<void()> on_ready_;
  mutable std::mutex mutex_;
  core::CameraModel camera_;
  core::SceneDescription scene_;
  std::unique_ptr<core::Renderer> renderer_;
  std::unique_ptr<SceneTracker> tracker_;  // last: its callbacks use the members above
};

}  // namespace xpersif
