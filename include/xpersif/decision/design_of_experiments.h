/**
 * @file design_of_experiments.h
 * @brief DESIGNOFEXPERIMENTS: the operation design_experiment, which chooses the next push with a
 *        core::ExperimentDesign chosen by name (~design, or the request's design): this package's curiosity,
 *        random and grid (experiment_design_plugins.xml) or any other package's (doc/plugins.md).
 *
 * The curiosity design is steered by MOTIVATION without calling it: the component keeps the latest latched
 * Motivation message (regions + curiosity) and evaluates each candidate push locally, by the region key
 * core::CuriosityMap::regionOf gives it ("object/side/offset_bin", with ~offset_bins equal to MOTIVATION's).
 * A region the message does not list, or every region before the first message, counts as unexplored:
 * optimistic curiosity (~optimistic_curiosity, 1 as in CuriosityConfig).
 *
 * Designs that read the run's history (usesHistory(): learning_progress, error_max) get the run's successful
 * experiments with their held-out errors (the records' `surprise`: the prediction was made before the outcome was
 * seen) from the KNOWLEDGEBASE's experiments, followed as MOTIVATION follows them (ExperimentFollower, restored from
 * the KB on a new run or a restart). A request of a run first waits until what it is designed from is of that run
 * and counts its `scored` successful experiments: MOTIVATION's latest message (curiosity designs) and the
 * follower's history (history designs). Deciding on less would make the choice depend on when a message arrived
 * (the curiosity of the run before, one experiment short); so after ~input_wait seconds the request is refused as
 * UNAVAILABLE, naming what is missing, and LOOPMODEL asks again.
 *
 * Which objects may be pushed: the request's `reachable` list, or else the objects of the latest feature
 * vector on ~features_topic (VISION's), always restricted to ~objects.
 *
 * The objects, their footprints and the push limits come from XPERSim's scene (core::SetupCatalogue).
 * Parameters: DesignOfExperiments::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md). An unknown design or bad
 * bounds make configure fail with the sentence naming the parameter (for a design: and listing the declared
 * ones); a request naming an undeclared design is refused with ResultCode INVALID and the same list.
 * Re-configuring restarts the design from its seed.
 */
#pragma once

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "xpersif/DesignExperiment.h"
#include "xpersif/FeatureVector.h"
#include "xpersif/Motivation.h"
#include "xpersif/cognition/experiment_follower.h"
#include "xpersif/core/motion/motion_control.h"
#include "xpersif/component/component.h"
#include "xpersif/core/planning/experiment_design.h"
#include "xpersif/core/learning/motivation.h"
#include "xpersif/ros/algorithm_loader.h"

namespace xpersif {

class DesignOfExperiments : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  DesignOfExperiments(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;

 private:
  /// The objects the request may push now (reachable list or what vision saw), or why there are none.
  std::string candidates(const DesignExperiment::Request& request, std::vector<std::string>* objects) const;
  void design(const DesignExperiment::Request& request, DesignExperiment::Response& response);
  /// Waits (mutex_ held in @p lock) for MOTIVATION's and the history's view of the request's run; "" or what is
  /// still missing after ~input_wait seconds.
  std::string awaitInputs(const DesignExperiment::Request& request, std::unique_lock<std::mutex>& lock);
  void onFeatures(const FeatureVector::ConstPtr& features);
  void onMotivation(const Motivation::ConstPtr& motivation);
  /// The follower's hooks: the run's history from scratch, and one more record.
  void resetHistory(std::uint64_t run_id, const std::vector<ExperimentRecord>& records);
  void addHistory(const ExperimentRecord& record);

  /// A new design of @p type, initialized with @p seed and @p options; throws ValidationError (naming
  /// @p parameter) for an undeclared type or bad options.
  std::shared_ptr<core::ExperimentDesign> makeDesign(const std::string& parameter, const std::string& type,
                                                     unsigned long seed, const core::DesignOptions& options);

  std::mutex loader_mutex_;
  AlgorithmLoader<core::ExperimentDesign> loader_;  // before design_: it holds the design's code
  mutable std::mutex mutex_;
  std::string design_name_;
  unsigned long seed_ = 1;
  core::DesignOptions options_;
  std::shared_ptr<core::ExperimentDesign> design_;
  std::unique_ptr<core::CuriosityMap> regions_;  // only for regionOf: the same keys as MOTIVATION's
  std::vector<std::string> objects_;  // ~objects: the ones designed for
  std::map<std::string, core::Footprint> footprints_;  // of every object in the scene, all in the way
  core::ArenaGeometry arena_;        // the scene's, for the feasibility of pushes
  double robot_radius_ = 0.0;  // m
  bool feasible_only_ = true;  // ~feasible_only
  double optimistic_ = 1.0;
  std::size_t designed_ = 0;
  std::map<std::string, double> curiosity_;  // region key -> curiosity, from the latest Motivation
  bool have_motivation_ = false;
  std::uint64_t motivation_run_ = 0;     // the run MOTIVATION's latest message is of
  std::uint32_t motivation_scored_ = 0;  // successful experiments MOTIVATION's latest message counts
  double input_wait_ = 5.0;              // ~input_wait, s
  std::condition_variable motivated_;
  FeatureVector::ConstPtr latest_features_;
  // The run's successful experiments with their held-out errors (the follower's thread fills them).
  ExperimentFollower::Options follow_;
  std::unique_ptr<ExperimentFollower> follower_;
  std::uint64_t history_run_ = 0;
  std::vector<core::PastExperiment> history_;
  std::size_t history_done_ = 0;  // the run's successful records heard of, with a valid error or not
  std::condition_variable history_grew_;
  std::string features_topic_;

  ros::Subscriber features_sub_;
  ros::Subscriber motivation_sub_;
};

}  // namespace xpersif
