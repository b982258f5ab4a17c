/**
 * @file experiment_design.h
 * @brief DESIGNOFEXPERIMENTS' algorithms: which push to try next. A curiosity-driven design (steered by
 *        MOTIVATION's expected learning progress) and the two baselines the paper's comparison needs, random
 *        and grid, behind one interface so the loop can swap them by name.
 *
 * An experiment is a push: the robot drives against one face of a cube (side, in the cube's frame: "-x",
 * "+x", "-y", "+y"; the push goes along the face's inward normal), at a lateral offset of the contact point
 * from the face's centre, for a distance after contact. Every design is seeded and deterministic: the same
 * seed and the same sequence of contexts give the same experiments. Unreachable objects are never chosen, and
 * with a context's `feasible` set no push it rejects is chosen while another can be found (drawFeasible).
 */
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "xpersif/core/common/experiment.h"
#include "xpersif/core/common/footprint.h"

namespace xpersif::core {

/// One designed experiment (a push). The loop turns it into its full experiment record.
struct ExperimentChoice {
  std::string object;  ///< e.g. "red_cube"
  std::string side;    ///< one of pushSides() (core/experiment.h)
  double offset = 0;   ///< metres, lateral offset of the contact point from the face centre
  double distance = 0; ///< metres driven after contact
  std::string rationale;  ///< why this one, for people and traces (e.g. "grid cell 3 of 96")

  /// "push red_cube on +x, offset 0.01 m, distance 0.06 m"
  std::string toString() const;
};

struct DesignObject {
  std::string name;
  bool reachable = true;  ///< false: the robot cannot get to it now (e.g. against a wall); never chosen
  Footprint footprint;    ///< its offsets are fractions of maxPushOffset(footprint, side)
};

/// An experiment of the run so far, with the error of the prediction the model made before it saw the outcome
/// (held out: LOOPMODEL's `surprise`, metres). Only successful experiments have one.
struct PastExperiment {
  std::string object;
  std::string side;
  double offset = 0;    ///< m
  double distance = 0;  ///< m
  double error = 0;     ///< m, >= 0
  double moved_x = 0;   ///< m, the object's motion along the push (the outcome's dx, in the push frame)
  double moved_y = 0;   ///< m, and to the push's left (dy)
};

struct DesignContext {
  std::vector<DesignObject> objects;  ///< the objects that may be pushed
  std::size_t history_count = 0;      ///< experiments done so far
  /// When set, the design draws this choice from a generator seeded with it (core::streamSeed of the run's
  /// seed, run and experiment), not from its own running generator: a resumed run then chooses the same.
  std::optional<std::uint64_t> stream;
  /// Expected learning progress of a candidate (MOTIVATION's curiosity); required by the curiosity design.
  std::function<double(const ExperimentChoice&)> curiosity;
  /// The run's successful experiments so far, in order, with their held-out errors; required (possibly empty)
  /// by designs whose usesHistory() is true.
  std::vector<PastExperiment> history;
  /// Whether a push can be done from where the objects are now (DESIGNOFEXPERIMENTS: MANIPULATION's push
  /// planner on the request's scene: a free approach spot, no wall or object in the way). Unset: every push
  /// can. A refused push teaches nothing and costs an experiment of the budget, so designs draw again instead.
  std::function<bool(const ExperimentChoice&)> feasible;
};

/// Draws a design makes for one choice before it gives up on `feasible` (kept small: each is a push plan).
constexpr int kFeasibleDraws = 64;

/// Calls @p draw until context.feasible accepts what it gives, at most kFeasibleDraws times (once when
/// feasible is unset). Returns the first accepted draw, or nothing; @p refused (optional) counts the rejected.
std::optional<ExperimentChoice> drawFeasible(const DesignContext& context,
                                             const std::function<ExperimentChoice()>& draw, int* refused = nullptr);
/// For rationales: "" when nothing was refused; otherwise how many draws the planner would refuse were skipped,
/// or (@p found false) that none was feasible, so that the choice will be refused.
std::string refusedNote(int refused, bool found);

struct DesignOptions;

/// The context's reachable objects (their names checked, unique); throws ValidationError (and so changes nothing)
/// when there are none.
std::vector<DesignObject> reachableObjects(const DesignContext& context);

/// A push drawn uniformly on one of @p objects: a side, an offset (a fraction of that face's limit) and a distance
/// within the options' bounds.
ExperimentChoice uniformPush(std::mt19937_64& rng, const std::vector<DesignObject>& objects,
                             const DesignOptions& options);

/// Offsets are fractions in [-1, 1] of each pushed face's offset limit (maxPushOffset, footprint.h), so one
/// set of options fits objects of every shape and size; distances are metres, normally the set-up's
/// (SetupCatalogue::minPushDistance / maxPushDistance).
struct DesignOptions {
  double min_offset = -1.0;  ///< fraction of the face's offset limit, in [-1, 1]
  double max_offset = 1.0;
  double min_distance = 0.015;  ///< m, > 0
  double max_distance = 0.15;   ///< m, >= min_distance
  std::vector<std::string> sides = pushSides();            ///< the faces designs may choose
  /// Grid design's values: offsets as fractions in [-1, 1] of the face's offset limit, distances as fractions
  /// in (0, 1] of max_distance.
  std::vector<double> grid_offsets{-0.75, 0.0, 0.75};
  std::vector<double> grid_distances{0.2, 0.4};
  std::size_t candidates = 32;  ///< curiosity design: candidates sampled per decision (1..10000)
  double epsilon = 0.1;         ///< curiosity design: probability of a random candidate instead of the best;
                                ///< region designs with region_choice "greedy": probability of a random region
  // Region designs (learning_progress, error_max; learning_progress.h):
  std::size_t region_max_size = 30;  ///< a region holding more experiments is split (4..10000)
  std::size_t progress_window = 10;  ///< errors per window of the learning progress (1..1000)
  std::string region_choice = "softmax";  ///< "softmax" or "greedy"
  double temperature = 0.1;   ///< softmax temperature, relative to the largest |interest| (0.001..100)
  double random_share = 0.2;  ///< probability of a uniformly random push over the whole space, [0, 1]
  /// Learning progress counts only beyond this many standard errors of the difference of the window means
  /// (0: the plain difference), so that a region whose errors are noise wins only by a margin noise rarely
  /// gives (0..10).
  double progress_confidence = 0.0;
  bool regions_per_object = false;  ///< region designs: start with one region per object, not one for all
  bool progress_at_most_error = false;  ///< learning progress counts at most the region's recent mean error

  /// Throw ValidationError (one sentence naming the option) unless the options are consistent.
  void validate() const;
};

/**
 * DESIGNOFEXPERIMENTS' algorithm (a pluginlib base class: "xpersif::core::ExperimentDesign"; the classes of
 * experiment_design_plugins.xml and any other package's). Plugins are made with their default constructor and
 * then initialize()d; a design used before initialize() works with seed 0 and default options.
 */
class ExperimentDesign {
 public:
  virtual ~ExperimentDesign() = default;
  /// Start again from @p seed with @p options. Throws ValidationError for bad options (and keeps the old ones).
  virtual void initialize(unsigned long seed, const DesignOptions& options) = 0;
  /// The next experiment. Throws ValidationError when the context offers nothing to push (no objects, none
  /// reachable, malformed names) or lacks what the design needs; the design's state is then unchanged.
  virtual ExperimentChoice next(const DesignContext& context) = 0;
  /// Whether next() consults context.curiosity (DESIGNOFEXPERIMENTS then waits for MOTIVATION's latest word).
  virtual bool usesCuriosity() const { return false; }
  /// Whether next() reads context.history (DESIGNOFEXPERIMENTS then follows the knowledge base's experiments of
  /// the run and waits until it has every one the request counts).
  virtual bool usesHistory() const { return false; }
};

/// Uniform over reachable objects, sides, offsets and distances (within the options' bounds), and over the
/// feasible ones among them when the context says which are (rejection; the last draw when none is found).
class RandomDesign : public ExperimentDesign {
 public:
  RandomDesign() = default;
  RandomDesign(unsigned long seed, DesignOptions options = {});
  void initialize(unsigned long seed, const DesignOptions& options) override;
  ExperimentChoice next(const DesignContext& context) override;

 private:
  DesignOptions options_;
  std::mt19937_64 rng_;
};

/**
 * Cycles through sides x grid_offsets x grid_distances x objects in that nesting order (object innermost, so
 * that every budget spreads over all objects evenly), skipping cells whose object is unreachable now or whose
 * push the context's `feasible` rejects (when every cell is rejected: the first reachable one). The
 * cursor is the grid cell after the last one chosen; it wraps around. A new grid asked with a history (a
 * resumed run) starts at cell history_count: the same cell as the uninterrupted run unless cells were skipped.
 */
class GridDesign : public ExperimentDesign {
 public:
  GridDesign() = default;
  explicit GridDesign(DesignOptions options);
  /// The grid has no randomness: @p seed is unused.
  void initialize(unsigned long seed, const DesignOptions& options) override;
  ExperimentChoice next(const DesignContext& context) override;
  /// Cells in the grid for @p objects objects.
  std::size_t cells(std::size_t objects) const;

 private:
  DesignOptions options_;
  std::size_t cursor_ = 0;
  bool started_ = false;
};

/**
 * Samples `candidates` random pushes (feasible ones, as RandomDesign) and chooses the one with the highest curiosity; with probability
 * epsilon it chooses a uniformly random one of them instead, so every push keeps a chance of being tried.
 * Ties go to the candidate sampled first (deterministic for a seed). A NaN curiosity is an error.
 */
class CuriosityDesign : public ExperimentDesign {
 public:
  CuriosityDesign() = default;
  CuriosityDesign(unsigned long seed, DesignOptions options = {});
  void initialize(unsigned long seed, const DesignOptions& options) override;
  ExperimentChoice next(const DesignContext& context) override;
  bool usesCuriosity() const override { return true; }
  /// Whether the last choice was an epsilon exploration (not the most curious candidate).
  bool lastWasExploration() const { return last_exploration_; }

 private:
  DesignOptions options_;
  std::mt19937_64 rng_;
  bool last_exploration_ = false;
};

/// The designs of this package under the names experiment_design_plugins.xml gives them ("curiosity",
/// "random", "grid", "learning_progress", "error_max", "strategic_student", "round_robin", "replicate_screening"), for tools and tests without pluginlib; DESIGNOFEXPERIMENTS loads designs by name
/// through pluginlib, which also finds other packages' designs.
std::vector<std::string> designNames();

/// One of designNames(), initialized; unknown names and bad options throw ValidationError.
std::unique_ptr<ExperimentDesign> makeDesign(const std::string& name, unsigned long seed,
                                             const DesignOptions& options = {});

}  // namespace xpersif::core
