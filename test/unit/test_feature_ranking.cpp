// FEATURESELECTION's ranking (core/feature_ranking.h): a feature that decides the outcome is ranked first, one that
// never varies last, the rule chooses by score, the same input gives the same scores, bad input is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "xpersif/core/learning/feature_ranking.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

namespace {

/// Pushes of four objects: "heavy" (1 for two of them) decides whether the object moves (dx = distance, or 0);
/// "noise" is drawn anew per push; "constant" is the same everywhere.
std::vector<PushSample> synthetic(int n, std::uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const char* sides[] = {"-x", "+x", "-y", "+y"};
  std::vector<PushSample> samples;
  for (int i = 0; i < n; ++i) {
    PushSample s;
    const int object = i % 4;
    s.input.experiment.object = "object_" + std::to_string(object);
    s.input.experiment.side = sides[(i / 4) % 4];
    s.input.experiment.offset = 0.02 * (unit(rng) - 0.5);
    s.input.experiment.distance = 0.02 + 0.1 * unit(rng);
    s.input.object.name = s.input.experiment.object;
    const bool heavy = object >= 2;
    s.input.object.extra = {{"heavy", heavy ? 1.0 : 0.0}, {"noise", unit(rng)}, {"constant", 0.5}};
    s.outcome.dx = heavy ? 0.0 : s.input.experiment.distance;
    s.outcome.dy = 0.002 * (unit(rng) - 0.5);
    s.outcome.dyaw = 0.0;
    samples.push_back(s);
  }
  return samples;
}

const std::vector<std::string> kCandidates = {"constant", "noise", "heavy"};

}  // namespace

TEST(FeatureRanking, TheDecisiveFeatureFirstTheConstantLast) {
  const FeatureRanking r = rankFeatures(synthetic(40), kCandidates);
  ASSERT_EQ(r.scores.size(), 3u);
  EXPECT_EQ(r.rows, 40u);
  EXPECT_EQ(r.scores.front().name, "heavy");
  EXPECT_GT(r.scores.front().score, 0.3);
  // Last: a value that never varies cannot change a prediction when shuffled (score exactly 0, the least there
  // is; noise that only hurts when kept is clipped to 0 as well and may tie with it).
  double constant = -1, noise = -1;
  for (const auto& s : r.scores) {
    if (s.name == "constant") constant = s.score;
    if (s.name == "noise") noise = s.score;
  }
  EXPECT_EQ(constant, 0.0);
  EXPECT_EQ(r.scores.back().score, 0.0);
  EXPECT_LT(noise, 0.2 * r.scores.front().score);
  ASSERT_FALSE(r.chosen.empty());
  EXPECT_EQ(r.chosen.front(), "heavy");
  for (const auto& name : r.chosen) EXPECT_NE(name, "constant");
}

TEST(FeatureRanking, TheRuleTakesAtMostCountAboveTheMinimum) {
  FeatureRankingOptions options;
  options.count = 1;
  FeatureRanking r = rankFeatures(synthetic(40), kCandidates, options);
  EXPECT_EQ(r.chosen, std::vector<std::string>{"heavy"});
  options.count = 3;
  options.min_score = 0.99;  // nothing explains all of the outcome's variance
  r = rankFeatures(synthetic(40), kCandidates, options);
  EXPECT_TRUE(r.chosen.empty());
  // Equal scores keep the candidates' order: two features that never vary both score 0.
  auto samples = synthetic(20);
  for (auto& s : samples) s.input.object.extra["other_constant"] = 2.0;
  options.min_score = 0.0;
  r = rankFeatures(samples, {"other_constant", "constant"}, options);
  ASSERT_EQ(r.scores.size(), 2u);
  EXPECT_EQ(r.scores[0].name, "other_constant");
  EXPECT_EQ(r.scores[1].name, "constant");
}

TEST(FeatureRanking, DeterministicForItsSeed) {
  FeatureRankingOptions options;
  options.seed = 42;
  const FeatureRanking a = rankFeatures(synthetic(30), kCandidates, options);
  const FeatureRanking b = rankFeatures(synthetic(30), kCandidates, options);
  ASSERT_EQ(a.scores.size(), b.scores.size());
  for (std::size_t i = 0; i < a.scores.size(); ++i) {
    EXPECT_EQ(a.scores[i].name, b.scores[i].name);
    EXPECT_EQ(a.scores[i].score, b.scores[i].score);  // bit for bit
  }
  EXPECT_EQ(a.chosen, b.chosen);
}

TEST(FeatureRanking, BadInputIsRefusedWithASentence) {
  const auto samples = synthetic(12);
  auto refused = [](const std::function<void()>& f, const std::string& part) {
    try {
      f();
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
      return;
    }
    ADD_FAILURE() << "not refused: expected a sentence with '" << part << "'";
  };
  refused([&] { rankFeatures(samples, {}); }, "no candidate features");
  refused([&] { rankFeatures(samples, {"heavy", "heavy"}); }, "named twice");
  refused([&] { rankFeatures(samples, {""}); }, "empty name");
  refused([&] { rankFeatures(samples, {"elongation"}); }, "has no feature 'elongation'");
  refused([&] { rankFeatures(synthetic(3), {"heavy"}); }, "at least 4 pushes");
  auto bad = samples;
  bad[5].input.object.extra["noise"] = std::numeric_limits<double>::quiet_NaN();
  refused([&] { rankFeatures(bad, kCandidates); }, "samples[5].input.object.extra[noise]");
  bad = samples;
  bad[2].outcome.dx = std::numeric_limits<double>::infinity();
  refused([&] { rankFeatures(bad, kCandidates); }, "samples[2].outcome");
  FeatureRankingOptions options;
  options.min_score = std::numeric_limits<double>::quiet_NaN();
  refused([&] { rankFeatures(samples, kCandidates, options); }, "min_score");
  options = {};
  options.count = 0;
  refused([&] { rankFeatures(samples, kCandidates, options); }, "count");
}
