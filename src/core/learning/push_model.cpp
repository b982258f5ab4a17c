/**
 * @file push_model.cpp
 * @brief What every push model shares: input checks, the input encoding and its scales, notions from pushes.
 */
#include "xpersif/core/learning/push_model.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {
constexpr double kDirectionScale = 1.0;
constexpr double kOffsetScale = 0.01;    // m
constexpr double kDistanceScale = 0.03;  // m
}  // namespace

void checkPushModelConfig(const PushModelConfig& c) {
  requirePositive("prior_std.dx", c.prior_std.dx);
  requirePositive("prior_std.dy", c.prior_std.dy);
  requirePositive("prior_std.dyaw", c.prior_std.dyaw);
  throwIfInvalid(checkMaxSize("feature_names", c.feature_names.size(), kMaxExtraFeatures));
  throwIfInvalid(checkMaxSize("identities", c.identities.size(), kMaxObjectsPerFeatureVector));
  for (const auto& name : c.feature_names) {
    if (name.empty()) throw ValidationError("feature_names has an empty name");
  }
  for (const auto& [name, scale] : c.feature_scales) requirePositive("feature_scales[" + name + "]", scale);
  if (c.one_hot_identity && c.identities.empty()) {
    throw ValidationError("one_hot_identity is on but identities is empty; list the object names");
  }
}

void checkPushInput(const std::vector<std::string>& feature_names, const PushInput& input, const std::string& field) {
  requireExperiment(field + ".experiment", input.experiment);
  if (input.object.name != input.experiment.object) {
    throw ValidationError(field + ".object.name '" + input.object.name + "' is not the pushed object '" +
                          input.experiment.object + "'");
  }
  requireFinite(field + ".object.x", input.object.x);
  requireFinite(field + ".object.y", input.object.y);
  requireFinite(field + ".object.yaw", input.object.yaw);
  for (const auto& name : feature_names) {
    const auto it = input.object.extra.find(name);
    if (it == input.object.extra.end()) {
      throw ValidationError(field + ".object.extra has no feature '" + name + "'; the learner uses it as an input");
    }
    requireFinite(field + ".object.extra[" + name + "]", it->second);
  }
}

std::vector<double> encodePushInput(const PushModelConfig& config, const PushInput& input) {
  checkPushInput(config.feature_names, input, "input");
  const double angle = pushAngleInObject(input.experiment.side);
  std::vector<double> row{std::cos(angle), std::sin(angle), input.experiment.offset, input.experiment.distance};
  for (const auto& name : config.feature_names) row.push_back(input.object.extra.at(name));
  if (config.one_hot_identity) {
    for (const auto& id : config.identities) row.push_back(id == input.object.name ? 1.0 : 0.0);
  }
  return row;
}

std::vector<double> pushInputScales(const PushModelConfig& c) {
  std::vector<double> scales{kDirectionScale, kDirectionScale, kOffsetScale, kDistanceScale};
  for (const auto& name : c.feature_names) {
    const auto it = c.feature_scales.find(name);
    scales.push_back(it == c.feature_scales.end() ? 1.0 : it->second);
  }
  if (c.one_hot_identity) scales.insert(scales.end(), c.identities.size(), 1.0);
  return scales;
}

std::vector<Notion> PushModel::notions() const { return deriveNotions(samples()); }

// ---- notions -------------------------------------------------------------------------------------------

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double pearson(const std::vector<double>& a, const std::vector<double>& b) {
  const double n = static_cast<double>(a.size());
  double ma = 0, mb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    ma += a[i];
    mb += b[i];
  }
  ma /= n;
  mb /= n;
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  if (saa <= 0 || sbb <= 0) return 0.0;
  return sab / std::sqrt(saa * sbb);
}

std::string percent(double share) { return std::to_string(static_cast<int>(std::lround(share * 100))) + " %"; }

std::string fixed(double value, int digits) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << value;
  return out.str();
}

}  // namespace

std::vector<Notion> deriveNotions(const std::vector<PushSample>& samples) {
  constexpr double kStillRatio = 0.1;
  constexpr double kOffCentre = 0.004;
  constexpr std::size_t kMinPushes = 3, kMinOffCentre = 5;
  std::map<std::string, std::vector<const PushSample*>> by_object;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const std::string field = "samples[" + std::to_string(i) + "]";
    requireExperiment(field + ".input.experiment", samples[i].input.experiment);
    requireOutcome(field + ".outcome", samples[i].outcome);
    by_object[samples[i].input.experiment.object].push_back(&samples[i]);
  }
  std::vector<Notion> notions;
  for (const auto& [object, pushes] : by_object) {
    if (pushes.size() < kMinPushes) continue;
    const int n = static_cast<int>(pushes.size());
    std::vector<double> ratios;
    for (const PushSample* s : pushes) {
      ratios.push_back(std::hypot(s->outcome.dx, s->outcome.dy) / s->input.experiment.distance);
    }
    const double median_ratio = median(ratios);
    double mean_ratio = 0;
    int still = 0, further = 0;
    for (double r : ratios) {
      mean_ratio += r / n;
      still += r < kStillRatio;
      further += r > 1.0;
    }
    if (median_ratio < kStillRatio) {
      notions.push_back({object, "does_not_move_when_pushed", median_ratio, static_cast<double>(still) / n, n,
                         object + " does not move when pushed (median displacement " +
                             percent(median_ratio) + " of the push distance over " + std::to_string(n) +
                             " pushes)."});
      continue;
    }
    notions.push_back({object, "moves_when_pushed", mean_ratio, static_cast<double>(n - still) / n, n,
                       object + " moves when pushed, on average " + fixed(mean_ratio, 2) +
                           " times the push distance (" + std::to_string(n) + " pushes)."});
    if (median_ratio > 1.05) {
      notions.push_back({object, "slides_further_than_pushed", median_ratio, static_cast<double>(further) / n, n,
                         object + " slides further than it is pushed (median " + fixed(median_ratio, 2) +
                             " times the push distance)."});
    }
    // Rotation per metre pushed against the offset.
    std::vector<double> abs_offset, abs_turn, offset, turn;
    for (const PushSample* s : pushes) {
      const double per_metre = s->outcome.dyaw / s->input.experiment.distance;
      abs_offset.push_back(std::fabs(s->input.experiment.offset));
      abs_turn.push_back(std::fabs(per_metre));
      offset.push_back(s->input.experiment.offset);
      turn.push_back(per_metre);
    }
    const double magnitude_r = pearson(abs_offset, abs_turn);
    const double signed_r = pearson(offset, turn);
    int off_centre = 0, agree = 0;
    for (std::size_t i = 0; i < offset.size(); ++i) {
      if (std::fabs(offset[i]) < kOffCentre) continue;
      ++off_centre;
      // Agreement with the dominant direction: turns with the offset (r > 0) or against it (r < 0).
      agree += (turn[i] * offset[i] * signed_r) > 0;
    }
    if (off_centre >= static_cast<int>(kMinOffCentre) && magnitude_r >= 0.5) {
      const double share = static_cast<double>(agree) / off_centre;
      if (share >= 0.8) {
        notions.push_back({object, "rotates_when_pushed_off_centre", signed_r, share, off_centre,
                           "off-centre pushes rotate " + object + (signed_r < 0 ? ", away from" : ", towards") +
                               " the side of the contact (" + std::to_string(agree) + " of " +
                               std::to_string(off_centre) + " off-centre pushes)."});
      }
    }
  }
  return notions;
}

PushSample pushSampleFrom(const std::string& object, const std::string& side, double offset, double distance,
                          const std::vector<double>& pose, const std::vector<double>& features,
                          const std::vector<std::string>& feature_names, const std::vector<double>& outcome) {
  PushSample s;
  s.input.experiment.object = object;
  s.input.experiment.side = side;
  s.input.experiment.offset = offset;
  s.input.experiment.distance = distance;
  s.input.object.name = object;
  s.input.object.x = pose[0];
  s.input.object.y = pose[1];
  s.input.object.yaw = pose[2];
  for (std::size_t i = 0; i < features.size(); ++i) s.input.object.extra[feature_names[i]] = features[i];
  s.outcome = {outcome[0], outcome[1], outcome[2]};
  return s;
}

}  // namespace xpersif::core
