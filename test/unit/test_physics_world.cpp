// XPERSim's physics without ROS: stability, driving, pushing, IR, determinism, blow-up recovery, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>

#include <nlohmann/json.hpp>

#include "shipped_worlds.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

namespace {

WorldSpec defaultWorld() { return loadWorldFile(std::string(XPERSIF_SOURCE_DIR) + "/worlds/default.yaml"); }

void run(PhysicsWorld& world, double seconds) {
  const int steps = static_cast<int>(std::lround(seconds / world.spec().physics.step));
  for (int i = 0; i < steps; ++i) ASSERT_TRUE(world.step().ok);
}

Eigen::Isometry3d planar(double x, double y, double yaw, double z = 0.018) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(x, y, z);
  t.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return t;
}

}  // namespace

TEST(PhysicsWorld, BuildsTheSceneWithDynamicAndFixedNodes) {
  PhysicsWorld world(defaultWorld());
  const SceneDescription& scene = world.scene();
  int dynamic = 0;
  for (const auto& n : scene.nodes) dynamic += n.dynamic ? 1 : 0;
  EXPECT_EQ(dynamic, 7) << "base, two wheels and four cubes move on their own";
  EXPECT_GE(scene.nodes.size(), 15u) << "about 15 scene nodes for robot and cubes, as in the paper";
  ASSERT_NE(scene.findNode("overhead_optical"), nullptr);
  EXPECT_EQ(scene.findNode("robot_camera_optical")->parent, "camera_link");
  EXPECT_EQ(world.dynamicTransforms().size(), 7u);
  EXPECT_NO_THROW(worldTransforms(scene, world.dynamicTransforms()));
}

TEST(PhysicsWorld, RestsStablyWhenNothingIsCommanded) {
  PhysicsWorld world(defaultWorld());
  const Eigen::Isometry3d robot0 = world.bodyPose("khepera"), cube0 = world.bodyPose("red_cube");
  run(world, 2.0);
  EXPECT_LT((world.bodyPose("khepera").translation() - robot0.translation()).norm(), 0.002);
  EXPECT_LT((world.bodyPose("red_cube").translation() - cube0.translation()).norm(), 0.001);
  EXPECT_NEAR(world.time(), 2.0, 1e-9);
  EXPECT_EQ(world.stepCount(), 1000u);
  EXPECT_EQ(world.checkHealth(), "");
}

TEST(PhysicsWorld, DrivesStraightAndTurnsAndOdometryFollows) {
  PhysicsWorld world(defaultWorld());
  const Eigen::Vector3d start = world.bodyPose("khepera").translation();
  world.setVelocity(0.1, 0.0);
  run(world, 1.0);
  const Eigen::Vector3d moved = world.bodyPose("khepera").translation() - start;
  EXPECT_NEAR(moved.x(), 0.1, 0.02);
  EXPECT_NEAR(moved.y(), 0.0, 0.005);
  const auto odom = world.odometry();
  EXPECT_NEAR(odom.x, world.bodyPose("khepera").translation().x(), 0.01);
  EXPECT_NEAR(odom.linear, 0.1, 0.01);

  world.setVelocity(0.0, 1.0);
  const double yaw0 = yawOf(world.bodyPose("khepera"));
  run(world, 1.0);
  EXPECT_NEAR(yawOf(world.bodyPose("khepera")) - yaw0, 1.0, 0.2);
  EXPECT_NEAR(world.odometry().yaw, yawOf(world.bodyPose("khepera")), 0.1);
}

TEST(PhysicsWorld, PushMovesALightCubeButNotTheHeavyOne) {
  PhysicsWorld world(defaultWorld());
  // Red cube (20 g) at (0.05, 0.15): start 8 cm behind it, facing +x, and drive into it.
  world.setPose("khepera", planar(-0.03, 0.15, 0.0));
  const Eigen::Vector3d red0 = world.bodyPose("red_cube").translation();
  world.setVelocity(0.08, 0.0);
  run(world, 2.0);
  const Eigen::Vector3d red_moved = world.bodyPose("red_cube").translation() - red0;
  EXPECT_GT(red_moved.x(), 0.05) << "the light cube is pushed along +x";
  EXPECT_LT(std::fabs(red_moved.y()), 0.03);

  // Blue cube (2 kg) at (0.25, 0): the robot's wheels slip, the cube stays.
  world.setPose("khepera", planar(0.17, 0.0, 0.0));
  const Eigen::Vector3d blue0 = world.bodyPose("blue_cube").translation();
  run(world, 2.0);
  EXPECT_LT((world.bodyPose("blue_cube").translation() - blue0).norm(), 0.002) << "the heavy cube does not move";
}

TEST(PhysicsWorld, IrSensorsSeeANearbyWall) {
  PhysicsWorld world(defaultWorld());
  // Wall at x = 0.45; the body's front is 3.5 cm ahead of its centre.
  world.setPose("khepera", planar(0.45 - 0.035 - 0.03, -0.2, 0.0));
  run(world, 0.05);
  const auto ranges = world.irRanges();
  ASSERT_EQ(ranges.size(), 8u);
  EXPECT_NEAR(ranges[2], 0.03, 0.004) << "front sensors (+-10 deg) see the wall 3 cm away";
  EXPECT_NEAR(ranges[3], 0.03, 0.004);
  EXPECT_DOUBLE_EQ(ranges[6], 0.06) << "rear sensors see nothing within range";
}

TEST(PhysicsWorld, SameSeedAndCommandsGiveBitIdenticalTrajectories) {
  PhysicsWorld a(defaultWorld()), b(defaultWorld());
  for (int i = 0; i < 3000; ++i) {
    // Interleaved stepping: each world keeps its own solver seed.
    const double turn = std::sin(i * 0.003);
    a.setVelocity(0.1, turn);
    b.setVelocity(0.1, turn);
    ASSERT_TRUE(a.step().ok);
    ASSERT_TRUE(b.step().ok);
  }
  for (const auto& name : a.spec().bodyNames()) {
    const Eigen::Isometry3d pa = a.bodyPose(name), pb = b.bodyPose(name);
    EXPECT_EQ(std::memcmp(pa.data(), pb.data(), sizeof(double) * 16), 0) << name;
  }
  // After a reset the world replays the same trajectory.
  const Eigen::Isometry3d first = a.bodyPose("khepera");
  a.reset();
  for (int i = 0; i < 3000; ++i) {
    a.setVelocity(0.1, std::sin(i * 0.003));
    ASSERT_TRUE(a.step().ok);
  }
  EXPECT_EQ(std::memcmp(a.bodyPose("khepera").data(), first.data(), sizeof(double) * 16), 0);
}

TEST(PhysicsWorld, BlowUpIsUndoneAndResolvedAndTimeGoesOn) {
  PhysicsWorld world(defaultWorld());
  run(world, 0.1);
  const Eigen::Isometry3d before = world.bodyPose("green_cube");
  const double t = world.time();
  world.injectFault("green_cube");  // a NaN force
  const auto result = world.step();
  EXPECT_FALSE(result.ok);
  EXPECT_FALSE(result.halted);
  EXPECT_NE(result.problem.find("green_cube has a non-finite"), std::string::npos) << result.problem;
  EXPECT_NE(result.problem.find("the step was undone and green_cube put at rest at its last good pose"), std::string::npos)
      << result.problem;
  EXPECT_EQ(world.checkHealth(), "");
  EXPECT_LT((world.bodyPose("green_cube").translation() - before.translation()).norm(), 1e-5);
  EXPECT_LT(world.bodyLinearVelocity("green_cube").norm(), 0.01);
  EXPECT_NEAR(world.time(), t + world.spec().physics.step, 1e-12) << "the step is taken again, resolved";

  world.injectFault("khepera", true);  // an absurd force: too fast
  const auto exploded = world.step();
  EXPECT_FALSE(exploded.ok);
  EXPECT_NE(exploded.problem.find(" m/s (physics.max_speed 5"), std::string::npos) << exploded.problem;
  EXPECT_NE(exploded.problem.find("the robot khepera put at rest"), std::string::npos) << exploded.problem;
  run(world, 0.1);  // and the world goes on
}

TEST(PhysicsWorld, ACubeDroppedFromFiveMetresFallsAndLandsWithoutABlowUp) {
  PhysicsWorld world(defaultWorld());
  Eigen::Isometry3d high = world.bodyPose("red_cube");
  const Eigen::Vector3d start = high.translation();
  high.translation().z() = 5.0;
  world.setPose("red_cube", high);
  // About 1 s of fall, reaching ~9.9 m/s, twice physics.max_speed: a legal state, simulated step by step.
  double fastest = 0;
  for (int i = 0; i < 1500; ++i) {
    const auto r = world.step();
    ASSERT_TRUE(r.ok) << "step " << i << ": " << r.problem;
    fastest = std::max(fastest, world.bodyLinearVelocity("red_cube").norm());
  }
  EXPECT_GT(fastest, 9.0) << "it fell freely";
  const Eigen::Vector3d landed = world.bodyPose("red_cube").translation();
  EXPECT_NEAR(landed.z(), 0.02, 0.002) << "it rests on the floor";
  EXPECT_LT((landed.head<2>() - start.head<2>()).norm(), 0.05) << "near where it was dropped";
  EXPECT_LT(world.bodyLinearVelocity("red_cube").norm(), 0.01);
  EXPECT_NEAR(world.time(), 3.0, 1e-9);
  // Back at rest, the bound is physics.max_speed again: an absurd speed is still a blow-up.
  world.injectFault("red_cube", true);
  EXPECT_FALSE(world.step().ok);
}

TEST(PhysicsWorld, BlowUpsThatDoNotStopHaltTheWorldInsteadOfRepeatingForever) {
  // Ten blow-ups in ten consecutive steps: the world halts, at rest, and says so.
  PhysicsWorld world(defaultWorld());
  PhysicsWorld::StepResult r;
  int steps = 0;
  for (; steps < 20 && !r.halted; ++steps) {
    world.injectFault("green_cube");
    r = world.step();
    EXPECT_FALSE(r.ok);
  }
  EXPECT_TRUE(r.halted);
  EXPECT_EQ(steps, 10);
  EXPECT_NE(r.problem.find("blew up in 10 steps in a row"), std::string::npos) << r.problem;
  EXPECT_TRUE(world.step().ok) << "nothing is wrong any more: it goes on";

  // A world where moving at all is a blow-up (no gravity, a tiny max_speed) and the robot is driven: at rest
  // the motors blow it up again, so it halts at once with the reason.
  WorldSpec spec = defaultWorld();
  spec.physics.gravity = 0;
  spec.physics.max_speed = 1e-6;
  PhysicsWorld strict(spec);
  strict.setVelocity(0.1, 0);
  const double t = strict.time();
  const auto halted = strict.step();
  EXPECT_FALSE(halted.ok);
  EXPECT_TRUE(halted.halted);
  EXPECT_NE(halted.problem.find("it blows up even with every body at rest"), std::string::npos) << halted.problem;
  EXPECT_DOUBLE_EQ(strict.time(), t) << "a halted step does not advance time";
  for (const auto& name : strict.spec().bodyNames()) EXPECT_EQ(strict.bodyLinearVelocity(name).norm(), 0.0) << name;
}

TEST(PhysicsWorld, PlacementsIntoAnotherBodyOutsideTheArenaOrUnderTheFloorAreRefused) {
  PhysicsWorld world(defaultWorld());
  run(world, 0.05);
  std::map<std::string, Eigen::Isometry3d> before;
  for (const auto& name : world.spec().bodyNames()) before[name] = world.bodyPose(name);
  const Eigen::Isometry3d blue = world.bodyPose("blue_cube");
  using Problem = PhysicsWorld::PlacementCheck::Problem;

  auto refused = [&](const std::string& body, const Eigen::Isometry3d& pose, Problem problem, const std::string& words,
                     bool on_floor = false) {
    const auto check = world.checkPlacement(body, pose, on_floor);
    EXPECT_EQ(check.problem, problem) << body << ": " << check.why;
    EXPECT_NE(check.why.find(words), std::string::npos) << check.why;
    try {
      world.setPose(body, pose, on_floor);
      ADD_FAILURE() << body << " was placed";
    } catch (const ValidationError& e) {
      EXPECT_EQ(std::string(e.what()), check.why);
    }
  };
  // Into the blue cube, half into it, into the robot; the robot into a cube.
  refused("red_cube", blue, Problem::Overlap, "red_cube at (0.25, ");
  refused("red_cube", blue, Problem::Overlap, "would overlap blue_cube by 40 mm");
  Eigen::Isometry3d half = blue;
  half.translation().x() -= 0.02;
  refused("green_cube", half, Problem::Overlap, "would overlap blue_cube by 20 mm");
  Eigen::Isometry3d on_robot = world.bodyPose("khepera");
  on_robot.translation().z() = 0.03;
  refused("yellow_cube", on_robot, Problem::Overlap, "would overlap the robot khepera");
  refused("khepera", blue, Problem::Overlap, "the robot khepera at (0.25, ", true);
  // Outside the walls (the centre inside, an edge outside), under the floor, too high.
  Eigen::Isometry3d edge = blue;
  edge.translation().x() = world.spec().arena.size_x / 2 - 0.01;
  refused("red_cube", edge, Problem::Invalid, "outside the arena (inside its walls |x| <= 0.45, |y| <= 0.3)");
  Eigen::Isometry3d sunk = before["red_cube"];
  sunk.translation().z() = 0.0;
  refused("red_cube", sunk, Problem::Invalid, "would reach 20 mm under the floor; at this orientation its origin must be at z >= 0.02");
  Eigen::Isometry3d tilted = before["red_cube"];
  tilted.linear() = Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitX()).toRotationMatrix();
  refused("red_cube", tilted, Problem::Invalid, "under the floor; at this orientation its origin must be at z >= 0.028");
  Eigen::Isometry3d sky = before["red_cube"];
  sky.translation().z() = 11.0;
  refused("red_cube", sky, Problem::Invalid, "m above the floor; at most 10 m");
  // Nothing moved, bit for bit.
  for (const auto& [name, pose] : before) {
    EXPECT_EQ(std::memcmp(world.bodyPose(name).data(), pose.data(), sizeof(double) * 16), 0) << name;
  }

  // Allowed: on top of the blue cube, touching a neighbour, set down on the floor whatever z says.
  Eigen::Isometry3d on_top = blue;
  on_top.translation().z() = 0.0601;
  EXPECT_TRUE(world.checkPlacement("red_cube", on_top).ok()) << world.checkPlacement("red_cube", on_top).why;
  Eigen::Isometry3d beside = blue;
  beside.translation().y() += 0.0405;
  EXPECT_TRUE(world.checkPlacement("red_cube", beside).ok()) << world.checkPlacement("red_cube", beside).why;
  world.setPose("red_cube", sunk, true);
  EXPECT_NEAR(world.bodyPose("red_cube").translation().z(), 0.0201, 1e-6);
  Eigen::Isometry3d robot = world.bodyPose("khepera");
  robot.translation() += Eigen::Vector3d(0, 0.1, 0.5);
  world.setPose("khepera", robot, true);
  EXPECT_NEAR(world.bodyPose("khepera").translation().z(), before["khepera"].translation().z(), 5e-4)
      << "the robot set down as it starts";
  run(world, 0.5);
  EXPECT_EQ(world.checkHealth(), "");
}

TEST(PhysicsWorld, BadInputIsRefusedAndChangesNothing) {
  PhysicsWorld world(defaultWorld());
  const Eigen::Isometry3d red = world.bodyPose("red_cube");
  EXPECT_THROW(world.setPose("purple_cube", planar(0, 0, 0)), ValidationError);
  EXPECT_THROW(world.setPose("red_cube", planar(NAN, 0, 0)), ValidationError);
  EXPECT_THROW(world.setPose("red_cube", planar(3.0, 0, 0)), ValidationError);
  Eigen::Isometry3d skewed = planar(0, 0, 0);
  skewed.linear() *= 2.0;
  EXPECT_THROW(world.setPose("red_cube", skewed), ValidationError);
  EXPECT_TRUE(world.bodyPose("red_cube").isApprox(red));
  EXPECT_THROW(world.setVelocity(INFINITY, 0), ValidationError);
  EXPECT_THROW(world.bodyPose("nobody"), ValidationError);
  world.setWheelSpeeds(100, -100);
  EXPECT_DOUBLE_EQ(world.wheels().left_command, 0.5) << "wheel speeds are clamped to max_wheel_speed";
  EXPECT_DOUBLE_EQ(world.wheels().right_command, -0.5);
}

// Every file in worlds/ loads, builds, and rests: after a second of simulated time every object is finite,
// inside the arena and on the floor (balls included: their spin is damped), and the scene lists it.
TEST(PhysicsWorld, EveryShippedWorldLoadsBuildsAndSettles) {
  const std::vector<std::string> files = shippedWorldFiles();
  EXPECT_GE(files.size(), 3u) << "default, mixed and large";
  for (const auto& file : files) {
    SCOPED_TRACE(file);
    WorldSpec spec;
    ASSERT_NO_THROW(spec = loadWorldFile(file));
    PhysicsWorld world(spec);
    EXPECT_EQ(world.scene().objects.size(), spec.objects.size());
    for (const auto& o : spec.objects) {
      const auto& listed = world.scene().objects;
      EXPECT_NE(std::find(listed.begin(), listed.end(), o.name), listed.end()) << o.name;
    }
    run(world, 1.0);
    EXPECT_EQ(world.checkHealth(), "");
    const double hx = spec.arena.size_x / 2, hy = spec.arena.size_y / 2;
    for (const auto& o : spec.objects) {
      const Eigen::Vector3d p = world.bodyPose(o.name).translation();
      ASSERT_TRUE(p.allFinite()) << o.name;
      EXPECT_LT(std::abs(p.x()), hx) << o.name;
      EXPECT_LT(std::abs(p.y()), hy) << o.name;
      const double rest_height = o.shape.type == Shape::Type::Box ? o.shape.box_size.z() / 2
                                 : o.shape.type == Shape::Type::Sphere ? o.shape.radius
                                                                       : o.shape.length / 2;
      EXPECT_NEAR(p.z(), rest_height, 0.002) << o.name << " is not on the floor";
      EXPECT_LT(world.bodyLinearVelocity(o.name).norm(), 0.005) << o.name << " still moves";
      EXPECT_LT((p.head<2>() - o.pose.translation().head<2>()).norm(), 0.003) << o.name << " drifted";
    }
    EXPECT_LT(std::abs(world.bodyPose(spec.robot.name).translation().z()), 0.1);
  }
}

// Looking straight down, a world camera sees the arena and its walls: its footprint on the floor,
// width * h / fx by height * h / fy, covers them.
TEST(PhysicsWorld, EveryShippedWorldsOverheadCameraSeesTheWholeArena) {
  for (const auto& entry : std::filesystem::directory_iterator(std::string(XPERSIF_SOURCE_DIR) + "/worlds")) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    const WorldSpec spec = loadWorldFile(entry.path().string());
    int overhead = 0;
    for (const auto& c : spec.cameras) {
      const Eigen::Vector3d look = c.parent_from_optical.rotation() * Eigen::Vector3d::UnitZ();
      if (c.parent != "world" || look.z() > -0.999) continue;
      ++overhead;
      const Eigen::Vector3d at = c.parent_from_optical.translation();
      const double h = at.z(), t = spec.arena.wall_thickness;
      EXPECT_GE(c.model.width * h / c.model.fx / 2 - std::abs(at.x()), spec.arena.size_x / 2 + t);
      EXPECT_GE(c.model.height * h / c.model.fy / 2 - std::abs(at.y()), spec.arena.size_y / 2 + t);
    }
    EXPECT_GE(overhead, 1);
  }
}

// The second robot (urdf/boxbot.urdf, root link `chassis`) drives like the first: any differential drive.
TEST(PhysicsWorld, ABoxBodiedRobotWithAnotherRootLinkDrives) {
  PhysicsWorld world(loadWorldFile(std::string(XPERSIF_SOURCE_DIR) + "/worlds/large.yaml"));
  ASSERT_EQ(world.spec().robot.links[0].name, "chassis");
  EXPECT_NEAR(world.spec().robot.wheel_radius, 0.01, 1e-12);
  EXPECT_NEAR(world.spec().robot.wheel_separation, 0.07, 1e-12);
  const Eigen::Vector3d start = world.bodyPose("boxbot").translation();
  world.setVelocity(0.1, 0.0);
  run(world, 1.0);
  const Eigen::Vector3d moved = world.bodyPose("boxbot").translation() - start;
  EXPECT_NEAR(moved.x(), 0.1, 0.02);
  EXPECT_NEAR(moved.y(), 0.0, 0.005);
  world.setVelocity(0.0, 1.0);
  const double yaw0 = yawOf(world.bodyPose("boxbot"));
  run(world, 1.0);
  EXPECT_NEAR(yawOf(world.bodyPose("boxbot")) - yaw0, 1.0, 0.2);
  EXPECT_EQ(world.checkHealth(), "");
}

// A ball pushed away rolls, then comes to rest (ODE alone would let it roll forever).
TEST(PhysicsWorld, APushedBallComesToRest) {
  PhysicsWorld world(loadWorldFile(std::string(XPERSIF_SOURCE_DIR) + "/worlds/mixed.yaml"));
  // orange_ball at (-0.12, -0.15): start 6 cm behind it, drive into it for a second, then stop.
  world.setPose("khepera", planar(-0.18, -0.15, 0.0));
  const Eigen::Vector3d ball0 = world.bodyPose("orange_ball").translation();
  world.setVelocity(0.1, 0.0);
  run(world, 1.0);
  world.setVelocity(-0.1, 0.0);
  run(world, 0.5);
  world.setVelocity(0.0, 0.0);
  EXPECT_GT((world.bodyPose("orange_ball").translation() - ball0).norm(), 0.03) << "the push moved the ball";
  run(world, 4.0);  // the spin decays at 3/s, rolling at about 0.9/s (the ball's own inertia goes with it)
  EXPECT_LT(world.bodyLinearVelocity("orange_ball").norm(), 0.005);
  EXPECT_LT(world.bodyAngularVelocity("orange_ball").norm(), 0.3);
  const Eigen::Vector3d ball = world.bodyPose("orange_ball").translation();
  EXPECT_LT(std::abs(ball.x()), 0.45);
  EXPECT_NEAR(ball.z(), 0.02, 0.002);
}

// The long bar of mixed.yaml turns when pushed off its centre, and slides straight when pushed at it.
TEST(PhysicsWorld, ALongBarPushedOffCentreTurns) {
  const auto yawAfterPush = [](double offset) {
    PhysicsWorld world(loadWorldFile(std::string(XPERSIF_SOURCE_DIR) + "/worlds/mixed.yaml"));
    // magenta_bar (8 cm along x) at (0.06, 0): push it towards +y, 3 cm off its centre or at it.
    world.setPose("khepera", planar(0.06 + offset, -0.08, M_PI / 2));
    world.setVelocity(0.08, 0.0);
    run(world, 1.5);
    world.setVelocity(0.0, 0.0);
    run(world, 0.5);
    EXPECT_GT(world.bodyPose("magenta_bar").translation().y(), 0.03) << "the push moved the bar";
    return yawOf(world.bodyPose("magenta_bar"));
  };
  EXPECT_GT(std::abs(yawAfterPush(0.03)), 0.2);
  EXPECT_LT(std::abs(yawAfterPush(0.0)), 0.05);
}

// ---- friction: the Coulomb model, per-axis friction, frictions redrawn per contact episode ---------------

namespace {

/// A world of the default one's robot and arena with the objects of @p objects (YAML list).
WorldSpec worldWith(const std::string& objects, const std::string& physics = "") {
  return parseWorld("physics: {step: 0.002, iterations: 20" + physics +
                        "}\nrobot: {urdf: ../urdf/khepera.urdf, pose: {x: -0.3}, ir_sensors: [ir_0]}\nobjects: " + objects +
                        "\n",
                    std::string(XPERSIF_SOURCE_DIR) + "/worlds", "test.yaml");
}

/// The robot starts with its centre 7.5 cm behind (x, y) facing @p yaw, drives into it at 8 cm/s for @p seconds,
/// and backs off for half a second.
void driveInto(PhysicsWorld& world, double x, double y, double yaw, double seconds) {
  world.setPose("khepera", planar(x - 0.075 * std::cos(yaw), y - 0.075 * std::sin(yaw), yaw));
  world.setVelocity(0.08, 0.0);
  run(world, seconds);
  world.setVelocity(-0.08, 0.0);
  run(world, 0.5);
  world.setVelocity(0.0, 0.0);
  run(world, 0.1);
}

}  // namespace

// A cube pushed open loop by the robot 1.5 cm off its centre: with friction opposing the slip (coulomb) it
// turns by tens of degrees; with ODE's friction pyramid it hardly turns, because the floor holds it across the
// slide (bench/contact.md has both over every offset).
TEST(PhysicsWorld, CoulombFrictionTurnsACubePushedOffCentreAndThePyramidHardly) {
  const auto turn = [](const std::string& model) {
    PhysicsWorld world(worldWith("[{name: cube, size: 0.04, mass: 0.02, friction: 0.4}]", ", friction_model: " + model));
    driveInto(world, 0.0, 0.015, 0.0, 1.5);
    EXPECT_GT(world.bodyPose("cube").translation().x(), 0.05) << model << ": the push moved the cube";
    return yawOf(world.bodyPose("cube"));
  };
  const double coulomb = turn("coulomb"), pyramid = turn("pyramid");
  EXPECT_LT(coulomb, -20 * M_PI / 180) << "pushed left of its centre, it turns clockwise";
  EXPECT_GT(std::abs(coulomb), 4 * std::abs(pyramid));
}

// A sled on runners (friction 0.1 along its x axis, 3 across): the robot pushes it along its length, not across
// it, and the axes turn with the sled.
TEST(PhysicsWorld, FrictionAlongAndAcrossAnObjectsAxes) {
  const auto moved = [](double yaw, double push_direction) {
    WorldSpec spec = worldWith("[{name: sled, size: [0.06, 0.04, 0.03], mass: 0.05, friction: [0.1, 3.0], pose: {yaw: " +
                               std::to_string(yaw) + "}}]");
    PhysicsWorld world(spec);
    const Eigen::Vector3d before = world.bodyPose("sled").translation();
    driveInto(world, 0.0, 0.0, push_direction, 1.5);
    return (world.bodyPose("sled").translation() - before).norm();
  };
  EXPECT_GT(moved(0.0, 0.0), 0.05) << "pushed along its runners, it slides";
  EXPECT_LT(moved(0.0, M_PI / 2), 0.01) << "pushed across them, the robot cannot move it";
  EXPECT_LT(moved(M_PI / 2, 0.0), 0.01) << "turned by 90 degrees, world x is across its runners";
  EXPECT_GT(moved(M_PI / 2, M_PI / 2), 0.05);
}

// A redrawn friction: one draw per contact episode (a touch after contact_episode_gap without one), in the
// file's range, from the redraw seed: the same seed gives the same draws, after reset() too; another seed others.
TEST(PhysicsWorld, FrictionIsRedrawnPerContactEpisodeFromTheSeed) {
  const WorldSpec spec = worldWith("[{name: cube, size: 0.04, mass: 0.02, friction: 0.5, friction_redraw: [0.1, 2.0]}, "
                                   "{name: plain, size: 0.04, mass: 0.02, friction: 0.4, pose: {y: 0.2}}]");
  const auto draws = [&](PhysicsWorld& world, int pushes) {
    std::vector<double> out;
    for (int i = 0; i < pushes; ++i) {
      const Eigen::Vector3d at = world.bodyPose("cube").translation();
      driveInto(world, at.x(), at.y(), 0.0, 0.6);  // touches it for about 0.35 s
      run(world, 0.5);                             // more than contact_episode_gap away
      out.push_back(world.objectFriction("cube"));
      EXPECT_EQ(world.contactEpisodes("cube"), i + 1);
      world.setPose("cube", planar(0.0, 0.0, 0.0, 0.02));
    }
    return out;
  };
  PhysicsWorld a(spec), b(spec);
  EXPECT_DOUBLE_EQ(a.objectFriction("cube"), 0.5) << "the file's friction until the first touch";
  EXPECT_EQ(a.redrawSeed(), 1u) << "physics.seed by default";
  const std::vector<double> first = draws(a, 5);
  for (double f : first) {
    EXPECT_GE(f, 0.1);
    EXPECT_LE(f, 2.0);
  }
  EXPECT_GT(*std::max_element(first.begin(), first.end()) / *std::min_element(first.begin(), first.end()), 1.5)
      << "the draws differ from push to push";
  EXPECT_EQ(draws(b, 5), first) << "the same seed gives the same draws";
  for (std::size_t k = 0; k < first.size(); ++k) {
    EXPECT_DOUBLE_EQ(first[k], redrawnFriction(spec.objects[0], 1, 0, static_cast<int>(k) + 1)) << "draw " << k + 1;
  }
  EXPECT_DOUBLE_EQ(a.objectFriction("plain"), 0.4) << "an object without friction_redraw keeps its friction";
  EXPECT_EQ(a.contactEpisodes("plain"), 0);

  a.reset();
  EXPECT_EQ(a.contactEpisodes("cube"), 0);
  EXPECT_DOUBLE_EQ(a.objectFriction("cube"), 0.5);
  EXPECT_EQ(draws(a, 5), first) << "after a reset the draws start again";

  PhysicsWorld c(spec);
  c.setRedrawSeed(7);
  EXPECT_NE(draws(c, 5), first) << "another seed, other draws";

  // A long push is one episode, however its contact flickers; touches closer than the gap are the same episode.
  PhysicsWorld d(spec);
  d.setPose("khepera", planar(-0.075, 0.0, 0.0));
  d.setVelocity(0.08, 0.0);
  run(d, 2.0);
  EXPECT_EQ(d.contactEpisodes("cube"), 1);
  const double during = d.objectFriction("cube");
  d.setVelocity(-0.08, 0);
  run(d, 0.1);
  d.setVelocity(0.08, 0);
  run(d, 0.5);
  EXPECT_EQ(d.contactEpisodes("cube"), 1) << "back off for 0.1 s and on again: the same push";
  EXPECT_DOUBLE_EQ(d.objectFriction("cube"), during);
  EXPECT_THROW(d.objectFriction("khepera"), ValidationError);
  EXPECT_THROW(d.contactEpisodes("nothing"), ValidationError);
}

// ---- world states: a checkpoint taken mid-push, restored into another world of the spec, continues bit for bit ----

namespace {

/// The robot 7.5 cm behind the world's first object, driving into it (contacts, moving bodies, maybe a redraw).
void startPushingFirstObject(PhysicsWorld& world) {
  const Eigen::Vector3d at = world.bodyPose(world.spec().objects.at(0).name).translation();
  const std::string robot = world.spec().robot.name;
  for (double behind = 0.05;; behind += 0.005) {  // the nearest free place behind it, whatever the sizes
    ASSERT_LT(behind, 0.3) << "no free place behind " << world.spec().objects[0].name;
    if (world.checkPlacement(robot, planar(at.x() - behind, at.y() + 0.01, 0.0), true).ok()) {
      world.setPose(robot, planar(at.x() - behind, at.y() + 0.01, 0.0), true);
      break;
    }
  }
  world.setVelocity(0.08, 0.05);
}

void goOn(PhysicsWorld& world, int steps) {
  for (int i = 0; i < steps; ++i) {
    world.setVelocity(i < steps / 2 ? 0.08 : -0.05, std::sin(i * 0.01));
    ASSERT_TRUE(world.step().ok);
  }
}

}  // namespace

TEST(PhysicsWorld, ACheckpointRestoredIntoAnotherWorldContinuesBitForBit) {
  for (const std::string& path : shippedWorldFiles()) {
    SCOPED_TRACE(path);
    const WorldSpec spec = loadWorldFile(path);
    PhysicsWorld a(spec);
    startPushingFirstObject(a);
    run(a, 0.6);  // mid-push: the robot and the object move and touch
    ASSERT_GT(a.bodyLinearVelocity(spec.objects[0].name).norm(), 1e-3) << "the checkpoint is taken mid-push";
    const std::string state = a.checkpoint();

    // Another world of the spec, with another history (other moves, so ODE's internal order differs).
    PhysicsWorld b(spec);
    b.setVelocity(-0.05, 1.0);
    run(b, 0.3);
    b.restoreState(state);
    // ODE normalises a quaternion it is given, which may change its last bit: the checkpoint restored its own
    // state for that reason, so both worlds hold the same normalised numbers.
    EXPECT_EQ(b.saveState(), a.saveState()) << "both worlds are in the same state";
    EXPECT_EQ(b.time(), a.time());
    EXPECT_EQ(b.stepCount(), a.stepCount());

    PhysicsWorld fresh(spec);  // as a restarted simulator: no history at all
    fresh.restoreState(state);

    goOn(a, 800);
    goOn(b, 800);
    goOn(fresh, 800);
    EXPECT_EQ(a.saveState(), b.saveState()) << "after 800 more steps of pushing and backing off";
    EXPECT_EQ(a.saveState(), fresh.saveState()) << "a fresh world, restored, after 800 more steps";
    for (const auto& name : spec.bodyNames()) {
      EXPECT_EQ(std::memcmp(a.bodyPose(name).data(), b.bodyPose(name).data(), sizeof(double) * 16), 0) << name;
    }
    EXPECT_EQ(a.objectFriction(spec.objects[0].name), b.objectFriction(spec.objects[0].name));
  }
}

TEST(PhysicsWorld, WhatHappensBetweenPlacementsDoesNotChangeThePhysics) {
  // XPERSim answers set_pose between ticks, and in lockstep an idle tick (which reads the IR sensors, a collision
  // query) may fall between two of them or not, as wall time has it: at a run's start LOOPMODEL arranges the
  // scene, one set_pose after another, then lets it settle. Neither which placements had a reading between them,
  // nor a placement that was refused, may change what the world then does.
  for (const std::string& path : shippedWorldFiles()) {
    SCOPED_TRACE(path);
    const WorldSpec spec = loadWorldFile(path);
    std::vector<std::string> order;  // the objects, the robot among them, and one object placed twice
    for (const auto& object : spec.objects) order.push_back(object.name);
    order.insert(order.begin() + static_cast<long>(order.size() / 2), spec.robot.name);
    order.push_back(spec.objects.front().name);
    auto campaign = [&](bool stepped, std::uint32_t sensed_before) {
      PhysicsWorld world(spec);
      if (stepped) run(world, 0.1);  // else as built: every geom not yet through a collision pass
      for (std::size_t i = 0; i < order.size(); ++i) {
        if (sensed_before >> i & 1u) {
          world.irRanges();
          // A refused placement of the robot onto an object is checked without moving anything.
          const std::string before = world.saveState();
          EXPECT_FALSE(world.checkPlacement(spec.robot.name, world.bodyPose(spec.objects.back().name), true).ok());
          EXPECT_EQ(world.saveState(), before) << "a refused placement of the robot before placing " << order[i];
        }
        world.setPose(order[i], world.bodyPose(order[i]), true);  // set down where it stands
      }
      std::vector<std::string> states{world.saveState()};
      run(world, 0.5);  // the scene settles
      states.push_back(world.saveState());
      startPushingFirstObject(world);
      goOn(world, 800);
      states.push_back(world.saveState());
      return states;
    };
    const std::vector<std::string> stages{"placed", "settled", "pushed and backed off"};
    for (bool stepped : {false, true}) {
      const auto quiet = campaign(stepped, 0);
      for (std::uint32_t sensed : {~0u, 0x55555555u, 0xaaaaaaaau, 1u << (order.size() / 2)}) {
        const auto busy = campaign(stepped, sensed);
        for (std::size_t k = 0; k < stages.size(); ++k) {
          EXPECT_EQ(quiet[k], busy[k]) << stages[k] << (stepped ? ", in a world that had stepped" : ", in a new world")
                                       << ", IR read before placements 0x" << std::hex << sensed;
        }
      }
    }
  }
}

TEST(PhysicsWorld, ACheckpointOfAnUnchangedWorldIsTheStateItIsIn) {
  // A run whose knowledge base refused a step's checkpoint is resumed from the world as it is, and checkpoints
  // it again: that must be the same state, and must not touch the world, or the resumed run goes on from
  // other numbers than the uninterrupted one.
  for (const std::string& path : shippedWorldFiles()) {
    SCOPED_TRACE(path);
    const WorldSpec spec = loadWorldFile(path);
    PhysicsWorld a(spec);
    startPushingFirstObject(a);
    run(a, 0.6);
    const std::string first = a.checkpoint();
    const std::string after_first = a.saveState();
    EXPECT_EQ(a.checkpoint(), first) << "checkpointed again, unchanged";
    EXPECT_EQ(a.saveState(), after_first) << "a second checkpoint does not touch the world";

    PhysicsWorld b(spec);
    b.restoreState(first);
    EXPECT_EQ(b.checkpoint(), first) << "a restored world's checkpoint is the state it was restored from";

    // Any change ends it: a step, a wheel command, a pose.
    goOn(a, 1);
    EXPECT_NE(a.checkpoint(), first) << "after a step";
    const std::string stepped = a.checkpoint();
    const auto wheels = a.wheels();
    a.setWheelSpeeds(wheels.left_command, wheels.right_command);
    EXPECT_EQ(a.checkpoint(), stepped) << "the same wheel command again changes nothing";
    a.setVelocity(0.01, 0.0);
    EXPECT_NE(a.checkpoint(), stepped) << "after another wheel command";
  }
}

TEST(PhysicsWorld, AWorldStateThatIsNotOneOfThisWorldIsRefusedAndChangesNothing) {
  const WorldSpec spec = loadWorldFile(shippedWorldFiles().front());
  PhysicsWorld world(spec);
  startPushingFirstObject(world);
  run(world, 0.3);
  const std::string good = world.saveState();
  const auto with = [&](const std::function<void(nlohmann::json&)>& change) {
    nlohmann::json state = nlohmann::json::parse(good);
    change(state);
    return state.dump();
  };
  const std::string object = spec.objects[0].name;
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"", "not JSON"},
      {"{\"world\": ", "not JSON"},
      {"[1, 2]", "not a JSON object"},
      {with([](auto& s) { s["world"] = "elsewhere"; }), "of world 'elsewhere'"},
      {with([](auto& s) { s["step"] = 0.5; }), "physics step"},
      {with([](auto& s) { s.erase("time"); }), "'time'"},
      {with([](auto& s) { s["steps"] = -3; }), "'steps'"},
      {with([](auto& s) { s["bodies"].erase(0); }), "bodies"},
      {with([&](auto& s) { s["bodies"][0]["name"] = object; }), "body 0 is not"},
      {with([](auto& s) { s["bodies"][1]["position"] = {0, 0}; }), "position is not a list of 3 numbers"},
      {with([](auto& s) { s["bodies"][1]["position"][2] = "high"; }), "position[2] is not a finite number"},
      {with([](auto& s) { s["bodies"][1]["orientation"] = {2, 0, 0, 0}; }), "not a unit quaternion"},
      {with([](auto& s) { s["objects"] = nlohmann::json::array(); }), "objects"},
      {with([](auto& s) { s["objects"][0]["friction"] = {-1, 0.5}; }), "friction is negative"},
      {with([](auto& s) { s["objects"][0].erase("episodes"); }), "'episodes'"},
  };
  for (const auto& [text, words] : bad) {
    try {
      world.restoreState(text);
      ADD_FAILURE() << "accepted: " << text.substr(0, 200);
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
    EXPECT_EQ(world.saveState(), good) << "a refused state changes nothing";
  }
  // Numbers beyond double's range read as infinite: refused too.
  std::string huge = good;
  const std::size_t at = huge.find("\"time\":") + 7;
  huge.replace(at, huge.find(',', at) - at, "1e999");
  EXPECT_THROW(world.restoreState(huge), ValidationError);
  EXPECT_EQ(world.saveState(), good);
}

// Components choose their camera by its mount unless told a name: a world names its cameras as it likes.
TEST(PhysicsWorld, CamerasAreChosenByNameOrByMountWhateverTheWorldCallsThem) {
  for (const std::string& file : shippedWorldFiles()) {
    const SceneDescription scene = PhysicsWorld(loadWorldFile(file)).scene();
    std::string problem;
    const CameraModel* fixed = chooseCamera(scene, kFixedCamera, problem);
    ASSERT_NE(fixed, nullptr) << file << ": " << problem;
    EXPECT_FALSE(carriedByRobot(scene, *fixed)) << file;
    const CameraModel* on_robot = chooseCamera(scene, kCameraOnRobot, problem);
    ASSERT_NE(on_robot, nullptr) << file << ": " << problem;
    EXPECT_TRUE(carriedByRobot(scene, *on_robot)) << file;
  }
  WorldSpec spec = defaultWorld();
  ASSERT_EQ(spec.cameras.size(), 2u);
  for (CameraSpec& c : spec.cameras) {
    c.model.name = c.parent == "world" ? "top" : "front";
    c.model.frame = c.model.name + "_optical";
  }
  std::string problem;
  {
    const SceneDescription scene = PhysicsWorld(spec).scene();
    EXPECT_EQ(chooseCamera(scene, kFixedCamera, problem)->name, "top");
    EXPECT_EQ(chooseCamera(scene, kCameraOnRobot, problem)->name, "front");
    EXPECT_EQ(chooseCamera(scene, "front", problem)->name, "front");
    EXPECT_EQ(chooseCamera(scene, "overhead", problem), nullptr);
    EXPECT_NE(problem.find("top (fixed), front (on the robot)"), std::string::npos) << problem;
  }
  CameraSpec side = spec.cameras.front().parent == "world" ? spec.cameras.front() : spec.cameras.back();
  side.model.name = "side";
  side.model.frame = "side_optical";
  side.parent_from_optical.translation().x() += 0.5;
  spec.cameras.push_back(side);
  spec.cameras.erase(std::remove_if(spec.cameras.begin(), spec.cameras.end(),
                                    [](const CameraSpec& c) { return c.model.name == "front"; }),
                     spec.cameras.end());
  const SceneDescription scene = PhysicsWorld(spec).scene();
  EXPECT_EQ(chooseCamera(scene, kFixedCamera, problem), nullptr);
  EXPECT_NE(problem.find("has 2 cameras fixed in the arena"), std::string::npos) << problem;
  EXPECT_NE(problem.find("~camera/name"), std::string::npos) << problem;
  EXPECT_EQ(chooseCamera(scene, "side", problem)->name, "side");
  EXPECT_EQ(chooseCamera(scene, kCameraOnRobot, problem), nullptr);
  EXPECT_NE(problem.find("has no camera carried by the robot"), std::string::npos) << problem;
}
