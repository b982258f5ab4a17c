#include "xpersif/traces/record_conversions.h"

#include <cmath>

#include "xpersif/core/validation.h"

namespace xpersif::traces {

core::FeatureVector fromMsg(const xpersif::FeatureVector& msg) {
  core::FeatureVector out;
  out.stamp = msg.header.stamp.toSec();
  for (std::size_t i = 0; i < msg.objects.size(); ++i) {
    const auto& o = msg.objects[i];
    if (o.feature_names.size() != o.feature_values.size()) {
      throw core::ValidationError("objects[" + std::to_string(i) + "] has " + std::to_string(o.feature_names.size()) +
                                  " feature_names but " + std::to_string(o.feature_values.size()) + " feature_values");
    }
    core::ObjectFeatures f;
    f.name = o.name;
    f.x = o.position.x;
    f.y = o.position.y;
    f.yaw = o.yaw;
    for (std::size_t k = 0; k < o.feature_names.size(); ++k) f.extra[o.feature_names[k]] = o.feature_values[k];
    out.objects.push_back(std::move(f));
  }
  return out;
}

core::ExperimentRecord fromMsg(const xpersif::ExperimentRecord& msg) {
  core::ExperimentRecord r;
  r.id = static_cast<std::int64_t>(msg.id);
  r.run_id = static_cast<std::int64_t>(msg.run_id);
  r.seq = msg.seq;
  r.experiment.object = msg.experiment.object;
  r.experiment.side = msg.experiment.side;
  r.experiment.offset = msg.experiment.offset;
  r.experiment.distance = msg.experiment.distance;
  r.before = fromMsg(msg.before);
  r.after = fromMsg(msg.after);
  r.status = msg.status;
  r.failure_reason = msg.reason;
  if (msg.status == "done") r.outcome = core::Outcome{msg.dx, msg.dy, msg.dyaw};
  if (msg.predicted_mean.size() == 3 && msg.predicted_std.size() == 3) {
    core::Prediction p;
    p.mean = {msg.predicted_mean[0], msg.predicted_mean[1], msg.predicted_mean[2]};
    p.std = {msg.predicted_std[0], msg.predicted_std[1], msg.predicted_std[2]};
    r.prediction = p;
    if (std::isfinite(msg.surprise) && msg.surprise >= 0) r.surprise = msg.surprise;
  }
  r.started = msg.started;
  r.finished = msg.finished;
  return r;
}

xpersif::FeatureVector toMsg(const core::FeatureVector& features) {
  xpersif::FeatureVector msg;
  msg.header.stamp.fromSec(features.stamp);
  msg.header.frame_id = "world";
  for (const auto& f : features.objects) {
    xpersif::ObjectFeatures o;
    o.name = f.name;
    o.position.x = f.x;
    o.position.y = f.y;
    o.yaw = f.yaw;
    o.yaw_period = M_PI / 2;
    o.orientation_known = true;
    o.confidence = 1.0;
    for (const auto& [name, value] : f.extra) {
      o.feature_names.push_back(name);
      o.feature_values.push_back(value);
    }
    msg.objects.push_back(std::move(o));
  }
  return msg;
}

xpersif::ExperimentRecord toMsg(const core::ExperimentRecord& r) {
  xpersif::ExperimentRecord msg;
  msg.id = static_cast<std::uint64_t>(r.id);
  msg.run_id = static_cast<std::uint64_t>(r.run_id);
  msg.seq = static_cast<std::uint32_t>(r.seq);
  msg.experiment.object = r.experiment.object;
  msg.experiment.side = r.experiment.side;
  msg.experiment.offset = r.experiment.offset;
  msg.experiment.distance = r.experiment.distance;
  msg.status = r.status;
  msg.reason = r.failure_reason;
  msg.before = toMsg(r.before);
  msg.after = toMsg(r.after);
  if (r.outcome) {
    msg.dx = r.outcome->dx;
    msg.dy = r.outcome->dy;
    msg.dyaw = r.outcome->dyaw;
  }
  if (r.prediction) {
    msg.predicted_mean = {r.prediction->mean.dx, r.prediction->mean.dy, r.prediction->mean.dyaw};
    msg.predicted_std = {r.prediction->std.dx, r.prediction->std.dy, r.prediction->std.dyaw};
  }
  msg.surprise = r.surprise.value_or(0.0);
  msg.started = r.started;
  msg.finished = r.finished;
  return msg;
}

}  // namespace xpersif::traces
