#include <gtest/gtest.h>

#include "xpersif/core/planning/experiment_design.h"
#include "xpersif/core/planning/learning_progress.h"
#include "xpersif/core/planning/strategic_student.h"
#include "xpersif/core/common/random_stream.h"
#include "xpersif/core/common/validation.h"

#include <cmath>
#include <random>
#include <map>
#include <set>
#include <tuple>

using namespace xpersif::core;

namespace {

const Footprint kCube = Footprint::rectangle(0.04, 0.04);  // offset limit 0.02 m on every face

DesignContext cubes() {
  DesignContext c;
  c.objects = {{"red_cube", true, kCube}, {"green_cube", true, kCube}, {"yellow_cube", true, kCube},
               {"blue_cube", true, kCube}};
  return c;
}

bool same(const ExperimentChoice& a, const ExperimentChoice& b) {
  return a.object == b.object && a.side == b.side && a.offset == b.offset && a.distance == b.distance;
}

std::vector<ExperimentChoice> run(ExperimentDesign& d, const DesignContext& c, int n) {
  std::vector<ExperimentChoice> out;
  for (int i = 0; i < n; ++i) out.push_back(d.next(c));
  return out;
}

/// A smooth curiosity with its maximum at green_cube, +y, offset 0.01, distance 0.05.
double peaked(const ExperimentChoice& e) {
  return (e.object == "green_cube" ? 1.0 : 0.0) + (e.side == "+y" ? 0.5 : 0.0) -
         100 * std::pow(e.offset - 0.01, 2) - 100 * std::pow(e.distance - 0.05, 2);
}

}  // namespace

TEST(ExperimentDesign, SameSeedSameExperiments) {
  DesignContext c = cubes();
  c.curiosity = peaked;
  for (const auto& name : designNames()) {
    auto a = makeDesign(name, 7);
    auto b = makeDesign(name, 7);
    const auto ra = run(*a, c, 50);
    const auto rb = run(*b, c, 50);
    for (int i = 0; i < 50; ++i) EXPECT_TRUE(same(ra[i], rb[i])) << name << " #" << i;
    EXPECT_EQ(a->usesCuriosity(), name == "curiosity");
  }
  // A different seed gives a different sequence (random and curiosity; the grid has no randomness).
  for (const std::string name : {"random", "curiosity"}) {
    auto a = makeDesign(name, 7);
    auto b = makeDesign(name, 8);
    const auto ra = run(*a, c, 20);
    const auto rb = run(*b, c, 20);
    int differ = 0;
    for (int i = 0; i < 20; ++i) differ += !same(ra[i], rb[i]);
    EXPECT_GT(differ, 10) << name;
  }
}

TEST(RandomDesign, StaysInBoundsAndCoversObjectsAndSides) {
  DesignOptions o;
  o.min_offset = -0.25;  // fractions of the 0.02 m offset limit: -0.005 .. 0.012 m
  o.max_offset = 0.6;
  const double limit = 0.02;
  o.min_distance = 0.04;
  o.max_distance = 0.07;
  o.sides = {"+x", "-y"};
  RandomDesign d(42, o);
  const DesignContext c = cubes();
  std::map<std::string, int> objects, sides;
  double lo_off = 1, hi_off = -1, lo_dist = 1, hi_dist = -1;
  for (const auto& e : run(d, c, 2000)) {
    ASSERT_GE(e.offset, o.min_offset * limit);
    ASSERT_LE(e.offset, o.max_offset * limit);
    ASSERT_GE(e.distance, o.min_distance);
    ASSERT_LE(e.distance, o.max_distance);
    ++objects[e.object];
    ++sides[e.side];
    lo_off = std::min(lo_off, e.offset);
    hi_off = std::max(hi_off, e.offset);
    lo_dist = std::min(lo_dist, e.distance);
    hi_dist = std::max(hi_dist, e.distance);
  }
  EXPECT_EQ(objects.size(), 4u);
  EXPECT_EQ(sides.size(), 2u);
  EXPECT_EQ(sides.count("+x"), 1u);
  EXPECT_EQ(sides.count("-y"), 1u);
  for (const auto& [name, n] : objects) EXPECT_GT(n, 400) << name;  // 500 expected each
  // Uniform: the samples spread over the whole range.
  EXPECT_LT(lo_off, o.min_offset * limit + 0.001);
  EXPECT_GT(hi_off, o.max_offset * limit - 0.001);
  EXPECT_LT(lo_dist, o.min_distance + 0.002);
  EXPECT_GT(hi_dist, o.max_distance - 0.002);
}

TEST(GridDesign, CoversEveryCellOnceThenRepeatsInOrder) {
  GridDesign d;
  const DesignContext c = cubes();
  ASSERT_EQ(d.cells(4), 96u);
  const auto first = run(d, c, 96);
  std::set<std::tuple<std::string, std::string, double, double>> cells;
  for (const auto& e : first) cells.insert({e.object, e.side, e.offset, e.distance});
  EXPECT_EQ(cells.size(), 96u);
  for (const auto& object : {"red_cube", "green_cube", "yellow_cube", "blue_cube"}) {
    for (const auto& side : pushSides()) {
      for (double offset : {-0.75 * 0.02, 0.0, 0.75 * 0.02}) {  // default grid fractions of the offset limit
        for (double distance : {0.2 * 0.15, 0.4 * 0.15}) {         // and of the longest push
          EXPECT_EQ(cells.count({object, side, offset, distance}), 1u);
        }
      }
    }
  }
  // Object innermost (every budget covers the objects evenly), then distance, offset, side.
  EXPECT_EQ(first[0].toString(), "push red_cube on -x, offset -0.015 m, distance 0.03 m");
  EXPECT_EQ(first[1].toString(), "push green_cube on -x, offset -0.015 m, distance 0.03 m");
  EXPECT_EQ(first[4].toString(), "push red_cube on -x, offset -0.015 m, distance 0.06 m");
  EXPECT_EQ(first[8].toString(), "push red_cube on -x, offset 0 m, distance 0.03 m");
  EXPECT_EQ(first[24].side, "+x");
  EXPECT_EQ(first[0].rationale, "grid cell 1 of 96");
  const auto second = run(d, c, 96);
  for (int i = 0; i < 96; ++i) EXPECT_TRUE(same(first[i], second[i])) << i;
}

TEST(GridDesign, SkipsUnreachableObjects) {
  GridDesign d;
  DesignContext c = cubes();
  c.objects[3].reachable = false;  // blue
  std::set<std::tuple<std::string, std::string, double, double>> cells;
  for (const auto& e : run(d, c, 72)) {
    EXPECT_NE(e.object, "blue_cube");
    cells.insert({e.object, e.side, e.offset, e.distance});
  }
  EXPECT_EQ(cells.size(), 72u);  // every reachable cell exactly once

  // Reachability changing in the middle of the cycle: green's cells are skipped while it is unreachable.
  GridDesign g;
  DesignContext now = cubes();
  run(g, now, 20);  // cells 1..20, the objects in turn
  now.objects[1].reachable = false;
  const auto next = run(g, now, 5);  // cells 21 (red), 23 (yellow), 24 (blue), 25 (red), 27 (yellow)
  const std::vector<std::string> expected{"red_cube", "yellow_cube", "blue_cube", "red_cube", "yellow_cube"};
  for (int i = 0; i < 5; ++i) EXPECT_EQ(next[i].object, expected[i]) << i;
  EXPECT_EQ(next[4].rationale, "grid cell 27 of 96");
}

TEST(CuriosityDesign, PicksTheMostCuriousCandidate) {
  DesignOptions o;
  o.epsilon = 0.0;
  o.candidates = 16;
  CuriosityDesign d(3, o);
  DesignContext c = cubes();
  std::vector<double> seen;
  c.curiosity = [&](const ExperimentChoice& e) {
    seen.push_back(peaked(e));
    return seen.back();
  };
  for (int i = 0; i < 200; ++i) {
    seen.clear();
    const ExperimentChoice e = d.next(c);
    ASSERT_EQ(seen.size(), 16u);
    EXPECT_DOUBLE_EQ(peaked(e), *std::max_element(seen.begin(), seen.end()));
    EXPECT_FALSE(d.lastWasExploration());
    EXPECT_NE(e.rationale.find("best of 16"), std::string::npos) << e.rationale;
  }
}

TEST(CuriosityDesign, MostlyExploitsAndStillExploresWithEpsilon) {
  DesignOptions o;
  o.epsilon = 0.2;
  CuriosityDesign d(11, o);
  DesignContext c = cubes();
  c.curiosity = [](const ExperimentChoice& e) { return e.object == "green_cube" ? 1.0 : 0.0; };
  int green = 0, explorations = 0, other_objects = 0;
  const int n = 1000;
  for (int i = 0; i < n; ++i) {
    const ExperimentChoice e = d.next(c);
    explorations += d.lastWasExploration();
    if (e.object == "green_cube") {
      ++green;
    } else {
      ++other_objects;
      EXPECT_TRUE(d.lastWasExploration()) << "a greedy choice was not the most curious: " << e.toString();
    }
  }
  // Expected: 20% explorations; 85% green (all greedy choices, a quarter of the explorations).
  EXPECT_GT(explorations, 140);
  EXPECT_LT(explorations, 260);
  EXPECT_GT(green, 780);
  EXPECT_GT(other_objects, 60);
}

TEST(CuriosityDesign, TiesGoToTheFirstSampledCandidate) {
  DesignOptions o;
  o.epsilon = 0.0;
  CuriosityDesign d(5, o);
  DesignContext c = cubes();
  std::vector<ExperimentChoice> seen;
  c.curiosity = [&](const ExperimentChoice& e) {
    seen.push_back(e);
    return 0.25;
  };
  for (int i = 0; i < 20; ++i) {
    seen.clear();
    const ExperimentChoice e = d.next(c);
    ASSERT_FALSE(seen.empty());
    EXPECT_TRUE(same(e, seen.front()));
  }
}

TEST(ExperimentDesign, UnreachableObjectsAreNeverChosen) {
  DesignContext c = cubes();
  c.objects[0].reachable = false;
  c.objects[3].reachable = false;
  // Curiosity that would love the unreachable ones.
  c.curiosity = [](const ExperimentChoice& e) { return e.object == "red_cube" || e.object == "blue_cube" ? 9.0 : 0.0; };
  for (const auto& name : designNames()) {
    auto d = makeDesign(name, 1);
    for (const auto& e : run(*d, c, 300)) {
      EXPECT_TRUE(e.object == "green_cube" || e.object == "yellow_cube") << name << ": " << e.toString();
    }
  }
}

TEST(ExperimentDesign, PushesThePlannerWouldRefuseAreNotChosen) {
  // A planner that refuses every push of red_cube, every push on +x and every push longer than 0.1 m.
  auto allowed = [](const ExperimentChoice& e) { return e.object != "red_cube" && e.side != "+x" && e.distance <= 0.1; };
  int asked = 0;
  DesignContext c = cubes();
  c.feasible = [&](const ExperimentChoice& e) {
    ++asked;
    return allowed(e);
  };
  c.curiosity = [](const ExperimentChoice& e) { return e.object == "red_cube" || e.side == "+x" ? 9.0 : 0.0; };
  // A history in which red_cube's errors fall fastest: the region designs would favour it.
  for (int i = 0; i < 120; ++i) {
    const std::string object = i % 2 ? "red_cube" : "green_cube";
    c.history.push_back({object, "-y", 0.0, 0.05, object == "red_cube" ? 0.05 * std::exp(-i / 30.0) : 0.01});
  }
  DesignOptions o;
  o.regions_per_object = true;
  for (const auto& name : designNames()) {
    auto d = makeDesign(name, 5, o);
    std::set<std::string> objects, sides;
    for (const auto& e : run(*d, c, 200)) {
      EXPECT_TRUE(allowed(e)) << name << ": " << e.toString() << " (" << e.rationale << ")";
      objects.insert(e.object);
      sides.insert(e.side);
    }
    // Everything allowed stays open: three objects, three sides.
    EXPECT_EQ(objects.size(), name == "curiosity" ? objects.size() : 3u) << name;
    EXPECT_EQ(sides.size(), name == "curiosity" ? sides.size() : 3u) << name;
  }
  EXPECT_GT(asked, 1000);
  // Rejections are said in the rationale (random: a third of the draws or more are refused here).
  RandomDesign r(9);
  bool said = false;
  for (const auto& e : run(r, c, 20)) said = said || e.rationale.find("the push planner would refuse skipped") != std::string::npos;
  EXPECT_TRUE(said);
}

TEST(ExperimentDesign, APlannerThatAcceptsEveryPushChangesNoChoice) {
  DesignContext plain = cubes();
  plain.curiosity = peaked;
  for (int i = 0; i < 60; ++i) plain.history.push_back({i % 3 ? "red_cube" : "blue_cube", "+y", 0.0, 0.05, 0.02 / (1 + i)});
  DesignContext accepting = plain;
  accepting.feasible = [](const ExperimentChoice&) { return true; };
  for (const auto& name : designNames()) {
    auto a = makeDesign(name, 11);
    auto b = makeDesign(name, 11);
    const auto ra = run(*a, plain, 60);
    const auto rb = run(*b, accepting, 60);
    for (int i = 0; i < 60; ++i) {
      EXPECT_TRUE(same(ra[i], rb[i])) << name << " #" << i;
      EXPECT_EQ(ra[i].rationale, rb[i].rationale) << name << " #" << i;
    }
  }
}

TEST(ExperimentDesign, WhenThePlannerRefusesEveryPushADesignStillChoosesAndSaysSo) {
  DesignContext c = cubes();
  c.curiosity = peaked;
  c.feasible = [](const ExperimentChoice&) { return false; };
  for (const auto& name : designNames()) {
    auto d = makeDesign(name, 2);
    const ExperimentChoice e = d->next(c);  // no throw: MANIPULATION refuses it and the loop records why
    EXPECT_FALSE(e.object.empty()) << name;
    EXPECT_NE(e.rationale.find("would refuse every"), std::string::npos) << name << ": " << e.rationale;
  }
}

TEST(GridDesign, SkipsCellsThePlannerWouldRefuse) {
  GridDesign d;
  DesignContext c = cubes();
  c.feasible = [](const ExperimentChoice& e) { return e.side != "-x"; };
  const auto first = d.next(c);  // cells 1..24 are on -x: the first +x cell is 25
  EXPECT_EQ(first.side, "+x");
  EXPECT_EQ(first.rationale, "grid cell 25 of 96 (cells the push planner would refuse skipped)");
  EXPECT_EQ(d.next(c).rationale, "grid cell 26 of 96");
}

TEST(ExperimentDesign, NothingToPushIsAClearError) {
  DesignContext empty;
  empty.curiosity = peaked;
  DesignContext none = cubes();
  none.curiosity = peaked;
  for (auto& o : none.objects) o.reachable = false;
  for (const auto& name : designNames()) {
    auto d = makeDesign(name, 1);
    try {
      d->next(empty);
      FAIL() << name << " accepted an empty object list";
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find("context.objects is empty"), std::string::npos) << e.what();
    }
    try {
      d->next(none);
      FAIL() << name << " chose an unreachable object";
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find("is reachable"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("'blue_cube'"), std::string::npos) << e.what();
    }
  }
  DesignContext twice = cubes();
  twice.objects[1].name = "red_cube";
  EXPECT_THROW(RandomDesign(1).next(twice), ValidationError);
  DesignContext bad_name = cubes();
  bad_name.objects[0].name = "red cube";
  EXPECT_THROW(GridDesign().next(bad_name), ValidationError);
}

TEST(CuriosityDesign, NeedsACuriosityThatIsANumberAndAnErrorChangesNothing) {
  CuriosityDesign d(9);
  DesignContext c = cubes();
  EXPECT_THROW(d.next(c), ValidationError);  // no callback
  c.curiosity = [](const ExperimentChoice&) { return std::nan(""); };
  EXPECT_THROW(d.next(c), ValidationError);
  c.curiosity = peaked;
  CuriosityDesign fresh(9);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(same(d.next(c), fresh.next(c))) << i;
}

TEST(ExperimentDesign, FactoryAndOptionsAreValidated) {
  try {
    makeDesign("bandit", 1);
    FAIL() << "unknown design accepted";
  } catch (const ValidationError& e) {
    const std::string what = e.what();
    for (const auto& name : designNames()) EXPECT_NE(what.find("'" + name + "'"), std::string::npos) << what;
    EXPECT_NE(what.find("'bandit'"), std::string::npos) << what;
  }
  auto expectInvalid = [](DesignOptions o, const std::string& field) {
    try {
      makeDesign("random", 1, o);
      FAIL() << field << " accepted";
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  DesignOptions o;
  o.min_offset = -1.5;
  expectInvalid(o, "options.min_offset");
  o = {};
  o.min_offset = 0.5;
  o.max_offset = 0.0;
  expectInvalid(o, "options.min_offset");
  o = {};
  o.min_distance = 0.0;
  expectInvalid(o, "options.min_distance");
  o = {};
  o.max_distance = 20;
  expectInvalid(o, "options.max_distance");
  o = {};
  o.max_distance = std::nan("");
  expectInvalid(o, "options.max_distance");
  o = {};
  o.sides = {"+z"};
  expectInvalid(o, "options.sides[0]");
  o = {};
  o.grid_distances = {0.03, 0.0};
  expectInvalid(o, "options.grid_distances[1]");
  o = {};
  o.grid_offsets = {1.25};
  expectInvalid(o, "options.grid_offsets[0]");
  o = {};
  o.epsilon = 1.5;
  expectInvalid(o, "options.epsilon");
  o = {};
  o.candidates = 0;
  expectInvalid(o, "options.candidates");
  EXPECT_NO_THROW(makeDesign("grid", 1, DesignOptions{}));
}

// A resumed run makes the same choices as an uninterrupted one: with a stream (core::streamSeed of the run's
// seed, run and experiment), a choice depends on the stream alone, not on what the design drew before.
TEST(ExperimentDesign, AStreamMakesAChoiceIndependentOfHistory) {
  DesignContext c = cubes();
  c.curiosity = peaked;
  for (const std::string name : {"random", "curiosity"}) {
    auto uninterrupted = makeDesign(name, 7);
    std::vector<ExperimentChoice> choices;
    for (std::uint64_t k = 0; k < 10; ++k) {
      c.stream = streamSeed(11, 1, k, StreamPurpose::Design);
      choices.push_back(uninterrupted->next(c));
    }
    auto resumed = makeDesign(name, 99);  // a fresh design, another ~seed: the stream decides
    for (std::uint64_t k = 6; k < 10; ++k) {
      c.stream = streamSeed(11, 1, k, StreamPurpose::Design);
      EXPECT_TRUE(same(resumed->next(c), choices[k])) << name << " experiment " << k;
    }
    int differ = 0;  // and the streams differ from one experiment to the next
    for (std::size_t k = 1; k < choices.size(); ++k) differ += !same(choices[k], choices[k - 1]);
    EXPECT_GT(differ, 7) << name;
  }
  // The grid resumes at the cell of the history.
  c.stream.reset();
  auto grid = makeDesign("grid", 1);
  const auto cells = run(*grid, c, 8);
  auto resumed = makeDesign("grid", 1);
  c.history_count = 5;
  EXPECT_TRUE(same(resumed->next(c), cells[5]));
  EXPECT_TRUE(same(resumed->next(c), cells[6]));  // then it follows its own cursor
}

TEST(StreamSeed, DependsOnEveryArgument) {
  const std::uint64_t base = streamSeed(1, 2, 3, StreamPurpose::Design);
  EXPECT_EQ(base, streamSeed(1, 2, 3, StreamPurpose::Design));
  std::set<std::uint64_t> seen{base, streamSeed(0, 2, 3, StreamPurpose::Design),
                               streamSeed(1, 3, 3, StreamPurpose::Design), streamSeed(1, 2, 4, StreamPurpose::Design),
                               streamSeed(1, 2, 3, StreamPurpose::Tidy), streamSeed(2, 1, 3, StreamPurpose::Design)};
  EXPECT_EQ(seen.size(), 6u);
}

TEST(ExperimentDesign, InitializeRestartsFromTheSeed) {
  // Plugins are made with the default constructor and initialize()d: that must equal the seeded constructor,
  // and initializing again must start over.
  DesignContext c = cubes();
  c.curiosity = peaked;
  DesignOptions options;
  options.epsilon = 0.3;
  for (const auto& name : designNames()) {
    auto made = makeDesign(name, 11, options);
    std::unique_ptr<ExperimentDesign> plugin;
    if (name == "random") plugin = std::make_unique<RandomDesign>();
    if (name == "grid") plugin = std::make_unique<GridDesign>();
    if (name == "curiosity") plugin = std::make_unique<CuriosityDesign>();
    if (name == "learning_progress") plugin = std::make_unique<LearningProgressDesign>();
    if (name == "error_max") plugin = std::make_unique<ErrorMaxDesign>();
    if (name == "strategic_student") plugin = std::make_unique<StrategicStudentDesign>();
    if (name == "round_robin") plugin = std::make_unique<RoundRobinDesign>();
    if (name == "replicate_screening") plugin = std::make_unique<ReplicateScreeningDesign>();
    ASSERT_TRUE(plugin) << name;
    plugin->initialize(11, options);
    const auto expected = run(*made, c, 12);
    const auto first = run(*plugin, c, 12);
    plugin->initialize(11, options);
    const auto again = run(*plugin, c, 12);
    for (int i = 0; i < 12; ++i) {
      EXPECT_TRUE(same(expected[i], first[i])) << name << " #" << i;
      EXPECT_TRUE(same(expected[i], again[i])) << name << " #" << i;
    }
  }
}

TEST(ExperimentDesign, InitializeWithBadOptionsKeepsTheOldOnes) {
  DesignContext c = cubes();
  RandomDesign design(3);
  DesignOptions bad;
  bad.min_distance = -1;
  EXPECT_THROW(design.initialize(3, bad), ValidationError);
  const ExperimentChoice choice = design.next(c);
  EXPECT_GE(choice.distance, DesignOptions().min_distance);
}

// ---- object-level designs (issue 38) ----------------------------------------------------------------------

TEST(StrategicStudent, TheCurveFitSeesProgressOnlyWhereTheErrorFalls) {
  std::vector<double> falling, flat, still, noisy;
  std::mt19937 rng(3);
  std::lognormal_distribution<double> noise(0.0, 0.6);
  for (int n = 1; n <= 20; ++n) {
    falling.push_back(0.03 * std::pow(n, -0.5));
    flat.push_back(0.02 * noise(rng));  // an unlearnable object: big errors that do not fall
    still.push_back(0.0);               // an object that never moves: predicted exactly
  }
  const auto f = fitObjectCurve(falling);
  EXPECT_NEAR(f.b, -0.5, 0.1);
  EXPECT_GT(f.progress, 0.0);
  EXPECT_EQ(fitObjectCurve(still).progress, 0.0);
  // A trivial object: two large errors before the model knew it, then none. The fitted power law falls steeply,
  // but nothing is left to learn: its progress is far below the learnable object's.
  std::vector<double> trivial{0.03, 0.02};
  for (int n = 3; n <= 20; ++n) trivial.push_back(0.0002);
  EXPECT_LT(fitObjectCurve(trivial).b, -0.5);
  EXPECT_LT(fitObjectCurve(trivial).progress, 0.05 * f.progress);
  EXPECT_EQ(fitObjectCurve(flat).progress, 0.0) << "slope " << fitObjectCurve(flat).b << " +- " << fitObjectCurve(flat).b_se;
  EXPECT_EQ(fitObjectCurve({0.03, 0.02}).progress, 0.0);  // too few pushes to fit
  EXPECT_THROW(fitObjectCurve({0.03, NAN, 0.01}), ValidationError);
}

TEST(StrategicStudent, RoundRobinFirstThenTheObjectsThatProgress) {
  StrategicStudentDesign design(7, DesignOptions{});
  DesignContext c = cubes();
  // Warm-up: the objects in turn, three rounds.
  for (std::size_t i = 0; i < kWarmupPushes * c.objects.size(); ++i) {
    c.history_count = i;
    EXPECT_EQ(design.next(c).object, c.objects[i % c.objects.size()].name) << i;
  }
  // Then: red learns (its error falls), green never moves, yellow and blue are noise.
  std::mt19937 rng(5);
  std::lognormal_distribution<double> noise(0.0, 0.6);
  for (int n = 1; n <= 12; ++n) {
    c.history.push_back({"red_cube", "-x", 0, 0.05, 0.04 * std::pow(n, -0.6)});
    c.history.push_back({"green_cube", "-x", 0, 0.05, 0.0});
    c.history.push_back({"yellow_cube", "-x", 0, 0.05, 0.02 * noise(rng)});
    c.history.push_back({"blue_cube", "-x", 0, 0.05, 0.02 * noise(rng)});
  }
  c.history_count = c.history.size();
  const auto p = design.probabilities(c);
  EXPECT_NEAR(p.at("red_cube") + p.at("green_cube") + p.at("yellow_cube") + p.at("blue_cube"), 1.0, 1e-12);
  EXPECT_NEAR(p.at("green_cube"), 0.2 / 4, 1e-12);  // the floor only
  EXPECT_GT(p.at("red_cube"), 0.5);
  std::map<std::string, int> chosen;
  for (int i = 0; i < 400; ++i) chosen[design.next(c).object]++;
  EXPECT_GT(chosen["red_cube"], 200);
  EXPECT_GT(chosen["green_cube"], 0);  // the floor keeps every object in play
}

TEST(StrategicStudent, AnObjectPredictedToTheFloorDoesNotTakeTheSharesOfNoisyOnes) {
  // A generated world's study: the immovable block's errors fell from 7 cm to 0 in three pushes, the learnable puck's
  // and bar's were noisy with no significant slope yet. The block's fall was steep, its progress tiny but the only
  // one above 0, so it took every share but the floor (50 % of the pushes) and starved the puck (6 %).
  std::vector<double> known{0.069, 0.044, 0.026};
  for (int n = 4; n <= 20; ++n) known.push_back(n % 5 ? 0.0 : 0.0001);
  EXPECT_EQ(fitObjectCurve(known).progress, 0.0);
  StrategicStudentDesign design(7, DesignOptions{});
  DesignContext c = cubes();
  std::mt19937 rng(11);
  std::lognormal_distribution<double> noise(0.0, 0.7);
  for (std::size_t n = 0; n < known.size(); ++n) c.history.push_back({"green_cube", "-x", 0, 0.05, known[n]});
  for (int n = 1; n <= 6; ++n) {
    for (const char* object : {"red_cube", "yellow_cube", "blue_cube"}) {
      c.history.push_back({object, "-x", 0, 0.05, 0.03 * noise(rng)});
    }
  }
  c.history_count = c.history.size();
  const auto p = design.probabilities(c);
  EXPECT_LE(p.at("green_cube"), 0.25 + 1e-12);  // at most an even share: nothing progresses, so uniform
  EXPECT_GE(p.at("red_cube"), 0.2 / 4);
}

TEST(StrategicStudent, AStreamGivesTheSameChoiceAndUnreachableObjectsAreNeverChosen) {
  DesignContext c = cubes();
  c.history_count = 40;
  for (int n = 1; n <= 10; ++n) c.history.push_back({"red_cube", "+y", 0, 0.05, 0.03 / n});
  c.stream = 1234;
  StrategicStudentDesign a(1, DesignOptions{}), b(99, DesignOptions{});
  EXPECT_TRUE(same(a.next(c), b.next(c)));  // a resumed run chooses as the uninterrupted one
  c.objects[0].reachable = false;           // red, the one that progresses, is against a wall now
  c.stream.reset();
  for (int i = 0; i < 50; ++i) EXPECT_NE(a.next(c).object, "red_cube");
  for (auto& o : c.objects) o.reachable = false;
  EXPECT_THROW(a.next(c), ValidationError);
}

TEST(RoundRobin, EveryObjectInTurnAndARandomPushOnIt) {
  RoundRobinDesign design(3, DesignOptions{});
  DesignContext c = cubes();
  c.objects[2].reachable = false;  // yellow's turn goes to the next reachable object
  std::map<std::string, int> counts;
  std::set<double> distances;
  for (std::size_t i = 0; i < 8; ++i) {
    c.history_count = i;
    const auto choice = design.next(c);
    counts[choice.object]++;
    distances.insert(choice.distance);
  }
  EXPECT_EQ(counts["red_cube"], 2);
  EXPECT_EQ(counts["green_cube"], 2);
  EXPECT_EQ(counts["yellow_cube"], 0);
  EXPECT_EQ(counts["blue_cube"], 4);
  EXPECT_EQ(distances.size(), 8u);  // pushes drawn at random, not a grid
  EXPECT_EQ(makeDesign("round_robin", 3)->next(c).object, makeDesign("round_robin", 4)->next(c).object);
}

// ---- replicate screening ------------------------------------------------------------------------------------

TEST(ReplicateScreening, TheSpreadOfReplicatedPushes) {
  // Deterministic: the same push moved the cube 40 and 41 mm; redrawn friction: 15 and 60 mm; a block that never
  // moves: 0 and 0 (its spread is relative to 5 mm, not to nothing).
  const PastExperiment a{"c", "-x", 0.004, 0.05, 0.01, 0.040, 0.002}, a2{"c", "-x", 0.005, 0.052, 0.01, 0.041, 0.001};
  EXPECT_EQ(replicateSpread({a, a2}).pairs, 1u);
  EXPECT_LT(replicateSpread({a, a2}).spread, 0.05);
  const PastExperiment n{"c", "+y", 0.0, 0.08, 0.02, 0.015, 0.0}, n2{"c", "+y", 0.0, 0.08, 0.02, 0.060, -0.01};
  EXPECT_GT(replicateSpread({n, n2}).spread, kNoisySpread);
  const PastExperiment z{"c", "+x", 0.0, 0.03, 0.0, 0.0, 0.0};
  EXPECT_EQ(replicateSpread({z, z}).spread, 0.0);
  // Not the same design point: another side, offset or distance.
  const PastExperiment side{"c", "+x", 0.004, 0.05, 0.01, 0.1, 0}, offset{"c", "-x", 0.010, 0.05, 0.01, 0.1, 0},
      far{"c", "-x", 0.004, 0.07, 0.01, 0.1, 0};
  EXPECT_EQ(replicateSpread({a, side, offset, far}).pairs, 0u);
  EXPECT_EQ(replicateSpread({}).spread, 0.0);
  // The median over the pairs: one odd pair among alike ones does not make an object noise.
  EXPECT_LT(replicateSpread({a, a2, a, a2, PastExperiment{"c", "-x", 0.004, 0.05, 0.01, 0.09, 0}}).spread, kNoisySpread);
  EXPECT_THROW(replicateSpread({a, PastExperiment{"c", "-x", 0, 0.05, 0.01, NAN, 0}}), ValidationError);
}

TEST(ReplicateScreening, AWarmUpOfPushesAndTheirReplicates) {
  ReplicateScreeningDesign design(7, DesignOptions{});
  DesignContext c = cubes();
  const std::size_t k = c.objects.size();
  std::vector<ExperimentChoice> first;
  for (std::size_t i = 0; i < 2 * k; ++i) {
    c.history_count = i;
    const ExperimentChoice choice = design.next(c);
    EXPECT_EQ(choice.object, c.objects[i % k].name) << i;
    if (i < k) {
      first.push_back(choice);
    } else {  // the same push again
      EXPECT_EQ(choice.side, first[i - k].side);
      EXPECT_DOUBLE_EQ(choice.offset, first[i - k].offset);
      EXPECT_DOUBLE_EQ(choice.distance, first[i - k].distance);
      EXPECT_NE(choice.rationale.find("replicate"), std::string::npos) << choice.rationale;
    }
    c.history.push_back({choice.object, choice.side, choice.offset, choice.distance, 0.02, 0.03, 0.0});
  }
  // A replicate the planner would refuse from here: a uniform push instead, and the rationale says so.
  c.history.resize(k);
  c.history_count = k;
  c.feasible = [&](const ExperimentChoice& e) { return !(e.side == first[0].side && e.offset == first[0].offset); };
  const ExperimentChoice instead = design.next(c);
  EXPECT_EQ(instead.object, c.objects[0].name);
  EXPECT_NE(instead.rationale.find("not feasible"), std::string::npos) << instead.rationale;
}

TEST(ReplicateScreening, NoiseAndKnownObjectsGetTheFloorTheLearnableShareTheRest) {
  ReplicateScreeningDesign design(7, DesignOptions{});
  DesignContext c = cubes();
  // red answers a push alike and its error is 2 cm; green never moves and is known; yellow and blue answered the same
  // push with 10 and 50 mm (friction redrawn).
  for (int round = 0; round < 3; ++round) {
    c.history.push_back({"red_cube", "-x", 0.0, 0.05, 0.02, 0.045 + 0.001 * round, 0.0});
    c.history.push_back({"green_cube", "-x", 0.0, 0.05, round ? 0.0 : 0.03, 0.0, 0.0});
    c.history.push_back({"yellow_cube", "+y", 0.0, 0.06, 0.03, round % 2 ? 0.05 : 0.01, 0.0});
    c.history.push_back({"blue_cube", "+y", 0.0, 0.06, 0.03, round % 2 ? 0.01 : 0.05, 0.01});
  }
  c.history.push_back({"green_cube", "-x", 0.0, 0.05, 0.0, 0.0, 0.0});
  c.history_count = c.history.size();
  const auto p = design.probabilities(c);
  EXPECT_NEAR(p.at("red_cube"), 0.2 / 4 + 0.8, 1e-12);
  for (const char* other : {"green_cube", "yellow_cube", "blue_cube"}) EXPECT_NEAR(p.at(other), 0.2 / 4, 1e-12) << other;
  // Each choice after the warm-up: red most of the time; the stream gives the same choice to any instance.
  std::map<std::string, int> chosen;
  for (int i = 0; i < 400; ++i) chosen[design.next(c).object]++;
  EXPECT_GT(chosen["red_cube"], 280);
  EXPECT_GT(chosen["blue_cube"], 0);
  c.stream = 42;
  ReplicateScreeningDesign other(99, DesignOptions{});
  EXPECT_TRUE(same(design.next(c), other.next(c)));
  EXPECT_EQ(makeDesign("replicate_screening", 1)->next(c).object, design.next(c).object);
}

TEST(ReplicateScreening, AnObjectNoPushMovedIsKnownWhateverTheModelsFirstErrors) {
  ReplicateScreeningDesign design(7, DesignOptions{});
  DesignContext c = cubes();
  // green: a push and its replicate that did not move it (0.4 mm), while the model still erred by 4 and 2 cm.
  c.history.push_back({"green_cube", "-x", 0.0, 0.05, 0.04, 0.0004, 0.0});
  c.history.push_back({"green_cube", "-x", 0.0, 0.05, 0.02, 0.0, 0.0});
  // yellow: one push that did not move it is not yet enough (it may have missed a light object).
  c.history.push_back({"yellow_cube", "+y", 0.0, 0.05, 0.03, 0.0, 0.0});
  c.history_count = c.history.size();
  auto p = design.probabilities(c);
  EXPECT_NEAR(p.at("green_cube"), 0.2 / 4, 1e-12);
  EXPECT_NEAR(p.at("yellow_cube"), 0.2 / 4 + 0.8 / 3, 1e-12);
  // A later push (at the floor) that moves green makes it learnable again.
  c.history.push_back({"green_cube", "+x", 0.01, 0.07, 0.03, 0.012, 0.002});
  p = design.probabilities(c);
  EXPECT_NEAR(p.at("green_cube"), 0.2 / 4 + 0.8 / 4, 1e-12);
}

TEST(ReplicateScreening, AnObjectIsAskedAgainForEveryTenOfItsPushesBeyondItsShare) {
  ReplicateScreeningDesign design(7, DesignOptions{});
  DesignContext c = cubes();
  ASSERT_EQ(c.objects.size(), 4u);
  for (std::size_t i = 1; i < c.objects.size(); ++i) c.objects[i].reachable = false;  // red is the only choice
  // A push and its replicate, then eleven pushes none of which repeats another: thirteen pushes, all of them red's,
  // 9.75 beyond its even share of a quarter, one pair.
  c.history.push_back({"red_cube", "-x", 0.0, 0.05, 0.02, 0.040, 0.0});
  c.history.push_back({"red_cube", "-x", 0.0, 0.05, 0.02, 0.041, 0.0});
  for (int i = 0; i < 11; ++i) {
    c.history.push_back({"red_cube", i % 2 ? "+y" : "+x", -0.02 + 0.004 * i, 0.03 + 0.005 * i, 0.02, 0.03, 0.0});
  }
  c.history_count = 20;
  EXPECT_EQ(design.next(c).rationale.find("replicate)"), std::string::npos);
  // The fourteenth push, 10.5 beyond its share: red wants a second pair, so the next choice is that push again.
  c.history.push_back({"red_cube", "-y", 0.004, 0.06, 0.02, 0.02, 0.01});
  const ExperimentChoice again = design.next(c);
  EXPECT_EQ(again.side, "-y");
  EXPECT_DOUBLE_EQ(again.offset, 0.004);
  EXPECT_DOUBLE_EQ(again.distance, 0.06);
  EXPECT_NE(again.rationale.find("replicate"), std::string::npos) << again.rationale;
  c.history.push_back({"red_cube", "-y", 0.004, 0.06, 0.02, 0.021, 0.01});
  EXPECT_EQ(design.next(c).rationale.find("replicate)"), std::string::npos);
}

TEST(ReplicateScreening, ObjectsAtTheirEvenShareAreNotAskedAgain) {
  // Where the budget is shared evenly (every object learnable), one pair each is enough however long the run.
  EXPECT_EQ(replicatePairsWanted(25, 100, 4), kReplicatePairs);
  EXPECT_EQ(replicatePairsWanted(300, 1200, 4), kReplicatePairs);
  EXPECT_EQ(replicatePairsWanted(34, 100, 4), kReplicatePairs);      // 9 beyond
  EXPECT_EQ(replicatePairsWanted(35, 100, 4), kReplicatePairs + 1);  // 10 beyond
  EXPECT_EQ(replicatePairsWanted(80, 100, 4), kReplicatePairs + 5);  // 55 beyond
  EXPECT_EQ(replicatePairsWanted(0, 0, 4), kReplicatePairs);
  ReplicateScreeningDesign design(7, DesignOptions{});
  DesignContext c = cubes();
  // Every object twenty pushes, the first two of each a replicated pair: no choice is a replicate.
  for (const auto& object : c.objects) {
    c.history.push_back({object.name, "-x", 0.0, 0.05, 0.02, 0.040, 0.0});
    c.history.push_back({object.name, "-x", 0.0, 0.05, 0.02, 0.041, 0.0});
    for (int i = 0; i < 18; ++i) {
      c.history.push_back({object.name, i % 2 ? "+y" : "+x", -0.02 + 0.002 * i, 0.03 + 0.003 * i, 0.02, 0.03, 0.0});
    }
  }
  c.history_count = c.history.size();
  for (std::uint64_t stream = 1; stream <= 20; ++stream) {
    c.stream = stream;
    const ExperimentChoice choice = design.next(c);
    EXPECT_EQ(choice.rationale.find("replicate)"), std::string::npos) << choice.rationale;
  }
}
