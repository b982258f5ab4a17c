/**
 * @file vision.h
 * @brief FEATURESELECTION and VISION, ROS-free: which parametrised features to compute for each detected object,
 *        and computing them from the image and FEATUREEXTRACTION's detections (perception.h).
 *
 * FEATURESELECTION holds a validated list of feature names (availableFeatures() lists them with units).
 * VISION computes them per detection: colour from the object's top-face pixels (the whole blob when the
 * top face is unknown, as with a forward camera), size, area, orientation and elongation from the
 * back-projected top face, and relations to the robot and the arena walls from the measured positions.
 * A feature that cannot be measured for a detection (e.g. orientation from a forward camera, distance to a
 * robot that was not found) is NaN rather than missing, so every object's vector has the same keys.
 */
#pragma once

#include <opencv2/core.hpp>

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "xpersif/core/perception/feature_extractor.h"
#include "xpersif/core/common/pose2d.h"

namespace xpersif::core {

struct FeatureInfo {
  std::string name;         ///< e.g. "hue"
  std::string unit;         ///< e.g. "deg", "m", "rad", "1"
  std::string description;  ///< one sentence
};

/**
 * @brief Every feature VISION can compute, in a fixed order:
 *        x, y (m, world), hue (deg, 0..360), saturation (1), color_r, color_g, color_b (0..1, mean of the top
 *        face's pixels), size (m, mean edge of the top face), area (m^2, top face), orientation (rad, yaw modulo
 *        the object's symmetry), elongation (1, long side / short side), distance_to_robot (m, centre to the
 *        robot's centre), bearing_from_robot (rad, in the robot's frame, +left), distance_to_wall (m, centre to
 *        the nearest inner wall face), confidence (1, the detection's).
 */
const std::vector<FeatureInfo>& availableFeatures();

/**
 * @brief The features that describe the object itself — what it looks like and its shape: hue, saturation,
 *        color_r, color_g, color_b, size, area, elongation (in availableFeatures() order). FEATURESELECTION ranks
 *        these as the learner's inputs. Not among them: x, y and orientation (where the object happens to be, which
 *        the push frame already factors out), distance_to_robot, bearing_from_robot and distance_to_wall (the
 *        moment's relations, not the object), and confidence (how well it was seen).
 */
const std::vector<std::string>& objectFeatureNames();

/// FEATURESELECTION: which features to compute. Names are unique, in the order given.
class FeatureSelection {
 public:
  /// The default selection (defaultNames()).
  FeatureSelection();
  /// @throws ValidationError as set()
  explicit FeatureSelection(const std::vector<std::string>& names);

  /// Replace the selection. Duplicates are dropped (first occurrence kept).
  /// @throws ValidationError if a name is unknown (the sentence lists the known ones) or @p names is empty;
  ///         the selection is unchanged then
  void set(const std::vector<std::string>& names);
  /// Back to defaultNames().
  void reset();

  const std::vector<std::string>& names() const { return names_; }
  bool contains(const std::string& name) const;

  /// x, y, hue, size, orientation, distance_to_robot, bearing_from_robot, distance_to_wall.
  static std::vector<std::string> defaultNames();

 private:
  std::vector<std::string> names_;
};

/// Inner extents of the rectangular arena, centred on the world origin (ArenaSpec::size_x, size_y).
struct ArenaExtents {
  double size_x = 0.9, size_y = 0.6;
};

/// VISION: feature values per detected object.
class Vision {
 public:
  /**
   * @brief The selected features of every object in @p detections.
   * @param bgr the image the detections came from (CV_8UC3, same size as when extracted)
   * @param robot the robot's pose for distance_to_robot / bearing_from_robot; when absent, the detected robot
   *        (detections.robot, if found) is used; with neither, those features are NaN
   * @return object name -> (feature name -> value); NaN where a feature cannot be measured
   * @throws ValidationError for an empty or non-CV_8UC3 image, non-positive or non-finite arena extents, or a
   *         non-finite robot pose
   */
  std::map<std::string, std::map<std::string, double>> compute(const cv::Mat& bgr, const Detections& detections,
                                                               const FeatureSelection& selection,
                                                               const ArenaExtents& arena,
                                                               const std::optional<Pose2D>& robot = std::nullopt) const;
};

}  // namespace xpersif::core
