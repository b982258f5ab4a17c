// The set-up catalogue read from XPERSim's scene: objects, footprints and the limits derived from them, on
// every shipped world (not only the default one).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "shipped_worlds.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/common/setup.h"
#include "xpersif/core/common/validation.h"
#include "xpersif/core/sim/world_spec.h"

using namespace xpersif::core;

namespace {


SceneDescription sceneOf(const std::string& file) { return PhysicsWorld(loadWorldFile(file)).scene(); }

}  // namespace

TEST(SetupCatalogue, EveryShippedWorldGivesItsObjectsAndSaneLimits) {
  const auto files = shippedWorldFiles();
  ASSERT_FALSE(files.empty());
  for (const auto& file : files) {
    SCOPED_TRACE(file);
    const WorldSpec spec = loadWorldFile(file);
    const SetupCatalogue cat = SetupCatalogue::fromScene(PhysicsWorld(spec).scene());
    ASSERT_EQ(cat.objects.size(), spec.objects.size());
    for (std::size_t i = 0; i < spec.objects.size(); ++i) {
      EXPECT_EQ(cat.objects[i].name, spec.objects[i].name);  // world-file order
      EXPECT_EQ(cat.objects[i].footprint.isDisc(), spec.objects[i].shape.type != Shape::Type::Box);
    }
    EXPECT_EQ(cat.arena_size_x, spec.arena.size_x);
    EXPECT_EQ(cat.arena_size_y, spec.arena.size_y);
    EXPECT_GT(cat.robot_radius, 0.0);
    EXPECT_LT(cat.minPushDistance(), cat.maxPushDistance());
    EXPECT_LT(cat.maxPushDistance(), 0.5 * std::min(cat.arena_size_x, cat.arena_size_y));
    // Tidying leaves room inside the arena.
    EXPECT_LT(cat.wallMargin(), 0.5 * std::min(cat.arena_size_x, cat.arena_size_y));
    for (const auto& o : cat.objects) {
      for (const auto& side : pushSides()) {
        const double limit = maxPushOffset(o.footprint, side);
        EXPECT_GT(limit, 0.0) << o.name;
        EXPECT_EQ(cat.checkExperiment("e", {o.name, side, limit, cat.maxPushDistance()}), "") << o.name;
        EXPECT_NE(cat.checkExperiment("e", {o.name, side, 1.01 * limit, cat.maxPushDistance()}), "") << o.name;
      }
    }
  }
}

TEST(SetupCatalogue, DefaultWorldKeepsItsFormerLimits) {
  // The limits that used to be constants for 4 cm cubes in a 0.9 x 0.6 m arena now follow from the geometry.
  const SetupCatalogue cat = SetupCatalogue::fromScene(sceneOf(std::string(XPERSIF_SOURCE_DIR) + "/worlds/default.yaml"));
  EXPECT_NEAR(cat.maxPushDistance(), 0.15, 1e-12);
  for (const auto& o : cat.objects) EXPECT_NEAR(maxPushOffset(o.footprint, "-x"), 0.02, 1e-12);
  EXPECT_NEAR(cat.robot_radius, 0.035, 1e-3);
}

TEST(SetupCatalogue, ShapesGiveTheirOwnPushGeometry) {
  const Footprint long_box = Footprint::rectangle(0.08, 0.03), disc = Footprint::disc(0.025);
  EXPECT_DOUBLE_EQ(long_box.depth("-x"), 0.04);
  EXPECT_DOUBLE_EQ(long_box.depth("+y"), 0.015);
  EXPECT_DOUBLE_EQ(maxPushOffset(long_box, "-x"), 0.015);  // across the narrow face
  EXPECT_DOUBLE_EQ(maxPushOffset(long_box, "-y"), 0.04);   // across the long face
  EXPECT_DOUBLE_EQ(maxPushOffset(disc, "+x"), 0.0125);     // half the radius
  EXPECT_NEAR(long_box.signedDistance(0.05, 0), 0.01, 1e-12);
  EXPECT_NEAR(disc.signedDistance(0, 0), -0.025, 1e-12);
  double hx = 0, hy = 0;
  worldHalfExtents(long_box, M_PI / 2, hx, hy);
  EXPECT_NEAR(hx, 0.015, 1e-12);
  EXPECT_NEAR(hy, 0.04, 1e-12);
}

TEST(SetupCatalogue, RestrictingToAnUnknownObjectNamesItAndTheWorldFile) {
  const std::string file = std::string(XPERSIF_SOURCE_DIR) + "/worlds/default.yaml";
  const SetupCatalogue cat = SetupCatalogue::fromScene(sceneOf(file));
  const std::string first = cat.objects.front().name;
  EXPECT_EQ(cat.restrictedTo({first}, "~objects").names(), std::vector<std::string>{first});
  try {
    cat.restrictedTo({first, "no_such_thing"}, "~objects");
    FAIL() << "an unknown object was accepted";
  } catch (const ValidationError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("~objects"), std::string::npos) << what;
    EXPECT_NE(what.find("no_such_thing"), std::string::npos) << what;
    EXPECT_NE(what.find("default.yaml"), std::string::npos) << what;
  }
  EXPECT_THROW(cat.restrictedTo({}, "~objects"), ValidationError);
  EXPECT_THROW(cat.restrictedTo({first, first}, "~objects"), ValidationError);
  const std::string why = cat.checkExperiment("goal", {"no_such_thing", "-x", 0, 0.05});
  EXPECT_NE(why.find("no_such_thing"), std::string::npos) << why;
}

TEST(SetupCatalogue, ASceneWithoutObjectsOrRobotIsRefused) {
  SceneDescription scene = sceneOf(std::string(XPERSIF_SOURCE_DIR) + "/worlds/default.yaml");
  SceneDescription no_objects = scene;
  no_objects.objects.clear();
  EXPECT_THROW(SetupCatalogue::fromScene(no_objects), ValidationError);
  SceneDescription no_robot = scene;
  no_robot.robot_root = "";
  EXPECT_THROW(SetupCatalogue::fromScene(no_robot), ValidationError);
  SceneDescription bad_name = scene;
  bad_name.objects.push_back("ghost");
  EXPECT_THROW(SetupCatalogue::fromScene(bad_name), ValidationError);
}

// LOOPMODEL's tidy (issue 38's generated_42843, oracle seed 5): two objects to be moved each still stand where they
// are until moved; a spot is never beside either, and an arena with no room gives none rather than any.
TEST(ArenaTidy, AnObjectNotYetMovedStillStandsWhereItIs) {
  const double spacing = 0.19;
  int placed = 0;  // spots found: the checks below must have run
  for (std::uint64_t seed = 1; seed <= 50; ++seed) {
    xpersif::core::ArenaTidy tidy(0.3, 0.14, spacing);
    tidy.stands("orange_cube", -0.02, -0.01);
    tidy.stands("magenta_block", 0.07, -0.11);
    tidy.stands("cyan_bar", -0.24, 0.01);
    tidy.stands("blue_block", -0.15, -0.14);
    tidy.stands("(the robot)", 0.2, 0.1);
    std::mt19937_64 rng(seed);
    const auto orange = tidy.spotFor("orange_cube", rng);
    if (orange) {
      ++placed;
      EXPECT_GT(std::hypot(orange->first + 0.24, orange->second - 0.01), spacing) << "beside cyan_bar, seed " << seed;
      EXPECT_GT(std::hypot(orange->first - 0.2, orange->second - 0.1), spacing) << "on the robot, seed " << seed;
      EXPECT_LE(std::abs(orange->first), 0.3);
      EXPECT_LE(std::abs(orange->second), 0.14);
      tidy.stands("orange_cube", orange->first, orange->second);
    }
    const auto cyan = tidy.spotFor("cyan_bar", rng);
    if (cyan) {
      ++placed;
      const double ox = orange ? orange->first : -0.02, oy = orange ? orange->second : -0.01;
      EXPECT_GT(std::hypot(cyan->first - ox, cyan->second - oy), spacing) << "beside orange_cube, seed " << seed;
      EXPECT_GT(std::hypot(cyan->first + 0.15, cyan->second + 0.14), spacing) << "beside blue_block, seed " << seed;
    }
  }
  EXPECT_GE(placed, 20) << "the arena had room for too few spots to check";
}

TEST(ArenaTidy, ItsOwnPlaceDoesNotCountAndAFullArenaGivesNoSpot) {
  xpersif::core::ArenaTidy tidy(0.1, 0.1, 0.3);
  tidy.stands("red_cube", 0.0, 0.0);
  std::mt19937_64 rng(7);
  EXPECT_TRUE(tidy.spotFor("red_cube", rng).has_value()) << "its own place kept red_cube from every spot";
  EXPECT_FALSE(tidy.spotFor("blue_cube", rng).has_value()) << "a spot 0.3 m from red_cube inside ±0.1 m";
  tidy.stands("red_cube", 5.0, 5.0);  // moved far away: its old place is free
  EXPECT_TRUE(tidy.spotFor("blue_cube", rng).has_value());
}
