#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <set>

#include "xpersif/core/learning/motivation.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

TEST(Surprise, ErrorAndNormalizedError) {
  const Prediction p{{0.05, 0.0, 0.1}, {0.01, 0.01, 0.1}};
  const Surprise exact = surprise(p, {0.05, 0.0, 0.1});
  EXPECT_DOUBLE_EQ(exact.error, 0.0);
  EXPECT_DOUBLE_EQ(exact.normalized, 0.0);
  // One std off in every component: normalized 1.
  const Surprise one = surprise(p, {0.06, -0.01, 0.2});
  EXPECT_NEAR(one.normalized, 1.0, 1e-12);
  EXPECT_NEAR(one.error, std::sqrt(0.01 * 0.01 + 0.01 * 0.01 + (0.02 * 0.1) * (0.02 * 0.1)), 1e-12);
  EXPECT_NEAR(one.residual.dy, -0.01, 1e-15);
  // The same error against a confident prediction is more surprising.
  const Prediction confident{{0.05, 0.0, 0.1}, {0.001, 0.001, 0.01}};
  EXPECT_NEAR(surprise(confident, {0.06, -0.01, 0.2}).normalized, 10.0, 1e-9);
  // Yaw residuals wrap: predicted pi - 0.05, got -pi + 0.05 is 0.1 rad off, not 2 pi - 0.1.
  const Surprise wrapped = surprise({{0, 0, M_PI - 0.05}, {1, 1, 1}}, {0, 0, -M_PI + 0.05});
  EXPECT_NEAR(wrapped.residual.dyaw, 0.1, 1e-12);
  // Zero std: large but finite.
  EXPECT_TRUE(std::isfinite(surprise({{0, 0, 0}, {0, 0, 0}}, {0.01, 0, 0}).normalized));
}

TEST(Surprise, RejectsInvalidInput) {
  const Prediction p{{0, 0, 0}, {0.01, 0.01, 0.1}};
  EXPECT_THROW(surprise(p, {std::nan(""), 0, 0}), ValidationError);
  EXPECT_THROW(surprise({{0, 0, 0}, {-0.01, 0.01, 0.1}}, {0, 0, 0}), ValidationError);
  EXPECT_THROW(surprise({{0, std::nan(""), 0}, {0.01, 0.01, 0.1}}, {0, 0, 0}), ValidationError);
  EXPECT_THROW(surprise(p, {0, 0, 0}, 0.0), ValidationError);
}

namespace {
CuriosityConfig twoObjects() {
  CuriosityConfig c;
  c.objects = {"red_cube", "blue_cube"};
  c.footprints = {{"red_cube", Footprint::rectangle(0.04, 0.04)}, {"blue_cube", Footprint::rectangle(0.04, 0.04)}};
  c.offset_bins = 3;
  c.window = 5;
  return c;
}
}  // namespace

TEST(Curiosity, RegionsCoverTheExperimentSpace) {
  CuriosityMap map(twoObjects());
  EXPECT_EQ(map.regions().size(), 2u * 4u * 3u);
  EXPECT_EQ(map.regionOf({"red_cube", "-x", -0.02, 0.1}), (RegionKey{"red_cube", "-x", 0}));
  EXPECT_EQ(map.regionOf({"red_cube", "-x", -0.0067, 0.1}).offset_bin, 0);
  EXPECT_EQ(map.regionOf({"red_cube", "-x", 0.0, 0.1}).offset_bin, 1);
  EXPECT_EQ(map.regionOf({"red_cube", "+y", 0.02, 0.1}), (RegionKey{"red_cube", "+y", 2}));
  const auto range = map.offsetRange(RegionKey{"red_cube", "-x", 1});
  EXPECT_NEAR(range.first, -0.02 / 3, 1e-12);
  EXPECT_NEAR(range.second, 0.02 / 3, 1e-12);
  EXPECT_EQ((RegionKey{"red_cube", "-x", 2}).toString(), "red_cube/-x/2");
}

TEST(Curiosity, ErrorsThatFallBeatErrorsThatStayFlat) {
  CuriosityMap map(twoObjects());
  const RegionKey learning{"red_cube", "-x", 1}, learned{"blue_cube", "-x", 1}, noisy{"red_cube", "+y", 0};
  cv::RNG rng(5);
  for (int i = 0; i < 12; ++i) {
    map.record(learning, 0.05 * std::exp(-0.2 * i));       // being learned: errors fall
    map.record(learned, 0.001);                              // learned: small and flat
    map.record(noisy, rng.uniform(0.0, 0.06));               // unlearnable: large, random, no trend
  }
  const double c_learning = map.curiosity(learning), c_learned = map.curiosity(learned), c_noisy = map.curiosity(noisy);
  std::printf("[ measured ] curiosity: learning %.4f, learned %.4f, noisy %.4f\n", c_learning, c_learned, c_noisy);
  EXPECT_GT(c_learning, 0.01);
  EXPECT_NEAR(c_learned, 0.0, 1e-12);
  EXPECT_GT(c_learning, c_learned);
  EXPECT_GT(c_learning, c_noisy);
  EXPECT_DOUBLE_EQ(map.learningProgress(learning), c_learning);

  // Once the unexplored regions are visited, the learning region is the most curious one.
  for (const auto& r : map.regions()) {
    if (r.count == 0) {
      map.record(r.key, 0.02);
      map.record(r.key, 0.02);
    }
  }
  EXPECT_EQ(map.mostCurious(), learning);
  for (const auto& r : map.regions()) {
    if (r.key == learning) {
      EXPECT_EQ(r.count, 12u);
      EXPECT_GT(r.mean_older, r.mean_newer);
      EXPECT_NEAR(r.last_error, 0.05 * std::exp(-0.2 * 11), 1e-12);
    }
  }
}

TEST(Curiosity, UnvisitedRegionsComeFirstInOrder) {
  CuriosityMap map(twoObjects());
  const RegionKey first = map.mostCurious();
  EXPECT_EQ(first, map.regions().front().key);  // all equal: key order
  EXPECT_DOUBLE_EQ(map.curiosity(first), 1.0);
  // Visiting every region once, always going where curiosity points, visits each region exactly once.
  std::set<std::string> visited;
  for (std::size_t i = 0; i < map.regions().size(); ++i) {
    const RegionKey next = map.mostCurious();
    EXPECT_TRUE(visited.insert(next.toString()).second) << next.toString();
    map.record(next, 0.03);
  }
  EXPECT_EQ(visited.size(), map.regions().size());
  // After one visit a region is still unexplored (min_visits = 2): optimism holds until the second.
  EXPECT_DOUBLE_EQ(map.curiosity(first), 1.0);
  map.record(first, 0.03);
  EXPECT_DOUBLE_EQ(map.curiosity(first), 0.0);
}

TEST(Curiosity, HistoryIsBounded) {
  CuriosityConfig config = twoObjects();
  config.max_history = 10;
  CuriosityMap map(config);
  const RegionKey key{"red_cube", "-x", 0};
  for (int i = 0; i < 100; ++i) map.record(key, i < 95 ? 1.0 : 0.5);
  for (const auto& r : map.regions()) EXPECT_EQ(r.count, r.key == key ? 100u : 0u);  // all counted, 10 kept
  EXPECT_NEAR(map.learningProgress(key), 0.5, 1e-12);  // windows [90, 95) of 1.0 against [95, 100) of 0.5
}

TEST(Curiosity, RejectsInvalidInput) {
  CuriosityMap map(twoObjects());
  EXPECT_THROW(map.record(RegionKey{"green_cube", "-x", 0}, 0.1), ValidationError);
  EXPECT_THROW(map.record(RegionKey{"red_cube", "x", 0}, 0.1), ValidationError);
  EXPECT_THROW(map.record(RegionKey{"red_cube", "-x", 3}, 0.1), ValidationError);
  EXPECT_THROW(map.record(RegionKey{"red_cube", "-x", 0}, -0.1), ValidationError);
  EXPECT_THROW(map.record(RegionKey{"red_cube", "-x", 0}, std::nan("")), ValidationError);
  EXPECT_THROW(map.regionOf({"red_cube", "-x", 0.05, 0.1}), ValidationError);
  EXPECT_THROW(map.regionOf({"green_cube", "-x", 0.0, 0.1}), ValidationError);
  EXPECT_THROW(map.offsetRange(RegionKey{"red_cube", "-x", 3}), ValidationError);
  for (const auto& r : map.regions()) EXPECT_EQ(r.count, 0u);  // nothing was recorded

  CuriosityConfig bad = twoObjects();
  bad.objects.clear();
  EXPECT_THROW(CuriosityMap{bad}, ValidationError);
  bad = twoObjects();
  bad.objects.push_back("red_cube");
  EXPECT_THROW(CuriosityMap{bad}, ValidationError);
  bad = twoObjects();
  bad.offset_bins = 0;
  EXPECT_THROW(CuriosityMap{bad}, ValidationError);
  bad = twoObjects();
  bad.sides = {"-x", "up"};
  EXPECT_THROW(CuriosityMap{bad}, ValidationError);
  bad = twoObjects();
  bad.max_history = 3;
  EXPECT_THROW(CuriosityMap{bad}, ValidationError);
}
