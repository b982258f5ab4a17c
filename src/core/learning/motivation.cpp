#include "xpersif/core/learning/motivation.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

Surprise surprise(const Prediction& prediction, const Outcome& outcome, double yaw_length) {
  requirePositive("yaw_length", yaw_length);
  requireAllFinite("prediction.mean", {prediction.mean.dx, prediction.mean.dy, prediction.mean.dyaw});
  requireAllFinite("outcome", {outcome.dx, outcome.dy, outcome.dyaw});
  const double stds[3] = {prediction.std.dx, prediction.std.dy, prediction.std.dyaw};
  const char* names[3] = {"prediction.std.dx", "prediction.std.dy", "prediction.std.dyaw"};
  for (int k = 0; k < 3; ++k) {
    requireFinite(names[k], stds[k]);
    if (stds[k] < 0) throw ValidationError(std::string(names[k]) + " is negative; a std must be 0 or more");
  }
  Surprise s;
  s.residual.dx = outcome.dx - prediction.mean.dx;
  s.residual.dy = outcome.dy - prediction.mean.dy;
  s.residual.dyaw = wrapAngle(outcome.dyaw - prediction.mean.dyaw);
  const double e[3] = {s.residual.dx, s.residual.dy, s.residual.dyaw};
  s.error = std::sqrt(e[0] * e[0] + e[1] * e[1] + (yaw_length * e[2]) * (yaw_length * e[2]));
  double z2 = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double z = e[k] / std::max(stds[k], 1e-9);
    z2 += z * z;
  }
  s.normalized = std::sqrt(z2 / 3.0);
  return s;
}

std::string RegionKey::toString() const { return object + "/" + side + "/" + std::to_string(offset_bin); }

CuriosityMap::CuriosityMap(CuriosityConfig config) : config_(std::move(config)) {
  const CuriosityConfig& c = config_;
  if (c.objects.empty()) throw ValidationError("curiosity objects is empty; list the objects the robot may push");
  throwIfInvalid(checkMaxSize("curiosity objects", c.objects.size(), kMaxObjectsPerFeatureVector));
  std::set<std::string> unique;
  for (const auto& object : c.objects) {
    if (object.empty()) throw ValidationError("curiosity objects has an empty name");
    if (!unique.insert(object).second) throw ValidationError("curiosity objects lists '" + object + "' twice");
    const auto footprint = c.footprints.find(object);
    if (footprint == c.footprints.end()) {
      throw ValidationError("curiosity footprints has no entry for '" + object + "'; its offsets cannot be binned");
    }
    throwIfInvalid(footprint->second.check("footprint of '" + object + "'"));
  }
  if (c.sides.empty()) throw ValidationError("curiosity sides is empty; give at least one side");
  std::set<std::string> sides;
  for (const auto& side : c.sides) {
    throwIfInvalid(checkOneOf("curiosity side", side, pushSides()));
    if (!sides.insert(side).second) throw ValidationError("curiosity sides lists '" + side + "' twice");
  }
  if (c.offset_bins < 1 || c.offset_bins > 100) throw ValidationError("offset_bins must be in [1, 100]");
  if (c.window < 1) throw ValidationError("curiosity window must be at least 1");
  if (c.min_visits < 1) throw ValidationError("min_visits must be at least 1");
  if (c.max_history < 2 * c.window) throw ValidationError("max_history must hold two windows (2 * window)");
  requireFinite("optimistic_curiosity", c.optimistic_curiosity);
  for (const auto& object : c.objects) {
    for (const auto& side : c.sides) {
      for (int bin = 0; bin < c.offset_bins; ++bin) histories_[RegionKey{object, side, bin}];
    }
  }
}

RegionKey CuriosityMap::regionOf(const Experiment& experiment) const {
  requireExperiment("experiment", experiment);
  RegionKey key{experiment.object, experiment.side, 0};
  const auto footprint = config_.footprints.find(experiment.object);
  if (footprint == config_.footprints.end()) throwIfInvalid(checkKnownName("experiment.object", experiment.object, config_.objects));
  const double limit = maxPushOffset(footprint->second, experiment.side);
  throwIfInvalid(checkInRange("experiment.offset", experiment.offset, -limit, limit));
  const double unit = (experiment.offset + limit) / (2.0 * limit);  // [0, 1]
  key.offset_bin = std::clamp(static_cast<int>(std::floor(unit * config_.offset_bins)), 0, config_.offset_bins - 1);
  requireRegion(key);
  return key;
}

std::pair<double, double> CuriosityMap::offsetRange(const RegionKey& region) const {
  requireRegion(region);
  const double limit = maxPushOffset(config_.footprints.at(region.object), region.side);
  const double width = 2.0 * limit / config_.offset_bins;
  return {-limit + region.offset_bin * width, -limit + (region.offset_bin + 1) * width};
}

void CuriosityMap::requireRegion(const RegionKey& region) const {
  if (histories_.count(region)) return;
  if (std::find(config_.objects.begin(), config_.objects.end(), region.object) == config_.objects.end()) {
    throwIfInvalid(checkKnownName("region object", region.object, config_.objects));
  }
  throwIfInvalid(checkOneOf("region side", region.side, config_.sides));
  throw ValidationError("region offset bin " + std::to_string(region.offset_bin) + " is not in [0, " +
                        std::to_string(config_.offset_bins - 1) + "]");
}

void CuriosityMap::record(const RegionKey& region, double error) {
  requireRegion(region);
  throwIfInvalid(checkInRange("prediction error", error, 0.0, 1e12));
  History& h = histories_.at(region);
  h.errors.push_back(error);
  ++h.count;
  while (h.errors.size() > config_.max_history) h.errors.pop_front();
}

RegionStats CuriosityMap::stats(const RegionKey& region) const {
  const History& h = histories_.at(region);
  RegionStats s;
  s.key = region;
  s.count = h.count;
  const std::size_t c = h.errors.size();
  if (c > 0) s.last_error = h.errors.back();
  if (c >= 2) {
    const std::size_t w = std::min(config_.window, c / 2);  // two full windows, or two halves
    auto mean = [&](std::size_t from, std::size_t to) {
      double sum = 0.0;
      for (std::size_t i = from; i < to; ++i) sum += h.errors[i];
      return sum / static_cast<double>(to - from);
    };
    s.mean_newer = mean(c - w, c);
    s.mean_older = mean(c - 2 * w, c - w);
    s.progress = s.mean_older - s.mean_newer;
  }
  s.curiosity = h.count < config_.min_visits ? config_.optimistic_curiosity : s.progress;
  return s;
}

double CuriosityMap::learningProgress(const RegionKey& region) const {
  requireRegion(region);
  return stats(region).progress;
}

double CuriosityMap::curiosity(const RegionKey& region) const {
  requireRegion(region);
  return stats(region).curiosity;
}

std::vector<RegionStats> CuriosityMap::regions() const {
  std::vector<RegionStats> all;
  for (const auto& [key, history] : histories_) all.push_back(stats(key));
  return all;
}

RegionKey CuriosityMap::mostCurious() const {
  const std::vector<RegionStats> all = regions();
  const RegionStats* best = &all.front();
  for (const RegionStats& s : all) {
    if (s.curiosity > best->curiosity || (s.curiosity == best->curiosity && s.count < best->count)) best = &s;
  }
  return best->key;
}

}  // namespace xpersif::core
