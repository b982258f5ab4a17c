// allocation_bench: how much a design could gain at best, by choosing only which object to push (bench/loop.md,
// "What a perfect allocator would gain"). ROS-free.
//
//   allocation_bench --evaluation-database FILE --pool DB [--pool DB ...] [--budget N] [--repeats R] [--seed S]
//                    [--every K] [--learner shared|per_object]
//
// The pool is every successful designed experiment of every run of the pool's knowledge bases (a study's random
// cells, say), grouped by object. A strategy draws a training sequence of N pushes from it, one at a time: it picks an
// object, then a push of that object not drawn yet, at random. The sequence's learning curve on the study's held-out
// evaluation set is computed with MACHINELEARNING's learner exactly as the study does (core::learningCurve). Strategies:
//   random          each object equally likely: what random design does;
//   evaluated       only the evaluation set's objects (the study leaves the unlearnable ones out of it), each
//                   equally likely: an allocator that knows which objects are unlearnable;
//   evaluated_capped  as evaluated, but an object the pool never saw move (the trivial one) gets at most 3 pushes
//                   (PushLearner::kMinTrainingSamples, what a per-object forest needs before it speaks for an
//                   object): an allocator that also knows, after three pushes, which object is trivial.
// Printed per strategy: the mean curve, and how many experiments each repeat needs to reach random's mean final
// error (median over repeats, a repeat that never does counting as beyond the budget, and how many never do). An object's pushes run out when the pool has fewer than the
// strategy wants: it then draws among the objects that have some left.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <map>
#include <random>
#include <set>

#include "xpersif/core/evaluation/evaluation.h"
#include "xpersif/core/learning/push_learner.h"

using namespace xpersif::core;

namespace {

struct Pool {
  std::map<std::string, std::vector<PushSample>> by_object;
  std::set<std::string> never_moved;  // every pooled push left it within 1 mm and 0.01 rad
};

Pool loadPool(const std::vector<std::string>& databases) {
  Pool pool;
  for (const auto& database : databases) {
    for (const auto& s : designedSamples(database)) pool.by_object[s.input.experiment.object].push_back(s);
  }
  for (const auto& [object, samples] : pool.by_object) {
    const bool moved = std::any_of(samples.begin(), samples.end(), [](const PushSample& s) {
      return std::hypot(s.outcome.dx, s.outcome.dy) > 1e-3 || std::abs(s.outcome.dyaw) > 0.01;
    });
    if (!moved) pool.never_moved.insert(object);
  }
  return pool;
}

/// One training sequence of up to @p budget pushes: objects drawn among @p allowed (capped ones at most cap times).
std::vector<PushSample> drawSequence(const Pool& pool, const std::vector<std::string>& allowed,
                                     const std::set<std::string>& capped, int cap, int budget, std::mt19937_64& rng) {
  std::map<std::string, std::vector<PushSample>> left;
  for (const auto& object : allowed) {
    left[object] = pool.by_object.at(object);
    std::shuffle(left[object].begin(), left[object].end(), rng);
  }
  std::map<std::string, int> taken;
  std::vector<PushSample> sequence;
  while (static_cast<int>(sequence.size()) < budget) {
    std::vector<std::string> open;
    for (const auto& object : allowed) {
      if (!left[object].empty() && !(capped.count(object) && taken[object] >= cap)) open.push_back(object);
    }
    if (open.empty()) break;
    const std::string object = open[std::uniform_int_distribution<std::size_t>(0, open.size() - 1)(rng)];
    sequence.push_back(left[object].back());
    left[object].pop_back();
    ++taken[object];
  }
  return sequence;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? NAN : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

}  // namespace

int main(int argc, char** argv) {
  std::string evaluation_database, learner = "shared";
  std::vector<std::string> pool_databases;
  int budget = 100, repeats = 20, every = 10;
  std::uint64_t seed = 1;
  for (int i = 1; i < argc; i += 2) {
    const std::string key = argv[i];
    if (i + 1 >= argc) {
      std::cerr << "allocation_bench: " << key << " needs a value\n";
      return 2;
    }
    const std::string value = argv[i + 1];
    if (key == "--evaluation-database") evaluation_database = value;
    else if (key == "--pool") pool_databases.push_back(value);
    else if (key == "--budget") budget = std::atoi(value.c_str());
    else if (key == "--repeats") repeats = std::atoi(value.c_str());
    else if (key == "--seed") seed = std::strtoull(value.c_str(), nullptr, 10);
    else if (key == "--every") every = std::atoi(value.c_str());
    else if (key == "--learner") learner = value;
    else {
      std::cerr << "allocation_bench: unknown option " << key << "\n";
      return 2;
    }
  }
  if (evaluation_database.empty() || pool_databases.empty() || budget < 1 || repeats < 1 || every < 1 ||
      (learner != "shared" && learner != "per_object")) {
    std::cerr << "usage: allocation_bench --evaluation-database FILE --pool DB [--pool DB ...] [--budget N >= 1] "
                 "[--repeats R >= 1] [--seed S] [--every K >= 1] [--learner shared|per_object]\n";
    return 2;
  }
  try {
    const EvaluationSet evaluation_set = loadEvaluationSet(evaluation_database);
    const std::vector<std::string>& identities = evaluation_set.identities;
    const std::vector<PushSample>& evaluation = evaluation_set.samples;
    std::set<std::string> evaluated;
    for (const auto& s : evaluation) evaluated.insert(s.input.experiment.object);

    const Pool pool = loadPool(pool_databases);
    std::vector<std::string> all, learnable;
    for (const auto& [object, samples] : pool.by_object) {
      all.push_back(object);
      if (evaluated.count(object)) learnable.push_back(object);
    }
    std::cout << "pool:";
    for (const auto& [object, samples] : pool.by_object) {
      std::cout << " " << object << " " << samples.size() << (evaluated.count(object) ? "" : " (not evaluated)")
                << (pool.never_moved.count(object) ? " (never moved)" : "");
    }
    std::cout << "; evaluation set " << evaluation.size() << " pushes; learner " << learner << "\n";

    struct Strategy {
      std::string name;
      std::vector<std::string> allowed;
      std::set<std::string> capped;
    };
    const std::vector<Strategy> strategies{
        {"random", all, {}}, {"evaluated", learnable, {}}, {"evaluated_capped", learnable, pool.never_moved}};
    std::vector<int> checkpoints;
    for (int k = 0; k <= budget; k += every) checkpoints.push_back(k);
    if (checkpoints.back() != budget) checkpoints.push_back(budget);
    const LearnerScope scope = learner == "per_object" ? LearnerScope::PerObject : LearnerScope::Shared;

    std::map<std::string, std::vector<LearningCurve>> curves;
    for (const auto& strategy : strategies) {
      for (int r = 0; r < repeats; ++r) {
        // The same repeat index draws from the same stream in every strategy (common random numbers).
        std::mt19937_64 rng(seed * 1000003ULL + static_cast<std::uint64_t>(r));
        const auto sequence =
            drawSequence(pool, strategy.allowed, strategy.capped, PushLearner::kMinTrainingSamples, budget, rng);
        curves[strategy.name].push_back(
            learningCurve(strategy.name, sequence, evaluation, loopLearnerConfig(identities), checkpoints, scope));
      }
    }
    auto meanAt = [&](const std::vector<LearningCurve>& cs, std::size_t i) {
      double sum = 0;
      int n = 0;
      for (const auto& c : cs) {
        if (i < c.error.size()) sum += c.error[i], ++n;
      }
      return n ? sum / n : NAN;
    };
    const auto& random_curves = curves["random"];
    const double target = meanAt(random_curves, checkpoints.size() - 1);
    std::cout << std::fixed << std::setprecision(4) << "k";
    for (const auto& s : strategies) std::cout << " " << s.name;
    std::cout << "\n";
    for (std::size_t i = 0; i < checkpoints.size(); ++i) {
      std::cout << checkpoints[i];
      for (const auto& s : strategies) std::cout << " " << meanAt(curves[s.name], i);
      std::cout << "\n";
    }
    std::cout << "random's mean final error " << target << " m after " << budget << " experiments\n";
    for (const auto& s : strategies) {
      std::vector<double> reach;
      int never = 0;
      for (const auto& c : curves[s.name]) {
        const int k = experimentsToReach(c, target);
        if (k < 0) ++never;
        reach.push_back(k < 0 ? INFINITY : 100.0 * k / budget);  // never: beyond any budget, in the median too
      }
      const double m = median(reach);
      std::cout << s.name << ": mean final error " << meanAt(curves[s.name], checkpoints.size() - 1)
                << " m; reaches random's mean final error after a median of "
                << (std::isinf(m) ? std::string("never") : std::to_string(std::lround(m)) + " %")
                << " of the budget (" << never << " of " << repeats << " repeats never do)\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "allocation_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
