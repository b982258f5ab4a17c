/**
 * @file robot_tracker.h
 * @brief The robot found from above by its ArUco fiducial (OpenCV's aruco module), as overhead tracking set-ups
 *        find robots whatever they look like, and the robot's silhouette at the pose found, which
 *        FEATUREEXTRACTION cuts out of the image before it looks for the objects (so a black wheel is never taken
 *        for a black object, nor an object touching the robot merged with it).
 *
 * The marker's four corners (refined to sub-pixel) are back-projected onto the plane of its top; their centre and
 * the direction from its bottom edge to its top edge give the marker's pose, and RobotAppearance::fiducial's
 * root_from_marker the root link's. Image conventions as in feature_extractor.h.
 *
 * Thread safety: find() and silhouette() are const and keep no state.
 */
#pragma once

#include <opencv2/aruco.hpp>

#include "xpersif/core/perception/feature_extractor.h"
#include "xpersif/core/render/renderer.h"

namespace xpersif::core {

/// The side of one cell of the robot's fiducial, m: the black square's side / (bits + 2).
/// @throws ValidationError if @p robot has no fiducial or an unknown dictionary
double fiducialCellSize(const RobotAppearance& robot);

class RobotTracker {
 public:
  /// @throws ValidationError if @p robot has no fiducial or an unknown dictionary
  RobotTracker(const RobotAppearance& robot, const CameraModel& camera);

  /// The robot in @p bgr (its fiducial's id); found = false when the marker is not seen.
  RobotDetection find(const cv::Mat& bgr, const Eigen::Isometry3d& world_from_camera) const;

  /// The robot's silhouette drawn at @p robot's pose (CV_8U, 255 where the robot is), grown by @p margin pixels.
  cv::Mat silhouette(const RobotDetection& robot, const Eigen::Isometry3d& world_from_camera, int margin) const;

  /// Pixels across one cell of the marker (the black square's side / (bits + 2)) seen at camera depth @p depth.
  double cellPixels(double depth) const;

 private:
  RobotAppearance robot_;
  CameraModel camera_;
  cv::Ptr<cv::aruco::Dictionary> dictionary_;
  cv::Ptr<cv::aruco::DetectorParameters> parameters_;
  SceneDescription body_;  // one node, "robot", with every part of the robot in white
  Renderer renderer_;
};

}  // namespace xpersif::core
