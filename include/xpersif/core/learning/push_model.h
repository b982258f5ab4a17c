/**
 * @file push_model.h
 * @brief The model of pushing beneath one interface, so that MACHINELEARNING and GOALDESIGN choose it by name
 *        (`~learner_type`), as move_base chooses its global planner: PushModel, with this package's random-forest
 *        ensemble (PushLearner, push_learner.h) and Gaussian process (gaussian_process_push_model.h).
 *
 * A push model learns from pushes (PushSample: the push, the object's features before it, the outcome dx, dy,
 * dyaw in the push frame), predicts the outcome of a push with its uncertainty (mean and std per output), turns
 * what it has seen into notions, and saves itself to bytes that load() (of the same class) reads back. It is a
 * pluginlib base class ("xpersif::core::PushModel"): classes are made with their default constructor and then
 * configure()d. No ROS here: implementations are tested with plain gtest.
 *
 * The contract every implementation keeps:
 *  - addSamples validates all samples first (check()) and throws ValidationError changing nothing when one is bad;
 *  - predict throws ValidationError for bad input, and before any sample predicts zero motion with prior_std;
 *  - the same config and the same samples in the same order give the same predictions (reproducible runs,
 *    offline training equal to the live model);
 *  - load(save()) gives a model that predicts the same; malformed bytes throw ValidationError, changing nothing.
 */
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "xpersif/core/common/experiment.h"

namespace xpersif::core {

/// What the learner sees of a push: the push and the pushed object's features just before it.
struct PushInput {
  Experiment experiment;
  ObjectFeatures object;  ///< object.name must equal experiment.object
};

struct PushSample {
  PushInput input;
  Outcome outcome;
};

/// A sample from the fields a saved model stores (both learners' files): the push, the object's pose
/// (x, y, yaw), its features in the order of @p feature_names, and the outcome (dx, dy, dyaw). The callers
/// have checked the sizes.
PushSample pushSampleFrom(const std::string& object, const std::string& side, double offset, double distance,
                          const std::vector<double>& pose, const std::vector<double>& features,
                          const std::vector<std::string>& feature_names, const std::vector<double>& outcome);

/// What every push model is told: its inputs and its prior. Learner-specific settings go in `options`.
struct PushModelConfig {
  /// Extra features of the object used as inputs; every sample must carry them.
  std::vector<std::string> feature_names{"hue", "size"};
  /// One unit of each feature in the input distance (what counts as "a different object"); default 1.
  std::map<std::string, double> feature_scales{{"hue", 30.0}, {"size", 0.01}};
  /// Add a one-hot code of the object's name over `identities` (unknown names get all zeros).
  bool one_hot_identity = false;
  std::vector<std::string> identities;
  std::uint64_t seed = 1;              ///< for learners that draw at random
  Outcome prior_std{0.10, 0.05, 0.5};  ///< m, m, rad: the std with no data nearby
  /// Learner-specific numbers by name (e.g. "ensemble_size"); an implementation refuses names it does not know.
  std::map<std::string, double> options;
};

class PushModel {
 public:
  virtual ~PushModel() = default;

  /// Replace the configuration and forget every sample. Throws ValidationError for a bad config (unknown
  /// option names included), keeping the previous state.
  virtual void configure(const PushModelConfig& config) = 0;
  /// Throws ValidationError (a sentence naming @p field) unless the model can use @p input.
  virtual void check(const PushInput& input, const std::string& field = "input") const = 0;
  /// Validate, store and learn from @p samples (one training); a bad sample throws and changes nothing.
  virtual void addSamples(const std::vector<PushSample>& samples) = 0;
  void addSample(const PushInput& input, const Outcome& outcome) { addSamples({PushSample{input, outcome}}); }
  virtual Prediction predict(const PushInput& input) const = 0;

  virtual std::size_t sampleCount() const = 0;
  virtual const std::vector<PushSample>& samples() const = 0;

  /// The model as bytes (its configuration and samples; see format()).
  virtual std::string save() const = 0;
  /// Replace this model by the one in @p bytes; malformed bytes throw ValidationError and change nothing.
  virtual void load(const std::string& bytes) = 0;
  /// The name and version of save()'s format ("xpersif-push-learner/1"): LearnedModel.format, the KB's models.
  virtual std::string format() const = 0;

  /// Learned facts about the objects (deriveNotions of the samples unless a model knows better).
  virtual std::vector<Notion> notions() const;
};

/// Learned facts from pushes, per object (objects in name order). Predicates:
///  - "does_not_move_when_pushed": median |displacement| / distance < 0.1 over >= 3 pushes;
///    value = that median ratio; confidence = the share of pushes below the threshold.
///  - "moves_when_pushed": otherwise, over >= 3 pushes; value = mean displacement ratio; confidence = the share
///    of pushes above the threshold.
///  - "slides_further_than_pushed": moves and its median ratio > 1.05; value = median ratio; confidence = share
///    of pushes with ratio > 1.
///  - "rotates_when_pushed_off_centre": moves, >= 5 off-centre pushes (|offset| >= 0.004), |dyaw| correlates
///    with |offset| (Pearson r >= 0.5) and the sign of dyaw follows the sign of the offset in >= 80 %
///    of them; value = the signed correlation of dyaw with offset (negative: turns away from the contact side);
///    confidence = the share of sign agreement.
/// Throws ValidationError for invalid samples.
std::vector<Notion> deriveNotions(const std::vector<PushSample>& samples);

/// Check the parts of @p input every model needs (the push, the object's pose, the features @p feature_names).
void checkPushInput(const std::vector<std::string>& feature_names, const PushInput& input, const std::string& field);
/// Check the shared parts of @p config (names, scales, priors, identities).
void checkPushModelConfig(const PushModelConfig& config);
/// The input row both of this package's models use: cos, sin of the push direction in the object's frame,
/// offset, distance, the features in config order, then the one-hot identity (if configured). Validates.
std::vector<double> encodePushInput(const PushModelConfig& config, const PushInput& input);
/// The unit of each entry of encodePushInput's row: direction 1, offset 1 cm, distance 3 cm, feature_scales
/// (default 1), identity 1.
std::vector<double> pushInputScales(const PushModelConfig& config);

}  // namespace xpersif::core
