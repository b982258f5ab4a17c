/**
 * @file learning_progress.h
 * @brief Curiosity by learning progress over adaptive regions of the experiment space (R-IAC, Baranes and
 *        Oudeyer 2009; SAGG-RIAC 2013), and the naive baseline that goes where the prediction error is highest.
 *
 * The experiment space is whatever the design may choose: the objects of the context (a category each), the
 * sides of the options (categories), the offset as a fraction of the pushed face's limit in [min_offset,
 * max_offset] and the distance in [min_distance, max_distance]. Nothing about a world is assumed.
 *
 * Every designed experiment that succeeded comes back with its held-out prediction error: the model predicted
 * the outcome before it saw it (LOOPMODEL's `surprise`, metres). The space starts as one region; a region that
 * holds more than `region_max_size` experiments is cut in two, along the cut (a set of objects or sides against
 * the rest, or a threshold on offset or distance) that maximises n_a * n_b * |I(a) - I(b)| (SAGG-RIAC's
 * criterion), where I is the region's interest. With regions_per_object the space starts cut by object (one
 * region each), so that an object learned at once or never does not share its region's interest with another:
 *  - learning progress (LearningProgressDesign): mean error of the older window minus mean error of the newer
 *    one, over the region's last 2 * progress_window errors in the order they were made (fewer errors: two
 *    halves). Errors that stay high (noise) or stay low (learned) give no progress. With progress_confidence
 *    z > 0 the difference is shrunk towards 0 by z of its standard errors (a confidence bound), so that the
 *    chance differences of a noisy region's windows count for little; with progress_at_most_error it counts at
 *    most the newer window's mean error (what is left to learn);
 *  - mean recent error (ErrorMaxDesign): the mean of the region's last progress_window errors. It is the trap
 *    the comparison shows: it goes where the outcome is noise.
 * Each choice: with probability `random_share` a uniformly random push over the whole space (it keeps every
 * region's estimate alive); otherwise a region (a leaf with a reachable object) by softmax over interest,
 * p ~ exp((I - I_best) / (temperature * I_best)) (I_best the best interest; the largest |I| when none is
 * positive), or greedily (the best, or with probability `epsilon` a random leaf),
 * then a uniformly random push inside it. The tree is rebuilt from the context's history at every call, so the
 * choice depends only on the history and the stream (a resumed run chooses as an uninterrupted one).
 */
#pragma once

#include <array>
#include <cstddef>
#include <random>
#include <string>
#include <vector>

#include "xpersif/core/planning/experiment_design.h"

namespace xpersif::core {

/// A point of the experiment space: object and side as indices, offset as a fraction, distance in metres.
struct SpacePoint {
  std::size_t object = 0;
  std::size_t side = 0;
  double offset = 0;    ///< fraction of the face's offset limit
  double distance = 0;  ///< m
};

/// The experiment space's extent: category names and the continuous ranges.
struct ExperimentSpace {
  std::vector<std::string> objects;
  std::vector<std::string> sides;
  double min_offset = -1, max_offset = 1;
  double min_distance = 0.015, max_distance = 0.15;
};

/// One region: a box of the space (categories allowed, continuous intervals), with its experiments.
struct Region {
  std::vector<bool> objects;  ///< by index of ExperimentSpace::objects
  std::vector<bool> sides;
  double offset_lo = 0, offset_hi = 0, distance_lo = 0, distance_hi = 0;
  std::vector<std::size_t> members;  ///< indices of AdaptiveRegions' points, in the order they were added
  int parent = -1;
  int children[2] = {-1, -1};
  std::string cut;  ///< how its parent was cut to make it, e.g. "object in {red_cube}" or "offset < 0.25"
  bool leaf() const { return children[0] < 0; }
};

/// What a region's errors say.
enum class Interest { Progress, Error };

/// How the regions' tree starts: one region for the whole space, or one per object (cut by object first).
enum class FirstCut { None, ByObject };

/// How learning progress is read beyond its windows.
struct ProgressRules {
  double confidence = 0.0;  ///< shrink the windows' difference towards 0 by this many standard errors (0..10)
  /// Count at most the newer window's mean error: a region cannot gain more than the error it has left, so an
  /// object learned at once stops drawing choices as soon as its errors are ~0, not when they leave the windows.
  bool at_most_recent_error = false;
};

/// The regions' tree over an experiment space. Not thread-safe.
class AdaptiveRegions {
 public:
  /// Throws ValidationError for an empty space, bad ranges, region_max_size < 4, window < 1 or a confidence
  /// outside [0, 10].
  AdaptiveRegions(ExperimentSpace space, Interest interest, std::size_t region_max_size, std::size_t window,
                  ProgressRules rules = {}, FirstCut first_cut = FirstCut::None);

  /// Adds an experiment (its point clamped into the space) with its held-out error (finite, >= 0); splits its
  /// region when it then holds more than region_max_size experiments and some cut leaves both sides at least
  /// a quarter of them.
  void add(const SpacePoint& point, double error);

  /// Learning progress of errors in the order they were made (older window mean - newer window mean), shrunk
  /// towards 0 by rules.confidence standard errors of that difference (windows of one error have none:
  /// unshrunk), and with rules.at_most_recent_error at most the newer window's mean.
  static double progress(const std::vector<double>& errors, std::size_t window, const ProgressRules& rules = {});
  /// Mean of the last @p window errors (0 for none).
  static double recentError(const std::vector<double>& errors, std::size_t window);

  /// The region's interest (progress or recent error, as constructed).
  double interest(int region) const;
  /// The region's errors in the order they were made.
  std::vector<double> errors(int region) const;
  /// The leaves, in the order they were made.
  std::vector<int> leaves() const;
  /// The leaf a point falls in.
  int leafOf(const SpacePoint& point) const;
  const Region& region(int id) const { return regions_.at(static_cast<std::size_t>(id)); }
  std::size_t size() const { return points_.size(); }
  const ExperimentSpace& space() const { return space_; }
  /// "red_cube,green_cube; -x,+x; offset [-1, 0.25); distance [0.015, 0.15)" (for rationales and reports).
  std::string describe(int region) const;

 private:
  void split(int region);
  /// Cuts leaf @p region in two, by categories (@p dim 0 objects, 1 sides; @p first: the first child's) or by
  /// @p threshold on the offset (2) or the distance (3); its members go to the children, whose ids it returns.
  std::array<int, 2> cutRegion(int region, int dim, const std::vector<bool>& first, double threshold);
  bool contains(const Region& r, const SpacePoint& p) const;
  double interestOf(const std::vector<std::size_t>& members) const;

  ExperimentSpace space_;
  Interest interest_;
  std::size_t region_max_size_;
  std::size_t window_;
  ProgressRules rules_;
  std::vector<SpacePoint> points_;
  std::vector<double> errors_;
  std::vector<Region> regions_;
};

/**
 * Region-based design by interest (see the file comment). LearningProgressDesign and ErrorMaxDesign are this
 * with the two interests. next() needs context.history (the run's successful experiments with their held-out
 * errors); without any it designs uniformly at random.
 */
class RegionInterestDesign : public ExperimentDesign {
 public:
  explicit RegionInterestDesign(Interest interest) : interest_(interest) {}
  void initialize(unsigned long seed, const DesignOptions& options) override;
  ExperimentChoice next(const DesignContext& context) override;
  bool usesHistory() const override { return true; }

  /// The regions built from the last next()'s history (for tests and traces).
  const AdaptiveRegions* regions() const { return regions_.get(); }

 private:
  Interest interest_;
  DesignOptions options_;
  std::mt19937_64 rng_;
  std::unique_ptr<AdaptiveRegions> regions_;
};

/// Curiosity by learning progress over adaptive regions ("learning_progress").
class LearningProgressDesign : public RegionInterestDesign {
 public:
  LearningProgressDesign() : RegionInterestDesign(Interest::Progress) {}
  LearningProgressDesign(unsigned long seed, const DesignOptions& options) : LearningProgressDesign() {
    initialize(seed, options);
  }
};

/// The naive baseline: where the recent prediction error is highest ("error_max").
class ErrorMaxDesign : public RegionInterestDesign {
 public:
  ErrorMaxDesign() : RegionInterestDesign(Interest::Error) {}
  ErrorMaxDesign(unsigned long seed, const DesignOptions& options) : ErrorMaxDesign() { initialize(seed, options); }
};

}  // namespace xpersif::core
