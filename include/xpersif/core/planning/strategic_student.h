/**
 * @file strategic_student.h
 * @brief Object-level designs (issue 38): the "strategic student" of Lopes & Oudeyer (2012), which chooses which
 *        object to practise as a bandit over objects scored by their learning progress, and round robin, which
 *        gives every object the same share and so shows what the variance of an allocation costs.
 *
 * Both choose an object, then a push drawn uniformly on it (side, offset, distance: uniformPush), so that the only
 * difference from random design is how the budget is shared among the objects.
 *
 * The strategic student ("strategic_student"):
 *  - first kWarmupPushes rounds of round robin over the objects (every object gets a few pushes);
 *  - then each object's learning progress from a learning curve fitted to the held-out errors of all its pushes
 *    (history: the error of each push's prediction, made before the push by the model of all the pushes before it,
 *    so an out-of-sample error): log(error + 1 mm) = a + b log(n) by least squares over the object's n-th pushes.
 *    Its progress is what one more push is expected to take off the error: the mean of its last 5 errors times
 *    1 - ((n+1)/n)^b', the fall of a power law with the slope b' = b + its standard error (only the part of the
 *    fall that noise rarely gives), and 0 when b' >= 0. The level comes from the recent errors, not from the fit,
 *    so an object that never moves (its errors go to 0 once the model knows it) scores 0 once they average below
 *    the 1 mm floor, and one that nothing predicts (its error does not fall) scores 0;
 *  - the object is drawn in proportion to progress, with a floor: probability random_share / K for each of the K
 *    reachable objects plus (1 - random_share) times its share of the progress (uniform when none progresses).
 * Being stateless between choices (everything comes from the context's history and stream), a resumed run chooses
 * as the uninterrupted one.
 *
 * Round robin ("round_robin"): the reachable objects in turn, by the number of experiments done so far.
 *
 * Replicate screening ("replicate_screening"): what a model can learn of an object is bounded by how differently the
 * object answers the same push (the pure error of a replicated design point). So:
 *  - a warm-up of two round-robin rounds: a uniform push on each object, then the same push again (a replicate);
 *    an object chosen later with fewer than kReplicatePairs replicated pairs, plus one per kReverifyEvery of its
 *    pushes beyond its even share, gets its last push again (one pair at first: each replicate teaches the model
 *    next to nothing, and two cost more than they told in design_replay; more as the object takes more than its
 *    share of the budget);
 *  - an object whose replicated pushes moved it differently (the median over its pairs of |outcome difference| /
 *    max(mean |outcome|, 5 mm) above kNoisySpread) is noise to the model and gets only the floor; so does one that is
 *    known: its last errors average below the 1 mm floor, or none of its two or more pushes moved it 1 mm; the
 *    others are what is left to learn, and share the rest equally (the study's measure weighs every object that
 *    moves equally);
 *  - probabilities as the strategic student's: random_share / K each, plus (1 - random_share) over the learnable.
 * Stateless between choices, as the strategic student.
 */
#pragma once

#include <map>
#include <random>
#include <string>
#include <vector>

#include "xpersif/core/planning/experiment_design.h"

namespace xpersif::core {

/// Round-robin pushes per object before the strategic student scores progress.
constexpr std::size_t kWarmupPushes = 3;

/// An object's learning curve fitted to its held-out errors in order: log(error + floor) = a + b log(n).
struct ObjectCurveFit {
  std::size_t pushes = 0;
  double a = 0, b = 0, b_se = 0;  ///< intercept, slope and the slope's standard error (0 below 3 pushes)
  /// What one more push is expected to take off the error (m): the recent errors' mean times the power law's fall
  /// with the slope made conservative by one standard error; 0 when that slope does not fall or the recent errors
  /// average below 1 mm (the object is known: its tiny progress must not take the shares of noisier objects).
  double progress = 0;
};

/// The fit of @p errors (held-out errors of an object's pushes, in order).
ObjectCurveFit fitObjectCurve(const std::vector<double>& errors);

/// What the object-level designs share: validated options and a generator reseeded from each choice's stream.
class ObjectLevelDesign : public ExperimentDesign {
 public:
  void initialize(unsigned long seed, const DesignOptions& options) override;

 protected:
  DesignOptions options_;
  std::mt19937_64 rng_;
};

class StrategicStudentDesign : public ObjectLevelDesign {
 public:
  StrategicStudentDesign() = default;
  StrategicStudentDesign(unsigned long seed, const DesignOptions& options) { initialize(seed, options); }
  ExperimentChoice next(const DesignContext& context) override;
  bool usesHistory() const override { return true; }
  /// Each reachable object's probability of being chosen after the warm-up (for rationales and tests).
  std::map<std::string, double> probabilities(const DesignContext& context) const;
};

/// Replicated pairs per object the replicate screening wants before it trusts an object's spread.
constexpr std::size_t kReplicatePairs = 1;
/// And one more for every this many pushes the object has beyond its even share: one pair is a single draw of an
/// object's noise (a long push carries a redrawn cube with the robot whatever its friction), so what takes the budget
/// is checked again as it does. Not per push: where every object is learnable, shares stay even and replicates,
/// which teach the model next to nothing, cost the budget (the all-learnable control lost 5 % with them per push).
constexpr std::size_t kReverifyEvery = 10;
/// The replicated pairs wanted of an object with @p object_pushes of @p all_pushes, shared by @p objects objects:
/// kReplicatePairs, plus one per kReverifyEvery of its pushes beyond all_pushes / objects.
std::size_t replicatePairsWanted(std::size_t object_pushes, std::size_t all_pushes, std::size_t objects);
/// Above this relative spread of replicated outcomes, an object is noise to the model (measured on 2026-11-28's
/// studies: deterministic objects 0.03-0.06 median, 0.15 at the 90th percentile; friction redrawn per push 0.37-0.94).
constexpr double kNoisySpread = 0.25;

/// How differently an object answered the same push: its pairs of pushes with the same side and, within 3 mm and
/// 6 mm, the same offset and distance (so that the nearest pooled pushes of an offline replay count too).
struct ReplicateSpread {
  std::size_t pairs = 0;
  double spread = 0;  ///< the pairs' median |outcome difference| / max(mean |outcome|, 5 mm); 0 without pairs
};

/// The spread of @p pushes (one object's, in order).
ReplicateSpread replicateSpread(const std::vector<PastExperiment>& pushes);

class ReplicateScreeningDesign : public ObjectLevelDesign {
 public:
  ReplicateScreeningDesign() = default;
  ReplicateScreeningDesign(unsigned long seed, const DesignOptions& options) { initialize(seed, options); }
  ExperimentChoice next(const DesignContext& context) override;
  bool usesHistory() const override { return true; }
  /// Each reachable object's probability of being chosen after the warm-up (for rationales and tests).
  std::map<std::string, double> probabilities(const DesignContext& context) const;
};

class RoundRobinDesign : public ObjectLevelDesign {
 public:
  RoundRobinDesign() = default;
  RoundRobinDesign(unsigned long seed, const DesignOptions& options) { initialize(seed, options); }
  ExperimentChoice next(const DesignContext& context) override;
};

}  // namespace xpersif::core
