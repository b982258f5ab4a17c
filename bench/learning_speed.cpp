// How long MACHINELEARNING's learner takes per experiment as the data grow (issue 13, item 5). ROS-free.
//
// Per experiment it pays what MachineLearning::add() and the loop pay (src/cognition/machine_learning.cpp,
// src/loop/loop_model.cpp): the loop's prediction of the push before it is learned, addSample, then publish():
// save() and deriveNotions() over all samples. Optionally (--load) also what GOALDESIGN pays per published model:
// load() of the saved bytes. Reported per window of experiments around 50, 500 and 2000 (0.9 n .. 1.1 n, so that a
// schedule that retrains every k % of n is amortised fairly): mean, p95 and max wall ms per step and in total.
//
// Usage: learning_speed [--max N] [--load] [--csv FILE]
#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "xpersif/core/learning/push_learner.h"

using namespace xpersif::core;

namespace {

/// The rule of test/unit/test_push_learner.cpp: a heavy cube never moves; light cubes move k * distance along
/// the push and turn by c * offset * distance, plus noise. Six objects so that the one-hot code is realistic.
struct Cube {
  const char* name;
  double hue, size, k, c;
};
const Cube kCubes[] = {{"red_cube", 0, 0.04, 0.9, -150},     {"green_cube", 120, 0.04, 0.8, -120},
                       {"yellow_cube", 60, 0.04, 1.3, -90},  {"blue_cube", 240, 0.04, 0.0, 0.0},
                       {"red_cylinder", 5, 0.05, 0.7, -20},  {"green_block", 110, 0.06, 0.4, -60}};
constexpr int kObjects = sizeof(kCubes) / sizeof(kCubes[0]);

PushSample push(cv::RNG& rng) {
  const Cube& cube = kCubes[rng.uniform(0, kObjects)];
  const std::vector<std::string>& sides = pushSides();
  PushSample s;
  s.input.experiment = {cube.name, sides[rng.uniform(0, static_cast<int>(sides.size()))], rng.uniform(-0.02, 0.02),
                        rng.uniform(0.01, 0.15)};
  s.input.object.name = cube.name;
  s.input.object.x = rng.uniform(-0.2, 0.2);
  s.input.object.y = rng.uniform(-0.2, 0.2);
  s.input.object.extra = {{"hue", cube.hue + rng.gaussian(2.0)}, {"size", cube.size}};
  const double d = s.input.experiment.distance, off = s.input.experiment.offset;
  s.outcome = {cube.k * d, 0.0, cube.c * off * d};
  if (cube.k > 0) {
    s.outcome.dx += rng.gaussian(0.002);
    s.outcome.dy += rng.gaussian(0.002);
    s.outcome.dyaw += rng.gaussian(0.01);
  }
  return s;
}

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

enum Step { kPredict, kLearn, kSave, kNotions, kLoad, kTotal, kSteps };
const char* kStepNames[kSteps] = {"predict", "learn", "save", "notions", "load", "total"};

struct Row {
  std::size_t n;        // samples after this experiment
  std::size_t trained;  // trainedCount() after it
  double ms[kSteps];
  std::size_t bytes;
};

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(std::ceil(q * v.size())) - 1)];
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t max_n = 2200;
  bool with_load = false;
  std::string csv;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--max") && i + 1 < argc) max_n = std::stoul(argv[++i]);
    else if (!std::strcmp(argv[i], "--load")) with_load = true;
    else if (!std::strcmp(argv[i], "--csv") && i + 1 < argc) csv = argv[++i];
    else {
      std::fprintf(stderr, "usage: %s [--max N] [--load] [--csv FILE]\n", argv[0]);
      return 2;
    }
  }
  // MACHINELEARNING's configuration (onConfigure): defaults, one-hot identity over the scene's objects.
  PushLearnerConfig config;
  config.one_hot_identity = true;
  for (const auto& c : kCubes) config.identities.push_back(c.name);
  PushLearner learner(config);

  cv::RNG rng(2026);
  std::vector<PushSample> test;
  for (int i = 0; i < 300; ++i) test.push_back(push(rng));
  std::vector<Row> rows;
  for (std::size_t i = 0; i < max_n; ++i) {
    const PushSample s = push(rng);
    Row row{};
    auto t = std::chrono::steady_clock::now();
    const auto t_all = t;
    (void)learner.predict(s.input);  // the loop's "what the model expected"
    row.ms[kPredict] = msSince(t);
    t = std::chrono::steady_clock::now();
    learner.addSample(s.input, s.outcome);
    row.ms[kLearn] = msSince(t);
    t = std::chrono::steady_clock::now();
    const std::string bytes = learner.save();
    row.ms[kSave] = msSince(t);
    t = std::chrono::steady_clock::now();
    const auto notions = deriveNotions(learner.samples());
    row.ms[kNotions] = msSince(t);
    row.ms[kTotal] = msSince(t_all);
    if (with_load) {
      t = std::chrono::steady_clock::now();
      PushLearner subscriber;
      subscriber.load(bytes);
      row.ms[kLoad] = msSince(t);
    }
    row.n = learner.sampleCount();
    row.trained = learner.trainedCount();
    row.bytes = bytes.size();
    rows.push_back(row);
    if (notions.empty() && row.n > 100) std::fprintf(stderr, "no notions at %zu samples?\n", row.n);
  }

  if (!csv.empty()) {
    std::ofstream out(csv);
    out << "n,trained,bytes";
    for (const char* name : kStepNames) out << ',' << name << "_ms";
    out << '\n';
    for (const auto& r : rows) {
      out << r.n << ',' << r.trained << ',' << r.bytes;
      for (double ms : r.ms) out << ',' << ms;
      out << '\n';
    }
  }

  std::printf("learning_speed: %zu experiments, ensemble %d x %d trees, %d objects, one-hot identity%s\n", max_n,
              config.ensemble_size, config.trees_per_member, kObjects, with_load ? ", with a subscriber's load()" : "");
  std::printf("ms per experiment in windows 0.9n..1.1n (total = predict + learn + save + notions; load apart)\n");
  std::printf("%6s %11s %8s %10s", "n", "window", "retrains", "bytes");
  for (int k = 0; k < kSteps; ++k) {
    if (k == kLoad && !with_load) continue;
    std::printf(" %22s", (std::string(kStepNames[k]) + " mean/p95/max").c_str());
  }
  std::printf("\n");
  for (std::size_t centre : {50, 500, 2000}) {
    const std::size_t lo = centre * 9 / 10, hi = std::min(max_n, centre * 11 / 10);
    if (lo >= max_n) continue;
    std::size_t retrains = 0;
    for (std::size_t i = lo; i < hi; ++i) retrains += rows[i].trained != (i ? rows[i - 1].trained : 0);
    std::printf("%6zu %5zu..%-5zu %8zu %10zu", centre, lo + 1, hi, retrains, rows[hi - 1].bytes);
    for (int k = 0; k < kSteps; ++k) {
      if (k == kLoad && !with_load) continue;
      std::vector<double> v;
      double sum = 0;
      for (std::size_t i = lo; i < hi; ++i) {
        v.push_back(rows[i].ms[k]);
        sum += rows[i].ms[k];
      }
      std::printf(" %8.2f/%6.2f/%6.1f", sum / v.size(), percentile(v, 0.95), *std::max_element(v.begin(), v.end()));
    }
    std::printf("\n");
  }
  double worst = 0, sum = 0;
  std::size_t worst_at = 0, trainings = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    sum += rows[i].ms[kTotal];
    trainings += rows[i].trained != (i ? rows[i - 1].trained : 0);
    if (rows[i].ms[kTotal] > worst) worst = rows[i].ms[kTotal], worst_at = rows[i].n;
  }
  std::printf("all %zu experiments: %zu trainings, %.1f s in all, mean %.2f ms, worst %.1f ms (at n = %zu)\n",
              rows.size(), trainings, sum / 1000.0, sum / rows.size(), worst, worst_at);
  // What the model is worth: rms error of the mean on held-out pushes (dyaw weighted as in the unit tests).
  double se = 0;
  for (const auto& s : test) {
    const Prediction p = learner.predict(s.input);
    se += std::pow(p.mean.dx - s.outcome.dx, 2) + std::pow(p.mean.dy - s.outcome.dy, 2) +
          std::pow(0.02 * (p.mean.dyaw - s.outcome.dyaw), 2);
  }
  std::printf("held-out rms error after %zu samples (trained on %zu): %.5f m\n", learner.sampleCount(),
              learner.trainedCount(), std::sqrt(se / test.size()));
  return 0;
}
