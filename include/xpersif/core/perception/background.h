/**
 * @file background.h
 * @brief The empty arena as XPERSim's cameras see it, rendered from the scene: the background model that
 *        FEATUREEXTRACTION subtracts (feature_extractor.h), so that objects of any colour are found by differing
 *        from what lies behind them.
 *
 * A real overhead set-up learns its background from frames of the empty arena; the simulator knows its scene and
 * draws it without the objects and the robot. A fixed camera's background is drawn once; a moving camera's (the
 * robot camera) is drawn again whenever the camera has moved.
 *
 * Thread safety: imageFor() may be called from several threads; the images it returns are shared, read them only.
 */
#pragma once

#include <map>
#include <mutex>
#include <string>

#include "xpersif/core/perception/feature_extractor.h"
#include "xpersif/core/render/renderer.h"

namespace xpersif::core {

class RenderedBackground : public BackgroundModel {
 public:
  /// @throws std::invalid_argument if the scene cannot be rendered (see Renderer)
  explicit RenderedBackground(const SceneDescription& scene, const RenderOptions& options = RenderOptions());

  cv::Mat imageFor(const CameraModel& camera, const Eigen::Isometry3d& world_from_camera) const override;

  /// @p scene without its objects and without the robot (its root link and every node below it).
  static SceneDescription emptyArena(const SceneDescription& scene);

 private:
  struct Cached {
    Eigen::Isometry3d pose;
    cv::Mat image;
  };
  SceneDescription empty_;
  FrameTransforms world_from_node_;
  Renderer renderer_;
  mutable std::mutex mutex_;
  mutable std::map<std::string, Cached> cache_;  // by camera name: the last pose drawn
};

}  // namespace xpersif::core
