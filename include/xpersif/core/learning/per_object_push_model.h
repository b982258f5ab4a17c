/**
 * @file per_object_push_model.h
 * @brief A push model per object, with one shared model for objects it knows too little about (plugin
 *        "per_object_forest" in push_model_plugins.xml).
 *
 * Why: MACHINELEARNING's shared forest (push_learner.h) carves an object out of the others only once that object
 * holds a fair share of the samples. A design that does what curiosity should do, few pushes on an object that never
 * moves and many on the learnable ones, is punished for it: with two pushes of the trivial object among a hundred,
 * the shared forest still predicts it moves, and the held-out error is 2.4x random design's (bench/loop.md, "What a
 * perfect allocator would gain", allocation_bench). One forest per object learns "this one does not move" from three
 * pushes and cannot be disturbed by the pushes of others.
 *
 * The model. A shared PushLearner over every sample (the configuration as given, one-hot identity included), and
 * one PushLearner per object over that object's samples alone (the same configuration without the identity code,
 * which says nothing within one object). A prediction for an object comes from its own learner once that learner is
 * trained (PushLearner::kMinTrainingSamples samples), from the shared one before: an object seen once is predicted
 * from what the others taught, not as the prior.
 *
 * The options are PushLearner's (both kinds of learner get them). save() is the shared learner's bytes (config and
 * every sample); load() rebuilds the per-object learners from them, so a saved model reloads to the same
 * predictions. Deterministic as PushLearner is. Not thread-safe (one owner, as PushLearner).
 */
#pragma once

#include <map>
#include <string>
#include <vector>

#include "xpersif/core/learning/push_learner.h"

namespace xpersif::core {

class PerObjectPushModel : public PushModel {
 public:
  /// Throws ValidationError for a bad config (as PushLearner).
  explicit PerObjectPushModel(PushLearnerConfig config = {});

  void configure(const PushModelConfig& config) override;
  void check(const PushInput& input, const std::string& field = "input") const override { shared_.check(input, field); }
  /// Bad input throws ValidationError and changes nothing (the shared learner validates every sample first).
  void addSamples(const std::vector<PushSample>& samples) override;
  Prediction predict(const PushInput& input) const override;

  std::size_t sampleCount() const override { return shared_.sampleCount(); }
  const std::vector<PushSample>& samples() const override { return shared_.samples(); }

  std::string save() const override;
  /// Malformed bytes (or another model's) throw ValidationError and change nothing.
  void load(const std::string& bytes) override;
  static constexpr const char* kFormat = "xpersif-per-object-forest/1";
  std::string format() const override { return kFormat; }

  /// True when @p object is predicted by a learner of its own (it has been trained on that object's pushes).
  bool ownsPrediction(const std::string& object) const;

 private:
  /// The per-object learners' configuration: the shared one without the identity code.
  static PushLearnerConfig perObjectConfig(PushLearnerConfig config);
  /// Add @p samples (already validated) to their objects' learners, creating the learners they need.
  void learnPerObject(const std::vector<PushSample>& samples);

  PushLearner shared_;
  std::map<std::string, PushLearner> per_object_;
};

}  // namespace xpersif::core
