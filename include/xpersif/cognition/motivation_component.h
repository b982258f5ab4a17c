/**
 * @file motivation_component.h
 * @brief MOTIVATION (aggregate): how surprised the robot was by each push and where it expects to learn the
 *        most (core/motivation.h: surprise, and curiosity as Intelligent Adaptive Curiosity's learning progress).
 *
 * Parts: `surprise` (the prediction error of a record: core::surprise of its predicted_mean/std against its
 * outcome; `~surprise/yaw_length`, m, default the objects' mean half-size) and `curiosity` (core::CuriosityMap
 * over `~objects` (default every object of XPERSim's scene, with their footprints) x sides -x +x -y +y x `~curiosity/offset_bins` (3) offset bins; `~curiosity/window` (5),
 * `~curiosity/min_visits` (2); `~curiosity/measure`: which error it records, `error` (metres, default) or
 * `normalized` (in predicted stds)).
 *
 * It follows the KNOWLEDGEBASE's `experiments` (experiment_follower.h; same `~restore`, `~experiments_topic`,
 * `~run_topic`, `~knowledge_base` parameters as MACHINELEARNING). Each DONE record that carries a prediction
 * is scored and recorded in its region, then `~motivation` (Motivation) is published, latched; records that
 * failed or carry no prediction have no error to learn from and change nothing. A new run starts a new map;
 * with restore on, a restart replays the run's stored records, so curiosity goes on where it stopped.
 * No operations besides the lifecycle ones: the loop reads the latched topic.
 */
#pragma once

#include "xpersif/core/common/parameters.h"

#include <map>
#include <memory>
#include <mutex>
#include <optional>

#include "xpersif/Motivation.h"
#include "xpersif/cognition/experiment_follower.h"
#include "xpersif/component/aggregate.h"
#include "xpersif/core/learning/motivation.h"

namespace xpersif {

/// Part `surprise`: scores a record's prediction.
class SurprisePart : public ComponentPart {
 public:
  SurprisePart() : ComponentPart("surprise") {}
  void configure(const ros::NodeHandle& parameters) override;
  /// ~surprise/yaw_length.
  static const core::ParameterTable& parameters();
  /// The surprise of a done record with a prediction; nothing for others.
  std::optional<core::Surprise> score(const ExperimentRecord& record) const;
  /// ~surprise/yaw_length's default: the objects' mean half-size (set before configure).
  void setDefaultYawLength(double metres) { default_yaw_length_ = metres; }

 private:
  double yaw_length_ = 0.02, default_yaw_length_ = 0.02;
};

/// Part `curiosity`: the regions' error histories.
class CuriosityPart : public ComponentPart {
 public:
  CuriosityPart() : ComponentPart("curiosity") {}
  /// ~curiosity/offset_bins, window, min_visits, measure.
  static const core::ParameterTable& parameters();
  /// The objects the robot may push (set by the aggregate from `~objects` before configure).
  void setObjects(std::vector<std::string> objects, std::map<std::string, core::Footprint> footprints) {
    objects_ = std::move(objects);
    footprints_ = std::move(footprints);
  }
  void configure(const ros::NodeHandle& parameters) override;
  void shutdown() override { map_.reset(); }
  /// Forget every region's history (a new run).
  void reset();
  /// Record the surprise of @p experiment in its region; false (and nothing recorded) for an unknown object.
  bool record(const Experiment& experiment, const core::Surprise& surprise, std::string* why);
  /// Fill regions, curiosity, learning_progress, visits and most_curious.
  void fill(Motivation& message) const;

 private:
  std::vector<std::string> objects_;
  std::map<std::string, core::Footprint> footprints_;
  core::CuriosityConfig config_;
  bool normalized_ = false;
  std::unique_ptr<core::CuriosityMap> map_;
};

class MotivationComponent : public AggregateComponent {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  MotivationComponent(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~MotivationComponent() override;

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;

 private:
  void reset(std::uint64_t run_id, const std::vector<ExperimentRecord>& records);
  void add(const ExperimentRecord& record);
  /// Count, score and record one record (mutex_ held); true when the message changes (a successful experiment
  /// heard of, scored or not).
  bool take(const ExperimentRecord& record);
  void publish();

  SurprisePart& surprise_;
  CuriosityPart& curiosity_;
  std::mutex mutex_;  // guards the parts' state and what follows
  std::uint64_t run_id_ = 0;
  // The run's successful experiments heard of, scored or not: what DESIGNOFEXPERIMENTS waits for (a record
  // without a valid prediction must not keep it waiting).
  std::uint32_t done_heard_ = 0;
  core::Surprise last_;
  ExperimentFollower::Options follow_;

  std::unique_ptr<ExperimentFollower> follower_;  // before the publisher: its thread publishes
  ros::Publisher motivation_pub_;
};

}  // namespace xpersif
