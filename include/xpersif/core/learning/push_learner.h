/**
 * @file push_learner.h
 * @brief MACHINELEARNING's model of pushing: it learns, one push at a time, to predict how an object moves
 *        (dx, dy, dyaw in the push frame, see experiment.h) for a push, with an estimate of its own
 *        uncertainty; and it turns what it has seen into notions (learned symbolic facts).
 *
 * The model. A bootstrap ensemble of OpenCV random forests (cv::ml::RTrees), one forest per ensemble member and
 * output, each member trained on a bootstrap resample of the samples.
 *  - Why forests: they need no feature scaling, cope with few samples, capture the non-linear and
 *    discontinuous effects of pushing (a heavy object does not move at all, a light one moves with the push)
 *    and train in milliseconds for the few hundred pushes of a run.
 *  - Why an ensemble: the spread of the members' predictions is the model's uncertainty about its mean
 *    (the classic bootstrap estimate); their out-of-bag residuals, averaged over the nearest samples, give the
 *    noise of the outcome around the mean where data exist (a light cube's outcome varies, a heavy cube's
 *    does not).
 *  - Why a novelty term as well: trees extrapolate flat, so far from every sample all members agree and the
 *    spread alone would claim certainty about pushes never tried. The learner counts the samples near the
 *    query, n_eff = sum_i exp(-d_i^2 / (2 L^2)) with d_i the distance to sample i in scaled input units, and
 *    adds the posterior variance of a local mean under the prior after n_eff observations of noise sigma^2:
 *    prior^2 sigma^2 / (sigma^2 + n_eff prior^2). It is the prior far from data and vanishes near data.
 *    variance = spread^2 + noise^2 + prior^2 sigma^2 / (sigma^2 + n_eff prior^2)        (per output)
 *    with noise^2 the mean out-of-bag residual^2 of the nearest samples and sigma^2 = max(noise^2,
 *    (0.05 prior)^2).
 *  Before the first kMinTrainingSamples samples it predicts zero motion with the prior std.
 *
 * The input. Not the object's name alone, so that what is learned carries over to objects that look alike:
 * the push direction in the object's frame (cos, sin of pushAngleInObject(side)), the offset, the distance,
 * the object's observed features named in the config (e.g. "hue", "size"), and, optionally, a one-hot code of
 * the object's identity.
 *
 * Determinism. Bootstrap resamples are drawn with cv::RNG seeded from the config's seed; OpenCV's RTrees seeds
 * its own generator at every training. The same samples in the same order give the same predictions, so
 * training offline from recorded pushes gives the model the live run had. The model after n samples is always the
 * one trained on the first trainedCount(n) samples, whether they came one by one or in a batch; samples after
 * those wait for the next retraining (they are stored and saved, but neither the forests nor the novelty and
 * noise terms see them yet). The schedule: every sample up to kRetrainEveryUpTo (40) samples; then every
 * kRetrainStride (4) samples, a stride that doubles each time n doubles (8 from 80, 16 from 160, ... 128 from
 * 1280). Why: a training costs at least in proportion to n (about 0.3 s at 500 samples, 1.3 s at 2000 on a busy
 * 2-core machine), so retraining every k samples costs at least n / k per sample, which grows with n for a fixed
 * k; a stride of 5-10 % of n keeps it about constant (10-20 ms per sample, bench/learning.md), at the price of a
 * model that lags the data by at most 10 % of them. The single experiment that retrains still pays the whole
 * training.
 *
 * Not thread-safe: one owner (the MACHINELEARNING component) calls it; save() updates a cache, so not even const
 * calls may overlap with it.
 */
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "xpersif/core/common/experiment.h"
#include "xpersif/core/learning/push_model.h"

namespace xpersif::core {

struct PushLearnerConfig {
  /// Extra features of the object used as inputs; every sample must carry them.
  std::vector<std::string> feature_names{"hue", "size"};
  /// One unit of each feature for the novelty distance (what counts as "a different object"); default 1.
  std::map<std::string, double> feature_scales{{"hue", 30.0}, {"size", 0.01}};
  /// Add a one-hot code of the object's name over `identities` (unknown names get all zeros).
  bool one_hot_identity = false;
  std::vector<std::string> identities;
  int ensemble_size = 8;        ///< bootstrap members
  int trees_per_member = 16;    ///< trees in each member's forest
  int max_depth = 10;
  int min_sample_count = 2;     ///< smallest node a tree splits
  std::uint64_t seed = 1;
  Outcome prior_std{0.10, 0.05, 0.5};  ///< m, m, rad: the std with no data nearby
  double novelty_length = 0.5;         ///< L, in scaled input units (offset: 1 cm, distance: 3 cm, direction: 1)
  int noise_neighbours = 8;            ///< samples whose out-of-bag residuals give the local noise

  /// The shared part as a PushModelConfig, the rest as its options (the names of kOptionNames).
  PushModelConfig toModelConfig() const;
  /// The inverse; an option not in kOptionNames, or not an integer where one is needed, throws ValidationError.
  static PushLearnerConfig fromModelConfig(const PushModelConfig& config);
  /// ensemble_size, trees_per_member, max_depth, min_sample_count, novelty_length, noise_neighbours.
  static const std::vector<std::string> kOptionNames;
};

/// The random-forest ensemble as a PushModel (plugin "random_forest" in push_model_plugins.xml).
class PushLearner : public PushModel {
 public:
  static constexpr std::size_t kMinTrainingSamples = 3;
  static constexpr std::size_t kRetrainEveryUpTo = 40;  ///< retrain at every sample up to this many
  static constexpr std::size_t kRetrainStride = 4;      ///< then every this many, doubled each time n doubles
  static constexpr std::size_t kMaxSamples = 100000;

  /// Throws ValidationError for a bad config (sizes < 1, non-positive scales or stds).
  explicit PushLearner(PushLearnerConfig config = {});
  ~PushLearner() override;
  PushLearner(PushLearner&&) noexcept;
  PushLearner& operator=(PushLearner&&) noexcept;

  /// PushModel: the options are PushLearnerConfig's own fields (kOptionNames).
  void configure(const PushModelConfig& config) override;
  void check(const PushInput& input, const std::string& field = "input") const override { validate(input, field); }
  /// Validate, store and learn from pushes; the same model as adding them one by one, but trained once.
  /// Bad input throws ValidationError and changes nothing.
  void addSamples(const std::vector<PushSample>& samples) override;

  /// Throws ValidationError for bad input (NaN, unknown side, missing feature...).
  Prediction predict(const PushInput& input) const override;

  std::size_t sampleCount() const override { return samples_.size(); }
  /// How many of the first samples the current model was trained on: trainedCount(sampleCount()).
  std::size_t trainedCount() const { return trained_count_; }
  /// The retraining schedule, the one rule for when the model retrains (see Determinism).
  static std::size_t trainedCount(std::size_t n);
  const std::vector<PushSample>& samples() const override { return samples_; }
  const PushLearnerConfig& config() const { return config_; }

  /// The model as bytes (OpenCV FileStorage YAML): config, samples and a fingerprint of its predictions.
  std::string save() const override;
  /// Replace this learner by the one in @p bytes (retrained deterministically from its samples and checked
  /// against the fingerprint). Malformed bytes throw ValidationError and change nothing.
  void load(const std::string& bytes) override;
  static constexpr const char* kFormat = "xpersif-push-learner/1";
  std::string format() const override { return kFormat; }

  /// The encoded input row (for tests and tools).
  std::vector<float> encode(const PushInput& input) const;

 private:
  struct Model;
  void validate(const PushInput& input, const std::string& field) const;
  void retrain();

  PushLearnerConfig config_;
  std::vector<PushSample> samples_;
  std::size_t trained_count_ = 0;
  std::unique_ptr<Model> model_;
  // save()'s text of the first saved_count_ samples: samples only grow, so each is written once.
  mutable std::string saved_samples_;
  mutable std::size_t saved_count_ = 0;
};

}  // namespace xpersif::core
