/**
 * @file experiment_design.cpp
 * @brief Random, grid and curiosity-driven designs of the next push; see experiment_design.h.
 */
#include "xpersif/core/planning/experiment_design.h"

#include "xpersif/core/planning/learning_progress.h"
#include "xpersif/core/planning/strategic_student.h"
#include "xpersif/core/common/validation.h"

#include <cmath>
#include <set>
#include <sstream>

namespace xpersif::core {

namespace {

std::string metres(double v) { return describeNumber(v) + " m"; }

}  // namespace

std::vector<DesignObject> reachableObjects(const DesignContext& context) {
  if (context.objects.empty()) {
    throw ValidationError("context.objects is empty; there is no object to design an experiment for");
  }
  std::vector<DesignObject> names;
  std::set<std::string> seen;
  for (std::size_t i = 0; i < context.objects.size(); ++i) {
    const auto& o = context.objects[i];
    requireIdentifier("context.objects[" + std::to_string(i) + "].name", o.name);
    if (!seen.insert(o.name).second) {
      throw ValidationError("context.objects[" + std::to_string(i) + "].name '" + o.name +
                            "' is listed twice; object names must be unique");
    }
    throwIfInvalid(o.footprint.check("context.objects[" + std::to_string(i) + "].footprint"));
    if (o.reachable) names.push_back(o);
  }
  if (names.empty()) {
    std::string all;
    for (const auto& o : context.objects) all += (all.empty() ? "'" : ", '") + o.name + "'";
    throw ValidationError("none of the objects (" + all + ") is reachable; there is nothing to push now");
  }
  return names;
}

ExperimentChoice uniformPush(std::mt19937_64& rng, const std::vector<DesignObject>& objects, const DesignOptions& o) {
  ExperimentChoice c;
  const DesignObject& object = objects[std::uniform_int_distribution<std::size_t>(0, objects.size() - 1)(rng)];
  c.object = object.name;
  c.side = o.sides[std::uniform_int_distribution<std::size_t>(0, o.sides.size() - 1)(rng)];
  c.offset = std::uniform_real_distribution<double>(o.min_offset, o.max_offset)(rng) *
             maxPushOffset(object.footprint, c.side);
  c.distance = std::uniform_real_distribution<double>(o.min_distance, o.max_distance)(rng);
  return c;
}

std::optional<ExperimentChoice> drawFeasible(const DesignContext& context,
                                             const std::function<ExperimentChoice()>& draw, int* refused) {
  const int tries = context.feasible ? kFeasibleDraws : 1;
  for (int i = 0; i < tries; ++i) {
    ExperimentChoice c = draw();
    if (!context.feasible || context.feasible(c)) return c;
    if (refused) ++*refused;
  }
  return std::nullopt;
}

std::string refusedNote(int refused, bool found) {
  if (refused == 0) return "";
  if (!found) return " (the push planner would refuse every push drawn: " + std::to_string(refused) + " draws)";
  return " (" + std::to_string(refused) + (refused == 1 ? " draw" : " draws") + " the push planner would refuse skipped)";
}

std::string ExperimentChoice::toString() const {
  return "push " + object + " on " + side + ", offset " + metres(offset) + ", distance " + metres(distance);
}

void DesignOptions::validate() const {
  requireInRange("options.min_offset", min_offset, -1, 1);
  requireInRange("options.max_offset", max_offset, -1, 1);
  if (min_offset > max_offset) {
    throw ValidationError("options.min_offset (" + describeNumber(min_offset) +
                          ") is greater than options.max_offset (" + describeNumber(max_offset) + ")");
  }
  requirePositive("options.min_distance", min_distance);
  requireInRange("options.min_distance", min_distance, 0, kMaxPushExtent);
  requireInRange("options.max_distance", max_distance, 0, kMaxPushExtent);
  if (min_distance > max_distance) {
    throw ValidationError("options.min_distance (" + metres(min_distance) +
                          ") is greater than options.max_distance (" + metres(max_distance) + ")");
  }
  if (sides.empty()) throw ValidationError("options.sides is empty; list at least one of -x, +x, -y, +y");
  for (std::size_t i = 0; i < sides.size(); ++i) {
    requireOneOf("options.sides[" + std::to_string(i) + "]", sides[i], pushSides());
  }
  if (grid_offsets.empty()) throw ValidationError("options.grid_offsets is empty; list at least one offset");
  for (std::size_t i = 0; i < grid_offsets.size(); ++i) {
    requireInRange("options.grid_offsets[" + std::to_string(i) + "]", grid_offsets[i], -1, 1);
  }
  if (grid_distances.empty()) throw ValidationError("options.grid_distances is empty; list at least one distance");
  for (std::size_t i = 0; i < grid_distances.size(); ++i) {
    requirePositive("options.grid_distances[" + std::to_string(i) + "]", grid_distances[i]);
    requireInRange("options.grid_distances[" + std::to_string(i) + "]", grid_distances[i], 0, 1);
  }
  if (candidates < 1 || candidates > 10000) {
    throw ValidationError("options.candidates is " + std::to_string(candidates) + "; it must lie in [1, 10000]");
  }
  requireInRange("options.epsilon", epsilon, 0.0, 1.0);
  if (region_max_size < 4 || region_max_size > 10000) {
    throw ValidationError("options.region_max_size is " + std::to_string(region_max_size) +
                          "; it must lie in [4, 10000]");
  }
  if (progress_window < 1 || progress_window > 1000) {
    throw ValidationError("options.progress_window is " + std::to_string(progress_window) +
                          "; it must lie in [1, 1000]");
  }
  requireOneOf("options.region_choice", region_choice, {"softmax", "greedy"});
  requireInRange("options.temperature", temperature, 0.001, 100.0);
  requireInRange("options.random_share", random_share, 0.0, 1.0);
  requireInRange("options.progress_confidence", progress_confidence, 0.0, 10.0);
}

// ---- random -----------------------------------------------------------------------------------------------

RandomDesign::RandomDesign(unsigned long seed, DesignOptions options) { initialize(seed, options); }

void RandomDesign::initialize(unsigned long seed, const DesignOptions& options) {
  options.validate();
  options_ = options;
  rng_.seed(seed);
}

ExperimentChoice RandomDesign::next(const DesignContext& context) {
  const auto objects = reachableObjects(context);
  if (context.stream) rng_.seed(*context.stream);
  int refused = 0;
  ExperimentChoice last;
  const auto found = drawFeasible(context, [&] { return last = uniformPush(rng_, objects, options_); }, &refused);
  ExperimentChoice c = found ? *found : last;
  c.rationale = "random" + refusedNote(refused, found.has_value());
  return c;
}

// ---- grid -------------------------------------------------------------------------------------------------

GridDesign::GridDesign(DesignOptions options) { initialize(0, options); }

void GridDesign::initialize(unsigned long /*seed*/, const DesignOptions& options) {
  options.validate();
  options_ = options;
  cursor_ = 0;
  started_ = false;
}

std::size_t GridDesign::cells(std::size_t objects) const {
  return objects * options_.sides.size() * options_.grid_offsets.size() * options_.grid_distances.size();
}

ExperimentChoice GridDesign::next(const DesignContext& context) {
  reachableObjects(context);  // throws when nothing can be pushed: there is then always a reachable cell
  const std::size_t total = cells(context.objects.size());
  if (!started_) cursor_ = context.history_count % total;
  started_ = true;
  std::optional<ExperimentChoice> first;  // the first reachable cell: chosen when the planner refuses every cell
  std::size_t first_cell = 0;
  for (std::size_t k = 0; k < total; ++k) {
    const std::size_t cell = (cursor_ + k) % total;
    const auto& object = context.objects[cell % context.objects.size()];
    if (!object.reachable) continue;
    std::size_t rest = cell / context.objects.size();
    const std::size_t n_dist = options_.grid_distances.size();
    const std::size_t n_off = options_.grid_offsets.size();
    ExperimentChoice c;
    c.object = object.name;
    c.distance = options_.grid_distances[rest % n_dist] * options_.max_distance;
    rest /= n_dist;
    c.side = options_.sides[rest / n_off];
    c.offset = options_.grid_offsets[rest % n_off] * maxPushOffset(object.footprint, c.side);
    c.rationale = "grid cell " + std::to_string(cell + 1) + " of " + std::to_string(total);
    if (!first) {
      first = c;
      first_cell = cell;
    }
    if (context.feasible && !context.feasible(c)) continue;
    if (cell != first_cell) c.rationale += " (cells the push planner would refuse skipped)";
    cursor_ = (cell + 1) % total;
    return c;
  }
  if (!first) throw ValidationError("no grid cell has a reachable object");  // unreachable: reachableObjects checked
  first->rationale += " (the push planner would refuse every cell)";
  cursor_ = (first_cell + 1) % total;
  return *first;
}

// ---- curiosity --------------------------------------------------------------------------------------------

CuriosityDesign::CuriosityDesign(unsigned long seed, DesignOptions options) { initialize(seed, options); }

void CuriosityDesign::initialize(unsigned long seed, const DesignOptions& options) {
  options.validate();
  options_ = options;
  rng_.seed(seed);
  last_exploration_ = false;
}

ExperimentChoice CuriosityDesign::next(const DesignContext& context) {
  const auto objects = reachableObjects(context);
  if (!context.curiosity) {
    throw ValidationError("context.curiosity is not set; the curiosity design needs MOTIVATION's expected "
                          "learning progress (use the random or grid design without it)");
  }
  // Draw on a copy and commit only on success, so an error (a NaN curiosity) changes nothing.
  std::mt19937_64 rng = rng_;
  if (context.stream) rng.seed(*context.stream);
  const bool explore = std::uniform_real_distribution<double>(0.0, 1.0)(rng) < options_.epsilon;
  std::vector<ExperimentChoice> candidates;
  candidates.reserve(options_.candidates);
  int refused = 0;
  bool all_found = true;
  for (std::size_t i = 0; i < options_.candidates; ++i) {
    ExperimentChoice last;
    const auto found = drawFeasible(context, [&] { return last = uniformPush(rng, objects, options_); }, &refused);
    candidates.push_back(found ? *found : last);
    all_found = all_found && found.has_value();
  }

  std::size_t chosen = 0;
  double value = 0;
  if (explore) {
    chosen = std::uniform_int_distribution<std::size_t>(0, candidates.size() - 1)(rng);
    value = context.curiosity(candidates[chosen]);
  } else {
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const double v = context.curiosity(candidates[i]);
      if (std::isnan(v)) {
        throw ValidationError("the curiosity of candidate '" + candidates[i].toString() +
                              "' is NaN; expected learning progress must be a number");
      }
      if (i == 0 || v > value) {  // strict: ties keep the earlier candidate
        chosen = i;
        value = v;
      }
    }
  }
  if (std::isnan(value)) {
    throw ValidationError("the curiosity of candidate '" + candidates[chosen].toString() +
                          "' is NaN; expected learning progress must be a number");
  }
  rng_ = rng;
  last_exploration_ = explore;
  ExperimentChoice c = candidates[chosen];
  std::ostringstream why;
  if (explore) {
    why << "exploration (epsilon " << describeNumber(options_.epsilon) << "), curiosity " << describeNumber(value);
  } else {
    why << "curiosity " << describeNumber(value) << ", best of " << candidates.size() << " candidates";
  }
  why << refusedNote(refused, all_found);
  c.rationale = why.str();
  return c;
}

// ---- factory ----------------------------------------------------------------------------------------------

std::vector<std::string> designNames() {
  return {"curiosity", "random", "grid", "learning_progress", "error_max", "strategic_student", "round_robin",
          "replicate_screening"};
}

std::unique_ptr<ExperimentDesign> makeDesign(const std::string& name, unsigned long seed,
                                             const DesignOptions& options) {
  requireOneOf("design", name, designNames());
  if (name == "curiosity") return std::make_unique<CuriosityDesign>(seed, options);
  if (name == "random") return std::make_unique<RandomDesign>(seed, options);
  if (name == "learning_progress") return std::make_unique<LearningProgressDesign>(seed, options);
  if (name == "error_max") return std::make_unique<ErrorMaxDesign>(seed, options);
  if (name == "strategic_student") return std::make_unique<StrategicStudentDesign>(seed, options);
  if (name == "round_robin") return std::make_unique<RoundRobinDesign>(seed, options);
  if (name == "replicate_screening") return std::make_unique<ReplicateScreeningDesign>(seed, options);
  return std::make_unique<GridDesign>(options);
}

}  // namespace xpersif::core
