/**
 * @file feature_extraction_part.h
 * @brief FEATUREEXTRACTION inside a component: the ROS side of core::FeatureExtractor. The same part
 *        is PERCEPTION's and OBSERVATION's own ROBOTFEATUREEXTRACTION instance, and the heart of the
 *        stand-alone FEATUREEXTRACTION component.
 *
 * It works on the image message's own buffer (a cv::Mat header over sensor_msgs::Image::data), so an image
 * received as a shared pointer inside a manager is never copied. Thread-safe.
 */
#pragma once

#include "xpersif/core/common/parameters.h"

#include <sensor_msgs/Image.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>

#include "xpersif/FeatureVector.h"
#include "xpersif/component/aggregate.h"
#include "xpersif/core/perception/feature_extractor.h"

namespace xpersif {

/// Detections as a message (world frame; @p header is the image's, with frame_id replaced by @p world_frame).
FeatureVector toFeatureVector(const core::Detections& detections, const std_msgs::Header& header,
                              const std::string& world_frame, const std::string& source);
/// Back from a message: what VISION needs of FEATUREEXTRACTION's output (contours, corners, poses).
core::Detections fromFeatureVector(const FeatureVector& features);

/// A cv::Mat header over a bgr8 image message's buffer (no copy). @throws ValidationError for other encodings
cv::Mat viewOf(const sensor_msgs::Image& image);

class FeatureExtractionPart : public ComponentPart {
 public:
  explicit FeatureExtractionPart(std::string name = "feature_extraction") : ComponentPart(std::move(name)) {}

  /// Reads `min_blob_pixels` and `max_chroma_tolerance` under its namespace.
  void configure(const ros::NodeHandle& parameters) override;
  /// ~<part>/min_blob_pixels, ~<part>/max_chroma_tolerance.
  static const core::ParameterTable& parameters();
  void shutdown() override;
  std::string problem() const override;
  /// HEALTH_ERROR when it refused the scene it was given (setCamera: an object or the robot it cannot tell
  /// apart), HEALTH_WARN while it waits for a scene.
  std::pair<std::uint8_t, std::string> diagnose() const override;

  /// Prepare for @p camera of @p scene (call whenever the scene arrives). Errors are kept in problem().
  void setCamera(const core::SceneDescription& scene, const core::CameraModel& camera);
  bool ready() const;

  /// Extract from @p image (bgr8) taken with the camera at @p world_from_camera.
  /// @throws ValidationError (bad image) or std::runtime_error (not ready)
  FeatureVector extract(const sensor_msgs::Image& image, const Eigen::Isometry3d& world_from_camera,
                        const std::string& source) const;
  std::uint64_t processed() const { return processed_; }

 private:
  mutable std::mutex mutex_;
  core::PerceptionOptions options_;
  std::string world_frame_ = "world";
  std::shared_ptr<const core::FeatureExtractor> extractor_;
  std::string problem_;
  bool refused_ = false;  // problem_ is setCamera's refusal, not a wait
  mutable std::atomic<std::uint64_t> processed_{0};
};

}  // namespace xpersif
