#include "xpersif/core/learning/per_object_push_model.h"

#include <string_view>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {
constexpr std::string_view kFormatPrefix = "# xpersif-per-object-forest/1\n";
}

PerObjectPushModel::PerObjectPushModel(PushLearnerConfig config) : shared_(std::move(config)) {}

PushLearnerConfig PerObjectPushModel::perObjectConfig(PushLearnerConfig config) {
  config.one_hot_identity = false;
  config.identities.clear();
  return config;
}

void PerObjectPushModel::configure(const PushModelConfig& config) {
  PushLearner shared;
  shared.configure(config);  // throws for a bad config, keeping this model as it was
  shared_ = std::move(shared);
  per_object_.clear();
}

void PerObjectPushModel::addSamples(const std::vector<PushSample>& samples) {
  shared_.addSamples(samples);  // validates every sample first: a bad one throws and changes nothing
  learnPerObject(samples);
}

void PerObjectPushModel::learnPerObject(const std::vector<PushSample>& samples) {
  // In the order the samples came, so that each object's learner sees its samples as it did live.
  std::map<std::string, std::vector<PushSample>> by_object;
  for (const auto& s : samples) by_object[s.input.experiment.object].push_back(s);
  for (auto& [object, own] : by_object) {
    auto it = per_object_.find(object);
    if (it == per_object_.end()) it = per_object_.emplace(object, PushLearner(perObjectConfig(shared_.config()))).first;
    it->second.addSamples(own);
  }
}

bool PerObjectPushModel::ownsPrediction(const std::string& object) const {
  const auto it = per_object_.find(object);
  return it != per_object_.end() && it->second.trainedCount() >= PushLearner::kMinTrainingSamples;
}

Prediction PerObjectPushModel::predict(const PushInput& input) const {
  shared_.check(input, "input");
  if (ownsPrediction(input.experiment.object)) return per_object_.at(input.experiment.object).predict(input);
  return shared_.predict(input);
}

std::string PerObjectPushModel::save() const { return std::string(kFormatPrefix) + shared_.save(); }

void PerObjectPushModel::load(const std::string& bytes) {
  if (std::string_view(bytes).substr(0, kFormatPrefix.size()) != kFormatPrefix) {
    throw ValidationError(std::string("the model's bytes are not a ") + kFormat + " model (they do not start with '" +
                          std::string(kFormatPrefix.substr(0, kFormatPrefix.size() - 1)) + "')");
  }
  PushLearner shared;
  shared.load(bytes.substr(kFormatPrefix.size()));  // throws for malformed bytes
  shared_ = std::move(shared);
  per_object_.clear();
  learnPerObject(shared_.samples());
}

}  // namespace xpersif::core
