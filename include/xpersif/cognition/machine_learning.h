/**
 * @file machine_learning.h
 * @brief MACHINELEARNING: learns from every stored push how objects move when pushed (a core::PushModel chosen
 *        by `~learner_type`, see doc/plugins.md) and what that means in words (its notions); predicts the
 *        outcome of a push.
 *
 * It follows the KNOWLEDGEBASE's `experiments` (see experiment_follower.h): each DONE record of the current run
 * becomes a sample — input: the experiment and the pushed object as the record's `before` vector saw it (name,
 * pose, and the features named in `~features`); outcome: the record's dx, dy, dyaw. A record whose `before`
 * lacks the object or a feature is skipped with a warning. After every sample, and after a restore, it
 * publishes latched `~model` (LearnedModel: run_id, samples, format = the model's format(), data =
 * save()) and latched `~notions` (Notions). With `~restore` (default true) it rebuilds itself from the KB's
 * get_experiments of the current run when activated, when a new run is announced, when a record of another
 * run arrives, or when it notices a lost record — so a restarted MACHINELEARNING goes on where it stopped.
 *
 * The learner's input: push direction, offset, distance, the object's `hue` and `size` (VISION's colour and
 * edge length: objects that look alike are expected to move alike, so what is learned about one cube carries
 * over to a similar one), and a one-hot code of the object's identity over the objects of XPERSim's scene (in
 * world-file order; `~objects` restricts them), because objects of the same look may differ in mass and
 * friction, which no camera sees.
 *
 * Operation `predict` (Predict): the predicted dx, dy, dyaw (mean and std) of a push of an object with the
 * given features, and how many samples the model has.
 *
 * Operation `use_features` (UseFeatures): learn from these features of the pushed object from now on (FEATURESELECTION's
 * choice, which LOOPMODEL passes on; none: the push and the identity alone; `initial`: back to `~features`); the model is retrained at once from every record of
 * the run it has followed (a record lacking a feature is skipped, as always) and published. Unknown or repeated names
 * are INVALID. Effect `learns_from(machine_learning, (names...) | none)`. A feature without a `~feature_scales`
 * entry gets a unit that tells objects apart (saturation and colours 0.1, area 4 cm^2, elongation 0.25, ...).
 * `LearnedModel.features` says what a published model learns from.
 *
 * Parameters: MachineLearning::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md).
 */
#pragma once

#include <memory>
#include <mutex>

#include "xpersif/LearnedModel.h"
#include "xpersif/Notions.h"
#include "xpersif/Predict.h"
#include "xpersif/UseFeatures.h"
#include "xpersif/cognition/experiment_follower.h"
#include "xpersif/component/component.h"
#include "xpersif/core/learning/push_model.h"
#include "xpersif/ros/algorithm_loader.h"

namespace xpersif {

class MachineLearning : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  MachineLearning(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~MachineLearning() override;

  /// The sample a done record gives, or why it gives none.
  static std::string sampleOf(const ExperimentRecord& record, core::PushSample* sample);

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;

 private:
  void reset(std::uint64_t run_id, const std::vector<ExperimentRecord>& records);
  void useFeatures(const std::vector<std::string>& names, bool initial, UseFeatures::Response& response);
  /// A fresh model of @p type and @p config trained on the samples of @p records.
  std::shared_ptr<core::PushModel> rebuild(const std::string& type, const core::PushModelConfig& config,
                                           std::uint64_t run_id, const std::vector<ExperimentRecord>& records);
  void add(const ExperimentRecord& record);
  void publish();

  /// A fresh model of the configured type and config (the loader is not thread-safe: under loader_mutex_).
  std::shared_ptr<core::PushModel> makeModel(const std::string& type, const core::PushModelConfig& config);

  std::mutex loader_mutex_;
  AlgorithmLoader<core::PushModel> loader_;  // before the models: it holds their code
  std::mutex mutex_;  // guards learner_type_, config_, learner_, run_id_, records_, ...
  std::string learner_type_;
  core::PushModelConfig config_;
  std::vector<std::string> configured_features_;  // ~features
  std::uint64_t config_generation_ = 0;           // bumped whenever config_ changes
  std::vector<ExperimentRecord> records_;         // the run's records followed so far (use_features learns them again)
  std::shared_ptr<core::PushModel> learner_;
  std::uint64_t run_id_ = 0;
  ExperimentFollower::Options follow_;

  std::unique_ptr<ExperimentFollower> follower_;  // before the publishers: its thread publishes
  ros::Publisher model_pub_, notions_pub_;
};

}  // namespace xpersif
