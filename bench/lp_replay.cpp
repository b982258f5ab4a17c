// lp_replay: what learning progress saw, step by step, in a finished run (bench/loop.md). ROS-free.
//
//   lp_replay --world FILE --database FILE --run NAME [--region-max-size N (15)] [--window W (10)]
//             [--temperature T (0.1)] [--random-share R (0.2)] [--every K (5)] [--confidence Z (0)]
//             [--per-object 0|1 (0)] [--at-most-error 0|1 (0)]
//
// Rebuilds learning_progress's regions from the run's successful designed experiments and their held-out errors
// (as DESIGNOFEXPERIMENTS does at every choice), every K experiments, and prints: the leaves with their interest,
// whether any interest is positive, and the probability the design's softmax rule (learning_progress.h) gives each
// object at that step. The world file gives the objects' footprints (the offset fractions the regions use).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <map>

#include "xpersif/core/evaluation/evaluation.h"
#include "xpersif/core/planning/learning_progress.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/common/setup.h"
#include "xpersif/core/sim/world_spec.h"

using namespace xpersif::core;

int main(int argc, char** argv) {
  std::string world, database, run_name;
  std::size_t region_max_size = 15, window = 10;
  double temperature = 0.1, random_share = 0.2, confidence = 0.0;
  bool per_object = false, at_most_error = false;
  int every = 5;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--world") world = value;
    else if (key == "--database") database = value;
    else if (key == "--run") run_name = value;
    else if (key == "--region-max-size") region_max_size = std::strtoul(value.c_str(), nullptr, 10);
    else if (key == "--window") window = std::strtoul(value.c_str(), nullptr, 10);
    else if (key == "--temperature") temperature = std::atof(value.c_str());
    else if (key == "--random-share") random_share = std::atof(value.c_str());
    else if (key == "--every") every = std::atoi(value.c_str());
    else if (key == "--confidence") confidence = std::atof(value.c_str());
    else if (key == "--per-object") per_object = value == "1" || value == "true";
    else if (key == "--at-most-error") at_most_error = value == "1" || value == "true";
    else {
      std::cerr << "lp_replay: unknown option " << key << "\n";
      return 2;
    }
  }
  if (world.empty() || database.empty() || run_name.empty() || every < 1) {
    std::cerr << "usage: lp_replay --world FILE --database FILE --run NAME [--region-max-size N] [--window W] "
                 "[--temperature T] [--random-share R] [--every K] [--confidence Z] [--per-object 0|1] [--at-most-error 0|1]\n";
    return 2;
  }
  try {
    PhysicsWorld physics(loadWorldFile(world));
    const SetupCatalogue catalogue = SetupCatalogue::fromScene(physics.scene());
    ExperimentSpace space;
    space.objects = catalogue.names();
    space.sides = pushSides();
    space.min_distance = catalogue.minPushDistance();
    space.max_distance = catalogue.maxPushDistance();
    auto kb = KnowledgeBase::open(database);
    RunInfo run;
    for (const auto& r : kb->runs()) {
      if (r.name == run_name) run = r;
    }
    if (run.id == 0) throw std::runtime_error(database + " has no run called '" + run_name + "'");
    const long designed = designedCount(run.parameters_json);
    std::vector<ExperimentRecord> history;
    for (const auto& r : kb->experiments(run.id, "done")) {
      if ((designed < 0 || r.seq <= designed) && r.surprise) history.push_back(r);
    }
    int non_positive = 0, steps = 0;
    std::map<std::string, double> mean_probability;
    for (std::size_t k = static_cast<std::size_t>(every); k <= history.size(); k += static_cast<std::size_t>(every)) {
      AdaptiveRegions regions(space, Interest::Progress, region_max_size, window, ProgressRules{confidence, at_most_error},
                              per_object ? FirstCut::ByObject : FirstCut::None);
      for (std::size_t i = 0; i < k; ++i) {
        const auto& r = history[i];
        const auto o = std::find(space.objects.begin(), space.objects.end(), r.experiment.object) - space.objects.begin();
        const auto s = std::find(space.sides.begin(), space.sides.end(), r.experiment.side) - space.sides.begin();
        const double limit = maxPushOffset(catalogue.find(r.experiment.object)->footprint, r.experiment.side);
        regions.add({static_cast<std::size_t>(o), static_cast<std::size_t>(s),
                     limit > 0 ? r.experiment.offset / limit : 0.0, r.experiment.distance},
                    *r.surprise);
      }
      std::vector<int> leaves = regions.leaves();
      std::vector<double> interest;
      double largest = 0, top = -INFINITY;
      for (int leaf : leaves) {
        interest.push_back(regions.interest(leaf));
        largest = std::max(largest, std::fabs(interest.back()));
        top = std::max(top, interest.back());
      }
      const double scale = top > 0 ? top : largest;
      std::vector<double> weights;
      double total = 0;
      for (double v : interest) total += weights.emplace_back(scale > 1e-12 ? std::exp((v - top) / (temperature * scale)) : 1.0);
      std::map<std::string, double> probability;
      for (const auto& o : space.objects) probability[o] += random_share / space.objects.size();
      for (std::size_t l = 0; l < leaves.size(); ++l) {
        const Region& r = regions.region(leaves[l]);
        const double in = static_cast<double>(std::count(r.objects.begin(), r.objects.end(), true));
        for (std::size_t o = 0; o < space.objects.size(); ++o) {
          if (r.objects[o]) probability[space.objects[o]] += (1 - random_share) * weights[l] / total / in;
        }
      }
      ++steps;
      if (top <= 0) ++non_positive;
      std::cout << "after " << k << ": " << leaves.size() << " leaves, best interest " << std::setprecision(3) << top
                << (top <= 0 ? " (none positive)" : "") << "; P(object):";
      for (const auto& [o, p] : probability) {
        std::cout << " " << o << " " << std::fixed << std::setprecision(2) << p << std::defaultfloat;
        mean_probability[o] += p;
      }
      std::cout << "\n";
      for (std::size_t l = 0; l < leaves.size(); ++l) {
        std::cout << "    " << std::setw(9) << std::setprecision(3) << interest[l] << "  w " << std::fixed
                  << std::setprecision(2) << weights[l] / total << std::defaultfloat << "  n "
                  << regions.region(leaves[l]).members.size() << "  " << regions.describe(leaves[l]) << "\n";
      }
    }
    std::cout << "steps with no positive interest: " << non_positive << " of " << steps << "; mean P(object):";
    for (const auto& [o, p] : mean_probability) std::cout << " " << o << " " << std::fixed << std::setprecision(2) << p / steps;
    std::cout << "\n";
  } catch (const std::exception& e) {
    std::cerr << "lp_replay: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
