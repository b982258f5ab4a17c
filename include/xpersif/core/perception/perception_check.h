/**
 * @file perception_check.h
 * @brief Whether the cameras of a scene can perceive it well enough for the loop to run, checked before it runs:
 *        each downward camera against the arena (does every object and the robot's marker cover enough pixels
 *        at the arena's far corner?), and the start scene rendered and run through the same FEATUREEXTRACTION as
 *        the loop (found or not, how far off, and why not). `xpersif check-world` and `xpersif_experiment check`
 *        (so scripts/run.sh and experiment.launch) refuse a world the loop could not run in, with the sentence.
 */
#pragma once

#include <string>
#include <vector>

#include "xpersif/core/perception/feature_extractor.h"

namespace xpersif::core {

/// One object or the robot as one camera perceived it.
struct PerceivedThing {
  std::string name;
  bool found = false;
  double position_error = 0;  ///< m, horizontal
  bool yaw_checked = false;   ///< the camera measured an orientation to compare
  double yaw_error = 0;       ///< rad, modulo the shape's symmetry
  std::string reason;         ///< why not found, or why it is too far off ("" = fine)
};

struct CameraPerception {
  std::string camera;
  bool downward = false;   ///< the loop's overhead view: everything must be found there
  std::string refusal;     ///< the camera cannot be used at all (too coarse, no extractor): the sentence
  std::vector<PerceivedThing> objects;
  bool robot_looked_for = false;
  PerceivedThing robot;
};

struct PerceptionCheck {
  std::vector<CameraPerception> cameras;
  /// The first reason the loop could not run ("" = it can): a downward camera refused, or an object or the robot
  /// not found or too far off in it. One sentence naming the camera, the thing and the cause.
  std::string problem() const;
  /// One line per camera and thing: found, errors, reasons.
  std::string describe() const;
};

/// Fewest pixels across an object's top (its smallest side) that FEATUREEXTRACTION measures from above.
constexpr double kMinObjectPixelsAcross = 6;
/// Fewest pixels across one cell of a fiducial (ArUco reads its bits from the cells' centres).
constexpr double kMinFiducialCellPixels = 3;
/// Fewest pixels a coloured heading marker's top covers (its blob loses edge pixels to shading and the body).
constexpr double kMinMarkerPixels = 8;

/**
 * @brief A downward camera against the arena: every arena corner in view, and every object's smallest side and
 *        the robot's fiducial cells (or heading marker) wide enough in pixels at the arena corner farthest from the
 *        camera. "" when the camera is fine, else a sentence with the pixels seen, the pixels needed and the focal
 *        length (and image size, for the same view) that would do.
 */
std::string checkCoverage(const PerceptionCatalogue& catalogue, const CameraModel& camera,
                          const Eigen::Isometry3d& world_from_camera, double arena_size_x, double arena_size_y);

/**
 * @brief Renders @p scene with its nodes at @p current (dynamic nodes' poses; the scene's own where missing) from
 *        every camera and runs FEATUREEXTRACTION (with the rendered empty arena as background) on each image,
 *        comparing with the true poses.
 */
PerceptionCheck checkPerception(const SceneDescription& scene, const FrameTransforms& current,
                                const PerceptionOptions& options = PerceptionOptions());

}  // namespace xpersif::core
