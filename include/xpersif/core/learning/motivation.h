/**
 * @file motivation.h
 * @brief MOTIVATION's measures: surprise (how wrong a prediction was) and curiosity (where the robot expects
 *        to learn the most), after Oudeyer, Kaplan and Hafner's Intelligent Adaptive Curiosity (IEEE TEC 2007).
 *
 * Curiosity is not the error itself: a region where errors stay high because the outcome is unpredictable
 * (noise) or where they stay low because it is learned offers nothing to learn. IAC's curiosity is the
 * expected LEARNING PROGRESS: how much the mean prediction error fell between an older and a newer window of
 * the region's history. The experiment space is cut into regions: object x side x offset bin.
 */
#pragma once

#include <cstddef>
#include <deque>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "xpersif/core/common/experiment.h"
#include "xpersif/core/common/footprint.h"

namespace xpersif::core {

struct Surprise {
  /// Plain error magnitude, in metres: |(ex, ey, yaw_length * eyaw)|, so that a turn counts as the distance
  /// a point at yaw_length from the centre travels (MOTIVATION takes the objects' mean half-size).
  double error = 0.0;
  /// The error in units of the predicted std: sqrt(mean of (e_k / std_k)^2) over dx, dy, dyaw; about 1 when
  /// the outcome falls where the model said it would.
  double normalized = 0.0;
  Outcome residual;  ///< outcome - prediction (dyaw wrapped)
};

/// m: a turn counts as the travel of a point this far from the object's centre (errors and travels in metres).
constexpr double kYawLength = 0.02;

/// Throws ValidationError for non-finite values, a negative std, or yaw_length <= 0. A zero std counts as
/// 1e-9 (a model claiming certainty and being wrong is very surprised, not infinitely).
Surprise surprise(const Prediction& prediction, const Outcome& outcome, double yaw_length = kYawLength);

struct CuriosityConfig {
  std::vector<std::string> objects;                      ///< the objects the robot may push
  std::map<std::string, Footprint> footprints;           ///< each object's footprint (its offset limits)
  std::vector<std::string> sides = pushSides();
  int offset_bins = 3;  ///< equal bins over each face's offsets, [-maxPushOffset, maxPushOffset]
  std::size_t window = 5;                                ///< errors per window (older and newer)
  std::size_t min_visits = 2;                            ///< below this, a region is still "unexplored"
  double optimistic_curiosity = 1.0;                     ///< curiosity of an unexplored region
  std::size_t max_history = 200;                         ///< errors kept per region
};

struct RegionKey {
  std::string object;
  std::string side;
  int offset_bin = 0;
  bool operator<(const RegionKey& o) const {
    return std::tie(object, side, offset_bin) < std::tie(o.object, o.side, o.offset_bin);
  }
  bool operator==(const RegionKey& o) const {
    return object == o.object && side == o.side && offset_bin == o.offset_bin;
  }
  std::string toString() const;  ///< e.g. "red_cube/-x/1"
};

struct RegionStats {
  RegionKey key;
  std::size_t count = 0;        ///< errors recorded in total
  double mean_older = 0.0;      ///< mean error of the older window (0 if none)
  double mean_newer = 0.0;      ///< mean error of the newer window (0 if none)
  double progress = 0.0;        ///< mean_older - mean_newer (> 0: errors fall)
  double curiosity = 0.0;
  double last_error = 0.0;
};

/// The regions' error histories and their learning progress. Not thread-safe: one owner.
class CuriosityMap {
 public:
  /// Throws ValidationError for a bad config (no objects, bins < 1, window < 1, unknown sides...).
  explicit CuriosityMap(CuriosityConfig config);

  /// The region an experiment falls in. Throws ValidationError for an invalid experiment or unknown object.
  RegionKey regionOf(const Experiment& experiment) const;
  /// Record a prediction error (>= 0, finite; use Surprise::error or ::normalized, but one of them throughout).
  void record(const RegionKey& region, double error);
  void record(const Experiment& experiment, double error) { record(regionOf(experiment), error); }

  /// Learning progress of the region: mean of the older window minus mean of the newer one, the windows being
  /// the last 2 * window errors; with fewer errors, windows of half the history each (0 below 2 errors).
  double learningProgress(const RegionKey& region) const;
  /// optimistic_curiosity while the region has fewer than min_visits errors, its learning progress after.
  double curiosity(const RegionKey& region) const;
  /// Every region (objects x sides x bins), in key order.
  std::vector<RegionStats> regions() const;
  /// The most curious region; ties go to the least visited, then to key order (deterministic).
  RegionKey mostCurious() const;
  /// The offset interval [lo, hi] of a region, m (for designing an experiment in it).
  std::pair<double, double> offsetRange(const RegionKey& region) const;

  const CuriosityConfig& config() const { return config_; }

 private:
  void requireRegion(const RegionKey& region) const;
  RegionStats stats(const RegionKey& region) const;

  struct History {
    std::deque<double> errors;
    std::size_t count = 0;
  };
  CuriosityConfig config_;
  std::map<RegionKey, History> histories_;
};

}  // namespace xpersif::core
