// The region designs (learning_progress.h) on a synthetic experiment space with three kinds of object, as in
// Oudeyer, Kaplan and Hafner's IAC experiments: a trivial one (the outcome is always 0), a learnable but complex
// one (a smooth nonlinear function of side, offset and distance) and an unlearnable one (uniform noise). A
// simple learner in the test (k nearest neighbours per object and side) predicts each outcome before it learns
// it; its error is the design's held-out error.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <map>
#include <random>
#include <vector>

#include "xpersif/core/planning/learning_progress.h"
#include "xpersif/core/common/random_stream.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

namespace {

const Footprint kBox = Footprint::rectangle(0.04, 0.04);  // offset limit 0.02 m on every face

DesignContext space() {
  DesignContext c;
  c.objects = {{"trivial", true, kBox}, {"learnable", true, kBox}, {"noisy", true, kBox}};
  return c;
}

/// The world of the test: what an experiment does.
double outcome(const ExperimentChoice& e, std::mt19937_64& noise) {
  if (e.object == "trivial") return 0.0;
  if (e.object == "noisy") return std::uniform_real_distribution<double>(0.0, 1.0)(noise);
  const double side = static_cast<double>(std::find(pushSides().begin(), pushSides().end(), e.side) - pushSides().begin());
  const double u = e.offset / 0.02;  // the offset as a fraction of the face's limit
  return 0.5 + 0.5 * std::sin(2.5 * u + 1.5 * side) * e.distance / 0.15;
}

/// k nearest neighbours (k = 3) per object and side over (offset fraction, distance fraction); 0 with no data.
class Knn {
 public:
  double predict(const ExperimentChoice& e) const {
    const auto found = data_.find(e.object + e.side);
    if (found == data_.end()) return 0.0;
    std::vector<std::pair<double, double>> by;  // distance, outcome
    for (const auto& [u, d, y] : found->second) {
      by.emplace_back(std::pow(u - e.offset / 0.02, 2) + std::pow((d - e.distance) / 0.15, 2), y);
    }
    const std::size_t k = std::min<std::size_t>(3, by.size());
    std::partial_sort(by.begin(), by.begin() + static_cast<long>(k), by.end());
    double sum = 0;
    for (std::size_t i = 0; i < k; ++i) sum += by[i].second;
    return sum / static_cast<double>(k);
  }
  void learn(const ExperimentChoice& e, double y) { data_[e.object + e.side].push_back({e.offset / 0.02, e.distance, y}); }

 private:
  std::map<std::string, std::vector<std::tuple<double, double, double>>> data_;
};

/// Runs @p n experiments designed by @p design (fresh with @p seed), learning as the loop does; returns the
/// objects chosen, in order.
std::vector<std::string> campaign(const std::string& design, unsigned long seed, int n,
                                  const DesignOptions& options) {
  auto d = makeDesign(design, seed, options);
  DesignContext c = space();
  std::mt19937_64 noise(seed + 1000);
  Knn learner;
  std::vector<std::string> chosen;
  for (int i = 0; i < n; ++i) {
    c.stream = streamSeed(seed, 1, static_cast<std::uint64_t>(i), StreamPurpose::Design);
    const ExperimentChoice e = d->next(c);
    const double y = outcome(e, noise);
    const double error = std::fabs(learner.predict(e) - y);  // held out: predicted before it is learned
    learner.learn(e, y);
    c.history.push_back({e.object, e.side, e.offset, e.distance, error});
    chosen.push_back(e.object);
  }
  return chosen;
}

/// Share of each object among the choices after the warm-up, averaged over seeds.
std::map<std::string, double> shares(const std::string& design, int seeds, int n, int warm_up,
                                     const DesignOptions& options = {}) {  // the defaults, as DESIGNOFEXPERIMENTS'
  std::map<std::string, double> share;
  for (int s = 1; s <= seeds; ++s) {
    const auto chosen = campaign(design, static_cast<unsigned long>(s), n, options);
    for (int i = warm_up; i < n; ++i) share[chosen[static_cast<std::size_t>(i)]] += 1.0 / (n - warm_up) / seeds;
  }
  return share;
}

}  // namespace

TEST(AdaptiveRegions, ProgressIsTheFallOfTheErrorNotTheError) {
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress({}, 5), 0.0);
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress({0.4}, 5), 0.0);
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress({0.4, 0.2}, 5), 0.2);
  // Windows of 2: (0.5 + 0.5) / 2 - (0.1 + 0.3) / 2; the oldest error is out of both windows.
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress({9.0, 0.5, 0.5, 0.1, 0.3}, 2), 0.3);
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress({0.7, 0.7, 0.7, 0.7}, 2), 0.0);  // high and flat: nothing to learn
  EXPECT_DOUBLE_EQ(AdaptiveRegions::recentError({9.0, 0.5, 0.1}, 2), 0.3);
}

TEST(AdaptiveRegions, ProgressWithAConfidenceShrinksTheDifferenceByItsStandardErrors) {
  // Windows {0.4, 0.6} and {0.1, 0.3}: difference 0.3; each window's sample variance 0.02, so the standard
  // error of the difference is sqrt((0.02 + 0.02) / 2) = 0.1414.
  const std::vector<double> falling{0.4, 0.6, 0.1, 0.3};
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress(falling, 2, {0.0}), 0.3);
  EXPECT_NEAR(AdaptiveRegions::progress(falling, 2, {1.0}), 0.3 - std::sqrt(0.02), 1e-12);
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress(falling, 2, {3.0}), 0.0) << "within three standard errors: no progress";
  // A rise is shrunk towards 0 likewise, never past it.
  const std::vector<double> rising{0.1, 0.3, 0.4, 0.6};
  EXPECT_NEAR(AdaptiveRegions::progress(rising, 2, {1.0}), -0.3 + std::sqrt(0.02), 1e-12);
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress(rising, 2, {3.0}), 0.0);
  // Steady errors have no spread: their fall counts whole.
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress({0.5, 0.5, 0.2, 0.2}, 2, {2.0}), 0.3);
  // Windows of one error have no standard error: unshrunk.
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress({0.4, 0.2}, 5, {2.0}), 0.2);
  ExperimentSpace s{{"a"}, {"-x"}, -1, 1, 0.01, 0.1};
  EXPECT_THROW(AdaptiveRegions(s, Interest::Progress, 8, 2, {-0.5}), ValidationError);
  DesignOptions bad;
  bad.progress_confidence = NAN;
  EXPECT_THROW(bad.validate(), ValidationError);
}

TEST(AdaptiveRegions, ProgressAtMostTheErrorLeft) {
  ProgressRules bounded;
  bounded.at_most_recent_error = true;
  // Learned at once: a fall of 0.3 to errors of 0.001; what is left to gain is 0.001.
  const std::vector<double> learned{0.3, 0.3, 0.001, 0.001};
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress(learned, 2), 0.299);
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress(learned, 2, bounded), 0.001);
  // Still learning: the fall is below the error left, so it counts whole; a rise is kept as it is.
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress({0.5, 0.5, 0.4, 0.4}, 2, bounded), 0.5 - 0.4);
  EXPECT_DOUBLE_EQ(AdaptiveRegions::progress({0.4, 0.4, 0.5, 0.5}, 2, bounded), 0.4 - 0.5);
}

TEST(AdaptiveRegions, PerObjectRegionsStartWithOneLeafPerObject) {
  ExperimentSpace s{{"a", "b", "c"}, {"-x", "+x"}, -1, 1, 0.01, 0.1};
  AdaptiveRegions regions(s, Interest::Progress, 8, 3, {}, FirstCut::ByObject);
  ASSERT_EQ(regions.leaves().size(), 3u);
  for (std::size_t object = 0; object < 3; ++object) {
    const Region& leaf = regions.region(regions.leafOf({object, 0, 0.0, 0.05}));
    for (std::size_t other = 0; other < 3; ++other) EXPECT_EQ(leaf.objects[other], other == object) << leaf.cut;
  }
  // Each object's experiments stay in its own leaf, which then splits on its own.
  for (int i = 0; i < 9; ++i) regions.add({1, static_cast<std::size_t>(i % 2), -0.9 + 0.2 * i, 0.05}, 0.1);
  EXPECT_EQ(regions.leaves().size(), 4u) << "b's leaf held 9 > 8 and was cut";
  EXPECT_EQ(regions.region(regions.leafOf({0, 0, 0.0, 0.05})).members.size(), 0u);
}

TEST(AdaptiveRegions, SplitsAlongTheCutThatSeparatesProgress) {
  ExperimentSpace s{{"a", "b"}, {"-x", "+x"}, -1, 1, 0.01, 0.1};
  AdaptiveRegions regions(s, Interest::Progress, 8, 3);
  // Object a: errors falling; object b: flat. The same offset and distance for all: no cut there.
  for (int i = 0; i < 9; ++i) {
    const bool a = i % 2 == 0;
    regions.add({a ? 0u : 1u, static_cast<std::size_t>(i % 2), 0.25, 0.05}, a ? 1.0 - 0.1 * i : 0.3);
  }
  ASSERT_EQ(regions.leaves().size(), 2u) << "9 experiments > region_max_size 8: one cut";
  const Region& first = regions.region(regions.leaves()[0]);
  // Objects and sides coincide in this history; either cut separates a from b (the object is tried first).
  EXPECT_EQ(first.cut.rfind("object in", 0), 0u) << first.cut;
  const double pa = regions.interest(regions.leafOf({0, 0, 0.0, 0.05}));
  const double pb = regions.interest(regions.leafOf({1, 1, 0.0, 0.05}));
  EXPECT_GT(pa, 0.1);
  EXPECT_DOUBLE_EQ(pb, 0.0);
  std::size_t held = 0;
  for (int leaf : regions.leaves()) held += regions.region(leaf).members.size();
  EXPECT_EQ(held, regions.size()) << "every experiment is in exactly one leaf";
}

TEST(AdaptiveRegions, BadInputIsRefusedWithASentence) {
  ExperimentSpace s{{"a"}, {"-x"}, -1, 1, 0.01, 0.1};
  EXPECT_THROW(AdaptiveRegions(s, Interest::Progress, 3, 2), ValidationError);
  EXPECT_THROW(AdaptiveRegions(ExperimentSpace{{}, {"-x"}, -1, 1, 0.01, 0.1}, Interest::Progress, 8, 2), ValidationError);
  AdaptiveRegions regions(s, Interest::Progress, 8, 2);
  EXPECT_THROW(regions.add({0, 0, 0, 0.05}, NAN), ValidationError);
  EXPECT_THROW(regions.add({0, 0, 0, 0.05}, -1), ValidationError);
  EXPECT_THROW(regions.add({3, 0, 0, 0.05}, 0.1), ValidationError);
  EXPECT_EQ(regions.size(), 0u) << "a refused experiment changes nothing";

  LearningProgressDesign d(1, DesignOptions{});
  DesignContext c = space();
  c.history = {{"learnable", "+x", 0.0, 0.05, NAN}};
  try {
    d.next(c);
    FAIL() << "a NaN error was accepted";
  } catch (const ValidationError& e) {
    EXPECT_NE(std::string(e.what()).find("context.history[0].error"), std::string::npos) << e.what();
  }
  DesignOptions bad;
  bad.region_choice = "roulette";
  EXPECT_THROW(bad.validate(), ValidationError);
  bad = DesignOptions{};
  bad.random_share = 1.5;
  EXPECT_THROW(bad.validate(), ValidationError);
}

TEST(RegionDesigns, SameSeedAndHistorySameChoiceAndOnlyReachableObjects) {
  for (const std::string name : {"learning_progress", "error_max"}) {
    const auto a = campaign(name, 3, 120, DesignOptions{});
    const auto b = campaign(name, 3, 120, DesignOptions{});
    EXPECT_EQ(a, b) << name;
    auto d = makeDesign(name, 3);
    EXPECT_TRUE(d->usesHistory());
    EXPECT_FALSE(d->usesCuriosity());
    DesignContext c = space();
    c.objects[2].reachable = false;
    std::mt19937_64 rng(4);
    for (int i = 0; i < 200; ++i) {
      const ExperimentChoice e = d->next(c);
      EXPECT_NE(e.object, "noisy") << name << ": an unreachable object was chosen";
      EXPECT_LE(std::fabs(e.offset), 0.02 + 1e-12);
      EXPECT_GE(e.distance, DesignOptions{}.min_distance);
      EXPECT_LE(e.distance, DesignOptions{}.max_distance);
      c.history.push_back({e.object, e.side, e.offset, e.distance, std::uniform_real_distribution<double>(0, 1)(rng)});
    }
  }
}

// The claim of the design: after a warm-up, learning progress spends most of its experiments where there is
// something to learn, while the error maximiser is caught by the noise. Shares over experiments 101-400,
// averaged over 10 seeds (the synthetic world and the learner run in milliseconds).
TEST(RegionDesigns, LearningProgressConcentratesOnTheLearnableAndErrorMaxOnTheNoise) {
  const auto random = shares("random", 10, 400, 100);
  const auto lp = shares("learning_progress", 10, 400, 100);
  const auto em = shares("error_max", 10, 400, 100);
  auto show = [](const std::map<std::string, double>& s) {
    std::string out;
    for (const auto& [k, v] : s) out += k + " " + std::to_string(v) + "  ";
    return out;
  };
  const std::string figures = "random: " + show(random) + "\nlearning_progress: " + show(lp) + "\nerror_max: " + show(em);
  std::cout << "shares of experiments 101-400 over 10 seeds:\n" << figures << std::endl;
  SCOPED_TRACE(figures);
  EXPECT_NEAR(random.at("learnable"), 1.0 / 3, 0.05);
  EXPECT_GT(lp.at("learnable"), 0.40);
  EXPECT_GT(lp.at("learnable"), lp.at("noisy") + 0.08);
  EXPECT_GT(lp.at("learnable"), lp.at("trivial") + 0.08);
  EXPECT_GT(em.at("noisy"), 0.6);
  EXPECT_LT(em.at("learnable"), random.at("learnable"));
}

TEST(RegionDesigns, PerObjectRegionsAndAConfidentProgressConcentrateMoreOnTheLearnable) {
  auto show = [](const std::map<std::string, double>& s) {
    std::string out;
    for (const auto& [k, v] : s) out += k + " " + std::to_string(v) + "  ";
    return out;
  };
  DesignOptions per_object, confident, both;
  per_object.regions_per_object = both.regions_per_object = true;
  confident.progress_confidence = both.progress_confidence = 1.0;
  const auto plain = shares("learning_progress", 10, 400, 100);
  const auto by_object = shares("learning_progress", 10, 400, 100, per_object);
  const auto lp = shares("learning_progress", 10, 400, 100, both);
  const std::string figures = "plain: " + show(plain) + "\nregions per object: " + show(by_object) + "\nconfidence 1: " +
                              show(shares("learning_progress", 10, 400, 100, confident)) + "\nboth: " + show(lp);
  std::cout << "learning_progress, shares of experiments 101-400 over 10 seeds:\n" << figures << std::endl;
  SCOPED_TRACE(figures);
  // Here the regions per object make the difference (a noisy or trivial object no longer shares a leaf with the
  // learnable one); the confidence alone changes little.
  EXPECT_GT(by_object.at("learnable"), plain.at("learnable") + 0.1);
  EXPECT_GT(lp.at("learnable"), plain.at("learnable") + 0.1);
  EXPECT_GT(lp.at("learnable"), lp.at("noisy") + 0.2);
  EXPECT_GT(lp.at("learnable"), lp.at("trivial") + 0.2);
}
