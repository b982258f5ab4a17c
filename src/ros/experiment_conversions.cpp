#include "xpersif/ros/experiment_conversions.h"

#include <algorithm>
#include <cmath>

#include "xpersif/core/common/validation.h"

namespace xpersif {

namespace {
constexpr std::size_t kMaxDesignLength = 64;

core::Outcome outcomeOf(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }
std::vector<double> vectorOf(const core::Outcome& o) { return {o.dx, o.dy, o.dyaw}; }
}  // namespace

core::Experiment fromMsg(const Experiment& msg) { return {msg.object, msg.side, msg.offset, msg.distance}; }

Experiment toMsg(const core::Experiment& experiment) {
  Experiment msg;
  msg.object = experiment.object;
  msg.side = experiment.side;
  msg.offset = experiment.offset;
  msg.distance = experiment.distance;
  return msg;
}

std::string checkObjectFeatures(const std::string& field, const ObjectFeatures& msg) {
  std::string why = core::checkFinite(field + ".position.x", msg.position.x);
  if (why.empty()) why = core::checkFinite(field + ".position.y", msg.position.y);
  if (why.empty()) why = core::checkFinite(field + ".yaw", msg.yaw);
  if (why.empty()) why = core::checkMaxSize(field + ".feature_names", msg.feature_names.size(), core::kMaxExtraFeatures);
  if (why.empty() && msg.feature_names.size() != msg.feature_values.size()) {
    why = field + " has " + std::to_string(msg.feature_names.size()) + " feature_names but " +
          std::to_string(msg.feature_values.size()) + " feature_values; they must be parallel";
  }
  for (std::size_t i = 0; why.empty() && i < msg.feature_values.size(); ++i) {
    why = core::checkFinite(field + ".feature_values[" + std::to_string(i) + "] (" + msg.feature_names[i] + ")",
                            msg.feature_values[i]);
  }
  return why;
}

core::ObjectFeatures fromMsg(const ObjectFeatures& msg) {
  core::ObjectFeatures object;
  object.name = msg.name;
  object.x = msg.position.x;
  object.y = msg.position.y;
  object.yaw = msg.yaw;
  for (std::size_t i = 0; i < msg.feature_names.size() && i < msg.feature_values.size(); ++i) {
    object.extra[msg.feature_names[i]] = msg.feature_values[i];
  }
  return object;
}

ObjectFeatures toMsg(const core::ObjectFeatures& object) {
  ObjectFeatures msg;
  msg.name = object.name;
  msg.position.x = object.x;
  msg.position.y = object.y;
  msg.yaw = object.yaw;
  for (const auto& [name, value] : object.extra) {
    msg.feature_names.push_back(name);
    msg.feature_values.push_back(value);
  }
  return msg;
}

std::string checkFeatureVector(const std::string& field, const FeatureVector& msg) {
  std::string why = core::checkMaxSize(field + ".objects", msg.objects.size(), core::kMaxObjectsPerFeatureVector);
  for (std::size_t i = 0; why.empty() && i < msg.objects.size(); ++i) {
    why = checkObjectFeatures(field + ".objects[" + std::to_string(i) + "]", msg.objects[i]);
  }
  return why.empty() ? core::checkFeatureVector(field, fromMsg(msg)) : why;
}

core::FeatureVector fromMsg(const FeatureVector& msg) {
  core::FeatureVector features;
  features.stamp = msg.header.stamp.toSec();
  for (const auto& o : msg.objects) features.objects.push_back(fromMsg(o));
  return features;
}

FeatureVector toMsg(const core::FeatureVector& features) {
  FeatureVector msg;
  if (std::isfinite(features.stamp) && features.stamp >= 0 && features.stamp < 4e9) msg.header.stamp.fromSec(features.stamp);
  for (const auto& o : features.objects) msg.objects.push_back(toMsg(o));
  return msg;
}

core::ExperimentRecord fromMsg(const ExperimentRecord& msg) {
  using core::throwIfInvalid;
  throwIfInvalid(core::checkOneOf("record.status", msg.status, {"done", "failed"}));
  throwIfInvalid(core::checkMaxLength("record.design", msg.design, kMaxDesignLength));
  throwIfInvalid(core::checkExperiment("record.experiment", fromMsg(msg.experiment)));
  throwIfInvalid(checkFeatureVector("record.before", msg.before));
  throwIfInvalid(checkFeatureVector("record.after", msg.after));
  core::ExperimentRecord record;
  record.id = 0;
  record.run_id = static_cast<std::int64_t>(msg.run_id);
  record.seq = msg.seq;
  record.experiment = fromMsg(msg.experiment);
  record.before = fromMsg(msg.before);
  record.after = fromMsg(msg.after);
  record.outcome = core::Outcome{msg.dx, msg.dy, msg.dyaw};
  throwIfInvalid(core::checkOutcome("record", *record.outcome));
  if (msg.predicted_mean.size() != msg.predicted_std.size() ||
      (!msg.predicted_mean.empty() && msg.predicted_mean.size() != 3)) {
    throw core::ValidationError("record.predicted_mean has " + std::to_string(msg.predicted_mean.size()) +
                                " numbers and record.predicted_std " + std::to_string(msg.predicted_std.size()) +
                                "; give both empty (no prediction) or both with 3 (dx, dy, dyaw)");
  }
  if (!msg.predicted_mean.empty()) {
    throwIfInvalid(core::checkAllFinite("record.predicted_mean", msg.predicted_mean));
    for (std::size_t i = 0; i < 3; ++i) {
      throwIfInvalid(core::checkInRange("record.predicted_std[" + std::to_string(i) + "]", msg.predicted_std[i], 0.0, 1e6));
    }
    record.prediction = core::Prediction{outcomeOf(msg.predicted_mean), outcomeOf(msg.predicted_std)};
    throwIfInvalid(core::checkInRange("record.surprise", msg.surprise, 0.0, 1e12));
    record.surprise = msg.surprise;
  } else if (msg.surprise != 0.0) {
    throw core::ValidationError("record.surprise is " + core::describeNumber(msg.surprise) +
                                " without a prediction; a surprise needs predicted_mean and predicted_std");
  }
  record.status = msg.status;
  record.design = msg.design;
  record.failure_reason = msg.reason;
  if (msg.status == "failed" && msg.reason.empty()) {
    throw core::ValidationError("record.reason is empty; a failed experiment must say why it failed");
  }
  throwIfInvalid(core::checkMaxLength("record.reason", msg.reason, core::KnowledgeBase::kMaxTextLength));
  throwIfInvalid(core::checkFinite("record.started", msg.started));
  throwIfInvalid(core::checkFinite("record.finished", msg.finished));
  record.started = msg.started;
  record.finished = msg.finished;
  return record;
}

ExperimentRecord toMsg(const core::ExperimentRecord& record) {
  ExperimentRecord msg;
  msg.id = static_cast<std::uint64_t>(record.id);
  msg.run_id = static_cast<std::uint64_t>(record.run_id);
  msg.seq = static_cast<std::uint32_t>(record.seq);
  msg.design = record.design;
  msg.experiment = toMsg(record.experiment);
  msg.status = record.status;
  msg.reason = record.failure_reason;
  msg.before = toMsg(record.before);
  msg.after = toMsg(record.after);
  if (record.outcome) {
    msg.dx = record.outcome->dx;
    msg.dy = record.outcome->dy;
    msg.dyaw = record.outcome->dyaw;
  }
  if (record.prediction) {
    msg.predicted_mean = vectorOf(record.prediction->mean);
    msg.predicted_std = vectorOf(record.prediction->std);
  }
  if (record.surprise) msg.surprise = *record.surprise;
  msg.started = record.started;
  msg.finished = record.finished;
  return msg;
}

Notion toMsg(const core::Notion& notion) {
  Notion msg;
  msg.subject = notion.subject;
  msg.predicate = notion.predicate;
  msg.value = notion.value;
  msg.confidence = notion.confidence;
  msg.support = static_cast<std::uint32_t>(std::max(0, notion.support));
  msg.text = notion.text;
  return msg;
}

core::Notion fromMsg(const Notion& msg) {
  core::Notion notion;
  notion.subject = msg.subject;
  notion.predicate = msg.predicate;
  notion.value = msg.value;
  notion.confidence = msg.confidence;
  notion.support = static_cast<int>(std::min<std::uint32_t>(msg.support, 1u << 30));
  notion.text = msg.text;
  return notion;
}

const ObjectFeatures* findObject(const FeatureVector& features, const std::string& name) {
  for (const auto& o : features.objects) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

void appendScenePoses(const FeatureVector& features, std::vector<std::string>* names,
                      std::vector<geometry_msgs::Pose2D>* poses) {
  for (const auto& o : features.objects) {
    names->push_back(o.name);
    geometry_msgs::Pose2D pose;
    pose.x = o.position.x;
    pose.y = o.position.y;
    pose.theta = o.yaw;
    poses->push_back(pose);
  }
}

}  // namespace xpersif
