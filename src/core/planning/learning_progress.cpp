/**
 * @file learning_progress.cpp
 * @brief Adaptive regions and the designs by learning progress and by error; see learning_progress.h.
 */
#include "xpersif/core/planning/learning_progress.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <sstream>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

double mean(const std::vector<double>& v, std::size_t from, std::size_t to) {
  if (to <= from) return 0.0;
  double sum = 0;
  for (std::size_t i = from; i < to; ++i) sum += v[i];
  return sum / static_cast<double>(to - from);
}

std::string names(const std::vector<std::string>& all, const std::vector<bool>& allowed) {
  std::string out;
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (allowed[i]) out += (out.empty() ? "" : ",") + all[i];
  }
  return out;
}

}  // namespace

// ---- the regions ------------------------------------------------------------------------------------------

AdaptiveRegions::AdaptiveRegions(ExperimentSpace space, Interest interest, std::size_t region_max_size,
                                 std::size_t window, ProgressRules rules, FirstCut first_cut)
    : space_(std::move(space)),
      interest_(interest),
      region_max_size_(region_max_size),
      window_(window),
      rules_(rules) {
  if (space_.objects.empty()) throw ValidationError("the experiment space has no objects");
  if (space_.sides.empty()) throw ValidationError("the experiment space has no sides");
  requireFinite("space.min_offset", space_.min_offset);
  requireFinite("space.max_offset", space_.max_offset);
  requireFinite("space.min_distance", space_.min_distance);
  requireFinite("space.max_distance", space_.max_distance);
  if (space_.min_offset > space_.max_offset || space_.min_distance > space_.max_distance) {
    throw ValidationError("the experiment space's ranges are empty (a minimum above its maximum)");
  }
  if (region_max_size_ < 4) {
    throw ValidationError("region_max_size is " + std::to_string(region_max_size_) + "; it must be at least 4");
  }
  if (window_ < 1) throw ValidationError("progress_window is 0; it must be at least 1");
  requireInRange("progress_confidence", rules_.confidence, 0.0, 10.0);
  Region root;
  root.objects.assign(space_.objects.size(), true);
  root.sides.assign(space_.sides.size(), true);
  root.offset_lo = space_.min_offset;
  root.offset_hi = space_.max_offset;
  root.distance_lo = space_.min_distance;
  root.distance_hi = space_.max_distance;
  regions_.push_back(root);
  if (first_cut == FirstCut::ByObject) {
    // A chain of binary cuts: {first object} against the rest, then the rest likewise.
    int rest = 0;
    for (std::size_t object = 0; object + 1 < space_.objects.size(); ++object) {
      std::vector<bool> only(space_.objects.size(), false);
      only[object] = true;
      rest = cutRegion(rest, 0, only, 0.0)[1];
    }
  }
}

double AdaptiveRegions::progress(const std::vector<double>& errors, std::size_t window, const ProgressRules& rules) {
  const std::size_t n = errors.size();
  const std::size_t w = std::min(window, n / 2);
  if (w == 0) return 0.0;
  const double older = mean(errors, n - 2 * w, n - w), newer = mean(errors, n - w, n);
  double progress = older - newer;
  if (rules.confidence > 0 && w >= 2) {
    auto variance = [&](std::size_t from, double m) {
      double sum = 0;
      for (std::size_t i = from; i < from + w; ++i) sum += (errors[i] - m) * (errors[i] - m);
      return sum / static_cast<double>(w - 1);
    };
    const double standard_error =
        std::sqrt((variance(n - 2 * w, older) + variance(n - w, newer)) / static_cast<double>(w));
    const double margin = rules.confidence * standard_error;
    progress = progress > 0 ? std::max(0.0, progress - margin) : std::min(0.0, progress + margin);
  }
  return rules.at_most_recent_error ? std::min(progress, newer) : progress;
}

double AdaptiveRegions::recentError(const std::vector<double>& errors, std::size_t window) {
  const std::size_t n = errors.size();
  return mean(errors, n - std::min(window, n), n);
}

double AdaptiveRegions::interestOf(const std::vector<std::size_t>& members) const {
  std::vector<double> e;
  e.reserve(members.size());
  for (std::size_t i : members) e.push_back(errors_[i]);
  return interest_ == Interest::Progress ? progress(e, window_, rules_) : recentError(e, window_);
}

double AdaptiveRegions::interest(int region) const { return interestOf(this->region(region).members); }

std::vector<double> AdaptiveRegions::errors(int region) const {
  std::vector<double> e;
  for (std::size_t i : this->region(region).members) e.push_back(errors_[i]);
  return e;
}

std::vector<int> AdaptiveRegions::leaves() const {
  std::vector<int> out;
  for (std::size_t i = 0; i < regions_.size(); ++i) {
    if (regions_[i].leaf()) out.push_back(static_cast<int>(i));
  }
  return out;
}

bool AdaptiveRegions::contains(const Region& r, const SpacePoint& p) const {
  // Half-open intervals, closed at the space's top, so that children partition their parent.
  auto in = [](double v, double lo, double hi, double top) { return v >= lo && (v < hi || (hi >= top && v <= hi)); };
  return r.objects[p.object] && r.sides[p.side] && in(p.offset, r.offset_lo, r.offset_hi, space_.max_offset) &&
         in(p.distance, r.distance_lo, r.distance_hi, space_.max_distance);
}

int AdaptiveRegions::leafOf(const SpacePoint& point) const {
  int at = 0;
  while (!regions_[static_cast<std::size_t>(at)].leaf()) {
    const Region& r = regions_[static_cast<std::size_t>(at)];
    at = contains(regions_[static_cast<std::size_t>(r.children[0])], point) ? r.children[0] : r.children[1];
  }
  return at;
}

void AdaptiveRegions::add(const SpacePoint& point, double error) {
  if (point.object >= space_.objects.size() || point.side >= space_.sides.size()) {
    throw ValidationError("the experiment's object or side is not in the experiment space");
  }
  requireFinite("error", error);
  if (error < 0) throw ValidationError("error is " + describeNumber(error) + "; a prediction error is >= 0");
  requireFinite("offset", point.offset);
  requireFinite("distance", point.distance);
  SpacePoint p = point;
  p.offset = std::clamp(p.offset, space_.min_offset, space_.max_offset);
  p.distance = std::clamp(p.distance, space_.min_distance, space_.max_distance);
  points_.push_back(p);
  errors_.push_back(error);
  const int leaf = leafOf(p);
  regions_[static_cast<std::size_t>(leaf)].members.push_back(points_.size() - 1);
  if (regions_[static_cast<std::size_t>(leaf)].members.size() > region_max_size_) split(leaf);
}

void AdaptiveRegions::split(int id) {
  const std::vector<std::size_t> members = regions_[static_cast<std::size_t>(id)].members;  // a copy: regions_ grows
  const Region parent = regions_[static_cast<std::size_t>(id)];
  const std::size_t min_child = std::max<std::size_t>(2, region_max_size_ / 4);
  struct Cut {
    double quality = -1;
    int dim = -1;              // 0 object, 1 side, 2 offset, 3 distance
    std::vector<bool> first;   // categories of the first child
    double threshold = 0;      // continuous: the first child is below it
  } best;
  auto consider = [&](int dim, const std::vector<std::size_t>& a, const std::vector<std::size_t>& b,
                      const std::vector<bool>& first, double threshold) {
    if (a.size() < min_child || b.size() < min_child) return;
    const double q = static_cast<double>(a.size()) * static_cast<double>(b.size()) *
                     std::fabs(interestOf(a) - interestOf(b));
    if (q > best.quality) best = Cut{q, dim, first, threshold};  // strict: ties keep the earlier cut
  };
  // Categories: ordered by their own interest, cut between neighbours (as CART does for categorical inputs).
  for (int dim = 0; dim < 2; ++dim) {
    const std::vector<bool>& allowed = dim == 0 ? parent.objects : parent.sides;
    std::map<std::size_t, std::vector<std::size_t>> by;
    for (std::size_t m : members) by[dim == 0 ? points_[m].object : points_[m].side].push_back(m);
    if (by.size() < 2) continue;
    std::vector<std::pair<double, std::size_t>> order;
    for (const auto& [category, its] : by) order.emplace_back(interestOf(its), category);
    std::stable_sort(order.begin(), order.end(),
                     [](const auto& x, const auto& y) { return x.first < y.first; });
    std::vector<bool> first(allowed.size(), false);
    for (std::size_t k = 0; k + 1 < order.size(); ++k) {
      first[order[k].second] = true;
      std::vector<std::size_t> a, b;
      for (std::size_t m : members) {
        (first[dim == 0 ? points_[m].object : points_[m].side] ? a : b).push_back(m);
      }
      consider(dim, a, b, first, 0);
    }
  }
  // Offset and distance: thresholds halfway between neighbouring values.
  for (int dim = 2; dim < 4; ++dim) {
    auto value = [&](std::size_t m) { return dim == 2 ? points_[m].offset : points_[m].distance; };
    std::vector<std::size_t> sorted = members;
    std::stable_sort(sorted.begin(), sorted.end(), [&](std::size_t x, std::size_t y) { return value(x) < value(y); });
    for (std::size_t k = 1; k < sorted.size(); ++k) {
      if (!(value(sorted[k - 1]) < value(sorted[k]))) continue;
      const double threshold = 0.5 * (value(sorted[k - 1]) + value(sorted[k]));
      std::vector<std::size_t> a, b;
      for (std::size_t m : members) (value(m) < threshold ? a : b).push_back(m);  // chronological in each
      consider(dim, a, b, {}, threshold);
    }
  }
  if (best.dim < 0) return;  // nothing leaves both sides a quarter: keep growing
  cutRegion(id, best.dim, best.first, best.threshold);
}

std::array<int, 2> AdaptiveRegions::cutRegion(int id, int dim, const std::vector<bool>& first, double threshold) {
  const Region parent = regions_[static_cast<std::size_t>(id)];  // a copy: regions_ grows
  Region lower = parent, upper = parent;
  lower.members.clear();
  upper.members.clear();
  lower.parent = upper.parent = id;
  lower.children[0] = lower.children[1] = upper.children[0] = upper.children[1] = -1;
  if (dim < 2) {
    const std::vector<std::string>& all = dim == 0 ? space_.objects : space_.sides;
    std::vector<bool>& lo = dim == 0 ? lower.objects : lower.sides;
    std::vector<bool>& hi = dim == 0 ? upper.objects : upper.sides;
    for (std::size_t c = 0; c < all.size(); ++c) {
      lo[c] = lo[c] && first[c];
      hi[c] = hi[c] && !first[c];
    }
    const std::string what = dim == 0 ? "object" : "side";
    lower.cut = what + " in {" + names(all, lo) + "}";
    upper.cut = what + " in {" + names(all, hi) + "}";
  } else {
    const std::string what = dim == 2 ? "offset" : "distance";
    (dim == 2 ? lower.offset_hi : lower.distance_hi) = threshold;
    (dim == 2 ? upper.offset_lo : upper.distance_lo) = threshold;
    lower.cut = what + " < " + describeNumber(threshold);
    upper.cut = what + " >= " + describeNumber(threshold);
  }
  for (std::size_t m : parent.members) (contains(lower, points_[m]) ? lower.members : upper.members).push_back(m);
  const int a = static_cast<int>(regions_.size());
  regions_.push_back(std::move(lower));
  regions_.push_back(std::move(upper));
  regions_[static_cast<std::size_t>(id)].children[0] = a;
  regions_[static_cast<std::size_t>(id)].children[1] = a + 1;
  return {a, a + 1};
}

std::string AdaptiveRegions::describe(int id) const {
  const Region& r = region(id);
  std::ostringstream out;
  out << names(space_.objects, r.objects) << "; " << names(space_.sides, r.sides) << "; offset ["
      << describeNumber(r.offset_lo) << ", " << describeNumber(r.offset_hi) << "]; distance ["
      << describeNumber(r.distance_lo) << ", " << describeNumber(r.distance_hi) << "] m";
  return out.str();
}

// ---- the designs ------------------------------------------------------------------------------------------

void RegionInterestDesign::initialize(unsigned long seed, const DesignOptions& options) {
  options.validate();
  options_ = options;
  rng_.seed(seed);
  regions_.reset();
}

namespace {

// The design's space over the context's objects, with where each object and side stands in it.
struct DesignSpace {
  ExperimentSpace space;
  std::map<std::string, std::size_t> object_index, side_index;
  std::vector<bool> reachable;  // by object index
};

DesignSpace designSpace(const DesignContext& context, const DesignOptions& options) {
  if (context.objects.empty()) {
    throw ValidationError("context.objects is empty; there is no object to design an experiment for");
  }
  DesignSpace d;
  for (std::size_t i = 0; i < context.objects.size(); ++i) {
    const auto& o = context.objects[i];
    requireIdentifier("context.objects[" + std::to_string(i) + "].name", o.name);
    if (!d.object_index.emplace(o.name, i).second) {
      throw ValidationError("context.objects[" + std::to_string(i) + "].name '" + o.name +
                            "' is listed twice; object names must be unique");
    }
    throwIfInvalid(o.footprint.check("context.objects[" + std::to_string(i) + "].footprint"));
    d.space.objects.push_back(o.name);
    d.reachable.push_back(o.reachable);
  }
  if (std::none_of(d.reachable.begin(), d.reachable.end(), [](bool r) { return r; })) {
    std::string all;
    for (const auto& o : context.objects) all += (all.empty() ? "'" : ", '") + o.name + "'";
    throw ValidationError("none of the objects (" + all + ") is reachable; there is nothing to push now");
  }
  d.space.sides = options.sides;
  for (std::size_t i = 0; i < d.space.sides.size(); ++i) d.side_index[d.space.sides[i]] = i;
  d.space.min_offset = options.min_offset;
  d.space.max_offset = options.max_offset;
  d.space.min_distance = options.min_distance;
  d.space.max_distance = options.max_distance;
  return d;
}

// The tree from the history alone: the same history gives the same regions. Experiments outside the design's
// space (other objects or sides) are left out.
std::unique_ptr<AdaptiveRegions> regionsOf(const DesignSpace& d, const DesignContext& context, Interest interest,
                                           const DesignOptions& options) {
  auto regions = std::make_unique<AdaptiveRegions>(
      d.space, interest, options.region_max_size, options.progress_window,
      ProgressRules{options.progress_confidence, options.progress_at_most_error},
      options.regions_per_object ? FirstCut::ByObject : FirstCut::None);
  for (std::size_t i = 0; i < context.history.size(); ++i) {
    const PastExperiment& h = context.history[i];
    const std::string at = "context.history[" + std::to_string(i) + "]";
    if (!std::isfinite(h.error) || h.error < 0) {
      throw ValidationError(at + ".error is " + describeNumber(h.error) + "; a prediction error is a number >= 0");
    }
    requireFinite(at + ".offset", h.offset);
    requireFinite(at + ".distance", h.distance);
    const auto o = d.object_index.find(h.object);
    const auto s = d.side_index.find(h.side);
    if (o == d.object_index.end() || s == d.side_index.end()) continue;
    const double limit = maxPushOffset(context.objects[o->second].footprint, h.side);
    regions->add({o->second, s->second, limit > 0 ? h.offset / limit : 0.0, h.distance}, h.error);
  }
  return regions;
}

// One next()'s draws, all from one generator (committed by the caller on success), in a fixed order.
struct Drawer {
  const DesignSpace& d;
  const DesignContext& context;
  const DesignOptions& options;
  std::mt19937_64& rng;
  std::uniform_real_distribution<double> unit{0.0, 1.0};
  int refused = 0;  // draws context.feasible rejected
  bool feasible = true;

  std::size_t pick(const std::vector<std::size_t>& from) {
    return from[std::uniform_int_distribution<std::size_t>(0, from.size() - 1)(rng)];
  }

  // A push drawn uniformly in region @p r, on one of its reachable objects.
  ExperimentChoice point(const Region& r) {
    std::vector<std::size_t> objects, sides;
    for (std::size_t i = 0; i < d.space.objects.size(); ++i) {
      if (r.objects[i] && d.reachable[i]) objects.push_back(i);
    }
    for (std::size_t i = 0; i < d.space.sides.size(); ++i) {
      if (r.sides[i]) sides.push_back(i);
    }
    ExperimentChoice c;
    const std::size_t o = pick(objects);
    c.object = d.space.objects[o];
    c.side = d.space.sides[pick(sides)];
    const double fraction = std::uniform_real_distribution<double>(r.offset_lo, r.offset_hi)(rng);
    c.offset = fraction * maxPushOffset(context.objects[o].footprint, c.side);
    c.distance = std::uniform_real_distribution<double>(r.distance_lo, r.distance_hi)(rng);
    return c;
  }

  ExperimentChoice atRandom(const AdaptiveRegions& regions) {
    ExperimentChoice last;
    const auto found = drawFeasible(context, [&] { return last = point(regions.region(0)); }, &refused);
    feasible = found.has_value();
    ExperimentChoice choice = found ? *found : last;
    choice.rationale = "random exploration (random_share " + describeNumber(options.random_share) + ")";
    return choice;
  }

  // One of the @p open leaves by options.region_choice: greedy (epsilon-greedy) or a softmax on @p interest.
  std::size_t chooseLeaf(const std::vector<std::size_t>& open, const std::vector<double>& interest) {
    if (options.region_choice == "greedy") {
      if (unit(rng) < options.epsilon) return pick(open);
      return *std::max_element(open.begin(), open.end(),
                               [&](std::size_t a, std::size_t b) { return interest[a] < interest[b]; });
    }
    // Temperature relative to the best interest (to the largest |interest| when none is positive), so that it
    // does not depend on the errors' unit and a noisy region's large fall of progress does not flatten the rest.
    double largest = 0, top = interest[open.front()];
    for (std::size_t i : open) {
      largest = std::max(largest, std::fabs(interest[i]));
      top = std::max(top, interest[i]);
    }
    const double scale = top > 0 ? top : largest;
    std::vector<double> weights;
    for (std::size_t i : open) {
      weights.push_back(scale > 1e-12 ? std::exp((interest[i] - top) / (options.temperature * scale)) : 1.0);
    }
    double r = unit(rng) * std::accumulate(weights.begin(), weights.end(), 0.0);
    for (std::size_t k = 0; k < weights.size(); ++k) {
      if (r < weights[k]) return open[k];
      r -= weights[k];
    }
    return open.back();
  }

  ExperimentChoice byInterest(const AdaptiveRegions& regions, const std::string& what) {
    std::vector<int> leaves;
    std::vector<double> interest;
    for (int leaf : regions.leaves()) {
      const Region& r = regions.region(leaf);
      bool any = false;
      for (std::size_t i = 0; i < r.objects.size(); ++i) any = any || (r.objects[i] && d.reachable[i]);
      if (!any) continue;
      leaves.push_back(leaf);
      interest.push_back(regions.interest(leaf));
    }
    // A leaf where no push can be done from where the objects are now (an object against a wall, pushed
    // towards it) is left out and the choice made again among the rest.
    std::vector<std::size_t> open(leaves.size());
    std::iota(open.begin(), open.end(), 0);
    std::size_t chosen = chooseLeaf(open, interest);
    const std::size_t first_chosen = chosen;
    std::optional<ExperimentChoice> found;
    while (!(found = drawFeasible(context, [&] { return point(regions.region(leaves[chosen])); }, &refused))) {
      open.erase(std::find(open.begin(), open.end(), chosen));
      if (open.empty()) break;
      chosen = chooseLeaf(open, interest);
    }
    feasible = found.has_value();
    if (!found) chosen = first_chosen;  // no leaf has a feasible push: the first choice, to be refused downstream
    ExperimentChoice choice = found ? *found : point(regions.region(leaves[chosen]));
    std::ostringstream why;
    why << what << " " << describeNumber(interest[chosen]) << " in region " << regions.describe(leaves[chosen])
        << " (" << regions.region(leaves[chosen]).members.size() << " experiments; " << leaves.size()
        << " regions, " << options.region_choice << ")";
    choice.rationale = why.str();
    return choice;
  }
};

}  // namespace

ExperimentChoice RegionInterestDesign::next(const DesignContext& context) {
  const DesignSpace d = designSpace(context, options_);
  std::unique_ptr<AdaptiveRegions> regions = regionsOf(d, context, interest_, options_);
  std::mt19937_64 rng = rng_;  // commit only on success
  if (context.stream) rng.seed(*context.stream);
  Drawer draw{d, context, options_, rng};
  const std::string what = interest_ == Interest::Progress ? "learning progress" : "recent error";
  ExperimentChoice choice =
      draw.unit(rng) < options_.random_share ? draw.atRandom(*regions) : draw.byInterest(*regions, what);
  choice.rationale += refusedNote(draw.refused, draw.feasible);
  rng_ = rng;
  regions_ = std::move(regions);
  return choice;
}

}  // namespace xpersif::core
