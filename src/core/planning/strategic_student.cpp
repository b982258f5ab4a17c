#include "xpersif/core/planning/strategic_student.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <tuple>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

constexpr double kErrorFloor = 0.001;  // m: errors near 0 (an object that never moves) stay finite in the log
constexpr std::size_t kRecentErrors = 5;  // the object's last errors, whose mean is the level progress falls from

/// The reachable object at the round-robin turn @p turn: the turn-th of the context's objects, or the next
/// reachable one after it.
const DesignObject& roundRobinObject(const DesignContext& context, std::size_t turn) {
  const std::size_t n = context.objects.size();
  for (std::size_t k = 0; k < n; ++k) {
    const auto& object = context.objects[(turn + k) % n];
    if (object.reachable) return object;
  }
  throw ValidationError("none of the objects is reachable; there is nothing to push now");
}

/// A feasible push on @p object, else on any reachable object, else the last draw (which the planner will refuse).
ExperimentChoice pushOn(const DesignObject& object, const std::vector<DesignObject>& reachable,
                        const DesignContext& context, const DesignOptions& options, std::mt19937_64& rng,
                        const std::string& why) {
  int refused = 0;
  ExperimentChoice last;
  auto found = drawFeasible(context, [&] { return last = uniformPush(rng, {object}, options); }, &refused);
  if (!found) found = drawFeasible(context, [&] { return last = uniformPush(rng, reachable, options); }, &refused);
  ExperimentChoice c = found ? *found : last;
  c.rationale = why + (found && c.object != object.name ? " (no feasible push on " + object.name + ")" : "") +
                refusedNote(refused, found.has_value());
  return c;
}

}  // namespace

ObjectCurveFit fitObjectCurve(const std::vector<double>& errors) {
  ObjectCurveFit fit;
  fit.pushes = errors.size();
  const std::size_t n = errors.size();
  if (n < 3) return fit;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  std::vector<double> xs, ys;
  for (std::size_t i = 0; i < n; ++i) {
    requireFinite("errors[" + std::to_string(i) + "]", errors[i]);
    const double x = std::log(static_cast<double>(i + 1)), y = std::log(std::max(errors[i], 0.0) + kErrorFloor);
    xs.push_back(x);
    ys.push_back(y);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  const double mean_x = sx / n, sxx_c = sxx - n * mean_x * mean_x;
  if (sxx_c <= 0) return fit;
  fit.b = (sxy - n * mean_x * (sy / n)) / sxx_c;
  fit.a = sy / n - fit.b * mean_x;
  double residuals = 0;
  for (std::size_t i = 0; i < n; ++i) residuals += std::pow(ys[i] - fit.a - fit.b * xs[i], 2);
  fit.b_se = std::sqrt(residuals / (n - 2) / sxx_c);
  // The curve gives the rate (a power law falls by the factor ((n + 1) / n)^b per push); the level it falls from is
  // the object's recent errors, not the fit's: a power law through a few large first errors and then zeros (an
  // object that never moves, once the model knows it) would promise a long tail of progress that is not there.
  const double slope = fit.b + fit.b_se;
  const std::size_t recent = std::min<std::size_t>(n, kRecentErrors);
  double level = 0;
  for (std::size_t i = n - recent; i < n; ++i) level += std::max(errors[i], 0.0) / recent;
  // Below the floor the model predicts the object to within the resolution the log keeps: nothing is left to learn
  // there, however steep the fall that led to it (else its tiny progress takes every share when no other progresses).
  if (slope < 0 && level >= kErrorFloor) fit.progress = level * (1 - std::pow((n + 1.0) / n, slope));
  return fit;
}

// ---- the strategic student ------------------------------------------------------------------------------

void ObjectLevelDesign::initialize(unsigned long seed, const DesignOptions& options) {
  options.validate();
  options_ = options;
  rng_.seed(seed);
}

std::map<std::string, double> StrategicStudentDesign::probabilities(const DesignContext& context) const {
  const auto reachable = reachableObjects(context);
  std::map<std::string, std::vector<double>> errors;
  for (const auto& past : context.history) errors[past.object].push_back(past.error);
  std::map<std::string, double> progress;
  double total = 0;
  for (const auto& object : reachable) total += progress[object.name] = fitObjectCurve(errors[object.name]).progress;
  std::map<std::string, double> p;
  const double k = static_cast<double>(reachable.size()), floor = options_.random_share;
  for (const auto& object : reachable) {
    p[object.name] = total > 0 ? floor / k + (1 - floor) * progress[object.name] / total : 1 / k;
  }
  return p;
}

ExperimentChoice StrategicStudentDesign::next(const DesignContext& context) {
  const auto reachable = reachableObjects(context);
  if (context.stream) rng_.seed(*context.stream);
  if (context.history_count < kWarmupPushes * context.objects.size()) {
    const auto& object = roundRobinObject(context, context.history_count);
    return pushOn(object, reachable, context, options_, rng_,
                  "strategic student: round robin, " + std::to_string(context.history_count + 1) + " of " +
                      std::to_string(kWarmupPushes * context.objects.size()));
  }
  const auto p = probabilities(context);
  std::vector<double> weights;
  for (const auto& object : reachable) weights.push_back(p.at(object.name));
  const std::size_t i = std::discrete_distribution<std::size_t>(weights.begin(), weights.end())(rng_);
  std::ostringstream why;
  why << "strategic student: " << reachable[i].name << " with probability " << std::setprecision(2)
      << p.at(reachable[i].name);
  return pushOn(reachable[i], reachable, context, options_, rng_, why.str());
}

// ---- replicate screening ----------------------------------------------------------------------------------

namespace {

constexpr double kReplicateOffset = 0.003;    // m: pushes this close in offset and
constexpr double kReplicateDistance = 0.006;  // in distance (same side) are the same design point
constexpr double kMinMotion = 0.005;          // m: the spread of smaller motions is relative to this
constexpr std::size_t kKnownErrors = 3;       // an object whose last errors average below kErrorFloor is known

std::map<std::string, std::vector<PastExperiment>> pushesByObject(const std::vector<PastExperiment>& history) {
  std::map<std::string, std::vector<PastExperiment>> pushes;
  for (const auto& past : history) pushes[past.object].push_back(past);
  return pushes;
}

/// Whether the model can still learn @p pushes' object: it answers the same push alike, and is not known yet.
bool learnable(const std::vector<PastExperiment>& pushes) {
  const ReplicateSpread replicates = replicateSpread(pushes);
  if (replicates.pairs > 0 && replicates.spread > kNoisySpread) return false;
  if (pushes.size() < 2) return true;
  // An object none of whose pushes moved it is foretold by "it stays": known, whatever the model's first errors say
  // (a model that has not yet learned it predicts it moving as others do, and took five more pushes to say so).
  // A push that missed a light object is undone by its next push (at the floor) that moves it.
  if (std::all_of(pushes.begin(), pushes.end(),
                  [](const PastExperiment& p) { return std::hypot(p.moved_x, p.moved_y) < kErrorFloor; })) {
    return false;
  }
  const std::size_t recent = std::min(pushes.size(), kKnownErrors);
  double level = 0;
  for (std::size_t i = pushes.size() - recent; i < pushes.size(); ++i) level += pushes[i].error / recent;
  return level >= kErrorFloor;
}

}  // namespace

std::size_t replicatePairsWanted(std::size_t object_pushes, std::size_t all_pushes, std::size_t objects) {
  // Beyond its even share: object_pushes - all_pushes / objects, in whole numbers.
  const std::size_t scaled = object_pushes * objects, even = all_pushes;
  return kReplicatePairs + (scaled > even ? (scaled - even) / (objects * kReverifyEvery) : 0);
}

ReplicateSpread replicateSpread(const std::vector<PastExperiment>& pushes) {
  // By side and offset, so that each push is compared only with the few within kReplicateOffset of it: a run of
  // thousands of pushes per object stays cheap at every choice (all pairs would be quadratic).
  std::vector<const PastExperiment*> sorted;
  for (const auto& push : pushes) {
    requireFinite("moved_x", push.moved_x);
    requireFinite("moved_y", push.moved_y);
    sorted.push_back(&push);
  }
  std::sort(sorted.begin(), sorted.end(), [](const PastExperiment* a, const PastExperiment* b) {
    return std::tie(a->side, a->offset) < std::tie(b->side, b->offset);
  });
  std::vector<double> spreads;
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    const PastExperiment& a = *sorted[i];
    for (std::size_t j = i + 1;
         j < sorted.size() && sorted[j]->side == a.side && sorted[j]->offset - a.offset <= kReplicateOffset; ++j) {
      const PastExperiment& b = *sorted[j];
      if (std::fabs(a.distance - b.distance) > kReplicateDistance) continue;
      const double mean_motion = (std::hypot(a.moved_x, a.moved_y) + std::hypot(b.moved_x, b.moved_y)) / 2;
      spreads.push_back(std::hypot(a.moved_x - b.moved_x, a.moved_y - b.moved_y) / std::max(mean_motion, kMinMotion));
    }
  }
  ReplicateSpread result;
  result.pairs = spreads.size();
  if (spreads.empty()) return result;
  std::sort(spreads.begin(), spreads.end());
  const std::size_t m = spreads.size() / 2;
  result.spread = spreads.size() % 2 ? spreads[m] : (spreads[m - 1] + spreads[m]) / 2;
  return result;
}

std::map<std::string, double> ReplicateScreeningDesign::probabilities(const DesignContext& context) const {
  const auto reachable = reachableObjects(context);
  const auto pushes = pushesByObject(context.history);
  std::map<std::string, bool> learns;
  double count = 0;
  for (const auto& object : reachable) {
    const auto found = pushes.find(object.name);
    count += learns[object.name] = found == pushes.end() || learnable(found->second);
  }
  std::map<std::string, double> p;
  const double k = static_cast<double>(reachable.size()), floor = options_.random_share;
  for (const auto& object : reachable) {
    p[object.name] = count > 0 ? floor / k + (1 - floor) * (learns[object.name] ? 1 / count : 0) : 1 / k;
  }
  return p;
}

ExperimentChoice ReplicateScreeningDesign::next(const DesignContext& context) {
  const auto reachable = reachableObjects(context);
  if (context.stream) rng_.seed(*context.stream);
  const std::size_t warmup = 2 * context.objects.size();
  const DesignObject* object = nullptr;
  std::string why;
  if (context.history_count < warmup) {
    object = &roundRobinObject(context, context.history_count);
    why = "replicate screening: round robin, " + std::to_string(context.history_count + 1) + " of " +
          std::to_string(warmup);
  } else {
    const auto p = probabilities(context);
    std::vector<double> weights;
    for (const auto& o : reachable) weights.push_back(p.at(o.name));
    object = &reachable[std::discrete_distribution<std::size_t>(weights.begin(), weights.end())(rng_)];
    std::ostringstream chosen;
    chosen << "replicate screening: " << object->name << " with probability " << std::setprecision(2)
           << p.at(object->name);
    why = chosen.str();
  }
  // Until the object has its replicated pairs, its last push again: how alike it answers is what is learnable of it.
  const auto pushes = pushesByObject(context.history);
  const auto found = pushes.find(object->name);
  if (found != pushes.end() &&
      replicateSpread(found->second).pairs < replicatePairsWanted(found->second.size(), context.history.size(),
                                                                   context.objects.size())) {
    const PastExperiment& last = found->second.back();
    ExperimentChoice again{last.object, last.side, last.offset, last.distance, ""};
    if (!context.feasible || context.feasible(again)) {
      again.rationale = why + "; its last push again (a replicate)";
      return again;
    }
    why += " (its last push again is not feasible from here)";
  }
  return pushOn(*object, reachable, context, options_, rng_, why);
}

// ---- round robin ----------------------------------------------------------------------------------------

ExperimentChoice RoundRobinDesign::next(const DesignContext& context) {
  const auto reachable = reachableObjects(context);
  if (context.stream) rng_.seed(*context.stream);
  const auto& object = roundRobinObject(context, context.history_count);
  return pushOn(object, reachable, context, options_, rng_,
                "round robin: turn " + std::to_string(context.history_count + 1));
}

}  // namespace xpersif::core
