#include "xpersif/core/evaluation/evaluation.h"

#include <algorithm>

#include <cmath>
#include <map>
#include <memory>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "xpersif/core/evaluation/experiment_samples.h"
#include "xpersif/core/learning/motivation.h"
#include "xpersif/core/learning/per_object_push_model.h"

namespace xpersif::core {

std::vector<PushSample> pushSamples(const std::vector<ExperimentRecord>& records) {
  std::vector<PushSample> samples;
  for (const auto& r : records) {
    if (auto sample = pushSampleOf(r)) samples.push_back(*sample);
  }
  return samples;
}

PushLearnerConfig loopLearnerConfig(const std::vector<std::string>& identities) {
  PushLearnerConfig config;
  config.feature_names = {"hue", "size"};
  config.one_hot_identity = true;
  config.identities = identities;
  return config;
}

std::vector<std::string> sceneIdentities(const std::vector<ExperimentRecord>& records) {
  std::vector<std::string> identities;
  for (const auto& r : records) {
    for (const auto& o : r.before.objects) {
      if (std::find(identities.begin(), identities.end(), o.name) == identities.end()) identities.push_back(o.name);
    }
  }
  return identities;
}

std::vector<PushSample> designedSamples(const std::string& database) {
  auto kb = KnowledgeBase::open(database);
  std::vector<PushSample> samples;
  for (const auto& run : kb->runs()) {
    const long designed = designedCount(run.parameters_json);
    std::vector<ExperimentRecord> records;
    for (const auto& r : kb->experiments(run.id, "done")) {
      if (designed < 0 || r.seq <= designed) records.push_back(r);
    }
    const auto some = pushSamples(records);
    samples.insert(samples.end(), some.begin(), some.end());
  }
  return samples;
}

EvaluationSet loadEvaluationSet(const std::string& database) {
  auto kb = KnowledgeBase::open(database);
  std::vector<ExperimentRecord> records;
  for (const auto& run : kb->runs()) {
    for (const auto& r : kb->experiments(run.id, "done")) records.push_back(r);
  }
  EvaluationSet set{sceneIdentities(records), pushSamples(records)};
  if (set.samples.empty()) throw std::runtime_error(database + " has no successful experiment to evaluate on");
  return set;
}

LearningCurve learningCurve(const std::string& name, const std::vector<PushSample>& training,
                            const std::vector<PushSample>& evaluation, const PushLearnerConfig& config,
                            const std::vector<int>& checkpoints, LearnerScope scope) {
  LearningCurve curve;
  curve.name = name;
  for (const auto& s : evaluation) ++curve.object_pushes[s.input.experiment.object];
  for (int k : checkpoints) {
    if (k < 0 || k > static_cast<int>(training.size())) continue;
    const std::vector<PushSample> first(training.begin(), training.begin() + k);
    std::unique_ptr<PushModel> learner;
    if (scope == LearnerScope::PerObject) learner = std::make_unique<PerObjectPushModel>(config);
    else learner = std::make_unique<PushLearner>(config);
    if (!first.empty()) learner->addSamples(first);
    double sum = 0;
    std::map<std::string, double> object_sum;
    std::vector<Outcome> predicted;
    for (const auto& s : evaluation) {
      const Prediction prediction = learner->predict(s.input);
      predicted.push_back(prediction.mean);
      const double e = surprise(prediction, s.outcome).error;
      sum += e * e;
      object_sum[s.input.experiment.object] += e * e;
    }
    for (const auto& [object, e] : oneShotGoalErrors(evaluation, predicted)) curve.object_goal_error[object].push_back(e);
    curve.experiments.push_back(k);
    curve.error.push_back(evaluation.empty() ? NAN : std::sqrt(sum / evaluation.size()));
    for (const auto& [object, squares] : object_sum) {
      curve.object_error[object].push_back(std::sqrt(squares / curve.object_pushes[object]));
    }
  }
  curve.object_goal_random_best = goalReferences(evaluation);
  return curve;
}

double outcomeDistance(const Outcome& a, const Outcome& b) {
  return std::hypot(a.dx - b.dx, a.dy - b.dy) + kYawLength * std::abs(std::remainder(a.dyaw - b.dyaw, 2 * M_PI));
}

std::map<std::string, double> oneShotGoalErrors(const std::vector<PushSample>& evaluation,
                                                 const std::vector<Outcome>& predicted) {
  std::map<std::string, std::vector<std::size_t>> by_object;
  for (std::size_t i = 0; i < evaluation.size(); ++i) by_object[evaluation[i].input.experiment.object].push_back(i);
  std::map<std::string, double> out;
  for (const auto& [object, pushes] : by_object) {
    if (pushes.size() < 2) continue;
    double sum = 0;
    for (std::size_t target : pushes) {
      std::size_t chosen = target;
      double closest = INFINITY;
      for (std::size_t i : pushes) {  // ties go to the earlier push: deterministic
        const double d = i == target ? INFINITY : outcomeDistance(predicted[i], evaluation[target].outcome);
        if (d < closest) closest = d, chosen = i;
      }
      sum += outcomeDistance(evaluation[chosen].outcome, evaluation[target].outcome);
    }
    out[object] = sum / static_cast<double>(pushes.size());
  }
  return out;
}

std::map<std::string, std::pair<double, double>> goalReferences(const std::vector<PushSample>& evaluation) {
  std::map<std::string, std::vector<const Outcome*>> by_object;
  for (const auto& s : evaluation) by_object[s.input.experiment.object].push_back(&s.outcome);
  std::map<std::string, std::pair<double, double>> out;
  for (const auto& [object, outcomes] : by_object) {
    if (outcomes.size() < 2) continue;
    double random_sum = 0, best_sum = 0;
    for (std::size_t t = 0; t < outcomes.size(); ++t) {
      double sum = 0, best = INFINITY;
      for (std::size_t i = 0; i < outcomes.size(); ++i) {
        if (i == t) continue;
        const double d = outcomeDistance(*outcomes[i], *outcomes[t]);
        sum += d;
        best = std::min(best, d);
      }
      random_sum += sum / static_cast<double>(outcomes.size() - 1);
      best_sum += best;
    }
    const double n = static_cast<double>(outcomes.size());
    out[object] = {random_sum / n, best_sum / n};
  }
  return out;
}

namespace {

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace

std::vector<std::string> movingObjects(const std::vector<PushSample>& evaluation, double share) {
  std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> pushes;  // object -> (distances, travels)
  std::vector<std::string> order;
  for (const auto& s : evaluation) {
    const std::string& object = s.input.experiment.object;
    if (!pushes.count(object)) order.push_back(object);
    pushes[object].first.push_back(std::abs(s.input.experiment.distance));
    pushes[object].second.push_back(std::hypot(s.outcome.dx, s.outcome.dy) + kYawLength * std::abs(s.outcome.dyaw));
  }
  std::vector<std::string> moving;
  for (const auto& object : order) {
    const auto& [distances, travels] = pushes[object];
    const double pushed = median(distances);
    if (pushed > 0 && median(travels) >= share * pushed) moving.push_back(object);
  }
  return moving;
}

std::vector<double> balancedOver(const std::map<std::string, std::vector<double>>& per_object, std::size_t points,
                                 const std::vector<std::string>& objects) {
  std::vector<double> out;
  for (std::size_t i = 0; i < points; ++i) {
    double sum = 0;
    int counted = 0;
    for (const auto& object : objects) {
      const auto it = per_object.find(object);
      if (it == per_object.end() || i >= it->second.size()) continue;
      sum += it->second[i];
      ++counted;
    }
    out.push_back(counted ? sum / counted : NAN);
  }
  return out;
}

double logArea(const std::vector<int>& experiments, const std::vector<double>& error) {
  if (experiments.empty() || experiments.size() != error.size()) return NAN;
  auto logOf = [](double e) { return std::log(std::max(e, 1e-12)); };
  if (experiments.size() == 1 || experiments.back() == experiments.front()) return logOf(error.front());
  double area = 0;
  for (std::size_t i = 1; i < experiments.size(); ++i) {
    area += (experiments[i] - experiments[i - 1]) * 0.5 * (logOf(error[i - 1]) + logOf(error[i]));
  }
  return area / (experiments.back() - experiments.front());
}

double valueAt(const std::vector<int>& experiments, const std::vector<double>& values, int k) {
  const std::size_t n = std::min(experiments.size(), values.size());
  if (n == 0) return NAN;
  for (std::size_t i = 0; i < n; ++i) {
    if (experiments[i] >= k) return values[i];
  }
  return values[n - 1];
}

int experimentsToReach(const LearningCurve& curve, double error) {
  for (std::size_t i = 0; i < curve.error.size(); ++i) {
    if (curve.error[i] <= error) return curve.experiments[i];
  }
  return -1;
}

double runParameter(const std::string& parameters_json, const std::string& key, double fallback) {
  const auto parameters = nlohmann::json::parse(parameters_json, nullptr, /*allow_exceptions=*/false);
  if (!parameters.is_object()) return fallback;
  const auto value = parameters.find(key);
  return value != parameters.end() && value->is_number() ? value->get<double>() : fallback;
}

long designedCount(const std::string& parameters_json) {
  return static_cast<long>(runParameter(parameters_json, "experiments", -1));
}

}  // namespace xpersif::core
