/**
 * @file camera_part.h
 * @brief A camera as a part of an aggregate (OBSERVATION's overhead camera, PERCEPTION's robot camera):
 *        a RenderedCamera configured from `~<part>/name` (the scene's camera) and `~<part>/scene_topic`
 *        (default xpersim/scene), which tells its owner when the scene (and with it the camera model)
 *        arrives.
 */
#pragma once

#include <functional>
#include <memory>
#include <mutex>

#include "xpersif/camera/rendered_camera.h"
#include "xpersif/component/aggregate.h"

namespace xpersif {

class CameraPart : public ComponentPart {
 public:
  /// @param on_scene runs (in a callback thread) each time the scene arrives, once the camera is known
  CameraPart(std::string part_name, ros::NodeHandle nh, std::string default_camera,
             std::function<void(const RenderedCamera&)> on_scene)
      : ComponentPart(std::move(part_name)),
        nh_(std::move(nh)),
        default_camera_(std::move(default_camera)),
        on_scene_(std::move(on_scene)) {}

  void configure(const ros::NodeHandle& parameters) override {
    std::string camera = default_camera_, topic = "xpersim/scene";
    parameters.param("name", camera, camera);
    parameters.param("scene_topic", topic, topic);
    core::requireIdentifier(parameters.resolveName("name"), camera);
    shutdown();
    auto scene_camera = std::make_shared<RenderedCamera>(
        nh_, camera, topic,
        [this](const std::string& error) {
          std::lock_guard<std::mutex> lock(mutex_);
          problem_ = error;
        },
        [this] { onReady(); });
    std::lock_guard<std::mutex> lock(mutex_);
    problem_.clear();
    camera_ = std::move(scene_camera);
  }

  void shutdown() override {
    std::shared_ptr<RenderedCamera> old;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      old.swap(camera_);
    }
    old.reset();  // outside the lock: unsubscribing waits for a running scene callback, which takes the lock
  }

  std::string problem() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!problem_.empty()) return problem_;
    return camera_ && camera_->ready() ? "" : "waiting for the scene";
  }

  std::shared_ptr<RenderedCamera> camera() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return camera_;
  }

 private:
  void onReady() {
    std::shared_ptr<RenderedCamera> camera = this->camera();
    if (camera && on_scene_) on_scene_(*camera);
  }

  ros::NodeHandle nh_;
  std::string default_camera_;
  std::function<void(const RenderedCamera&)> on_scene_;
  mutable std::mutex mutex_;
  std::string problem_;
  std::shared_ptr<RenderedCamera> camera_;
};

}  // namespace xpersif
