// The motion core closed-loop on XPERSim's real physics: the controllers run every 20 ms of simulated time
// on the wheel odometry (as the RELOCATION / MANIPULATION nodelets do), physics steps in between, and the
// results are checked against the simulator's ground truth (bodyPose). Planners and bad input too.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <random>

#include "xpersif/core/motion/motion.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kControlPeriod = 0.02;
constexpr double kRobotRadius = 0.035;
const std::vector<std::string> kCubes{"red_cube", "green_cube", "blue_cube", "yellow_cube"};

WorldSpec defaultWorld() { return loadWorldFile(std::string(XPERSIF_SOURCE_DIR) + "/worlds/default.yaml"); }

Pose2D truth(const PhysicsWorld& world, const std::string& body = "khepera") {
  const Eigen::Isometry3d p = world.bodyPose(body);
  return {p.translation().x(), p.translation().y(), yawOf(p)};
}

Pose2D odometry(const PhysicsWorld& world) {
  const auto o = world.odometry();
  return {o.x, o.y, o.yaw};
}

ArenaGeometry arenaOf(const PhysicsWorld& world) { return {world.spec().arena.size_x, world.spec().arena.size_y}; }

std::vector<Obstacle> cubesOf(const PhysicsWorld& world) {
  std::vector<Obstacle> objects;
  for (const auto& o : world.spec().objects) {
    const Pose2D p = truth(world, o.name);
    objects.push_back({o.name, p.x, p.y, p.yaw, Footprint::ofShape(o.shape)});
  }
  return objects;
}

/// A square footprint of edge @p edge (the default world's cubes have 0.04 m).
Footprint square(double edge) { return Footprint::rectangle(edge, edge); }

/// One control period: @p command to the robot, then 20 ms of physics.
void applyAndStep(PhysicsWorld& world, const Velocity2D& command) {
  world.setVelocity(command.linear, command.angular);
  const int steps = static_cast<int>(std::lround(kControlPeriod / world.spec().physics.step));
  for (int i = 0; i < steps; ++i) ASSERT_TRUE(world.step().ok);
}

/// Run a motion controller on odometry until done/failed or @p limit seconds; returns the last feedback.
template <class Controller>
MotionFeedback runMotion(PhysicsWorld& world, Controller& controller, double limit) {
  MotionFeedback fb;
  const double t0 = world.time();
  while (world.time() - t0 < limit) {
    fb = controller.update(odometry(world), kControlPeriod);
    if (fb.done || fb.failed) break;
    applyAndStep(world, fb.command);
  }
  applyAndStep(world, Velocity2D{});  // let it settle on a zero command
  return fb;
}

double yawDiff(double a, double b) { return std::fabs(normalizeAngle(a - b)); }
double distance(const Pose2D& a, const Pose2D& b) { return std::hypot(a.x - b.x, a.y - b.y); }

}  // namespace

// (a) Random reachable poses in the free arena (cubes removed), one after the other from where the last
// move ended: odometry errors accumulate over the whole run, as they would in a session.
TEST(GoToPose, ReachesRandomPosesWithinOneCentimetreAndThreeDegreesOfGroundTruth) {
  WorldSpec spec = defaultWorld();
  spec.objects.clear();
  PhysicsWorld world(spec);
  GoToPoseController controller;
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> ux(-0.36, 0.36), uy(-0.21, 0.21), uyaw(-kPi, kPi);
  double worst_position = 0, worst_yaw = 0, worst_odom_position = 0, total_time = 0, longest = 0;
  const int kMoves = 32;
  for (int i = 0; i < kMoves; ++i) {
    const Pose2D goal{ux(rng), uy(rng), uyaw(rng)};
    controller.setGoal(goal);
    const double t0 = world.time();
    const MotionFeedback fb = runMotion(world, controller, 30.0);
    ASSERT_TRUE(fb.done) << "move " << i << ": " << fb.reason << " phase " << toString(fb.phase);
    const double took = world.time() - t0;
    total_time += took;
    longest = std::max(longest, took);
    const Pose2D real = truth(world);
    const double dp = distance(real, goal), dyaw = yawDiff(real.yaw, goal.yaw);
    worst_position = std::max(worst_position, dp);
    worst_yaw = std::max(worst_yaw, dyaw);
    worst_odom_position = std::max(worst_odom_position, distance(odometry(world), goal));
    if (std::getenv("MOTION_VERBOSE"))
      std::printf("move %d took %.2f truth err %.2f mm %.2f deg, odom-truth %.2f mm %.2f deg\n", i, took,
                  dp * 1000, dyaw * 180 / kPi, distance(odometry(world), real) * 1000,
                  yawDiff(odometry(world).yaw, real.yaw) * 180 / kPi);
    EXPECT_LT(dp, 0.01) << "move " << i;
    EXPECT_LT(dyaw, 3.0 * kPi / 180.0) << "move " << i;
  }
  std::printf("[ measured ] %d moves: worst ground-truth error %.2f mm, %.2f deg (odometry %.2f mm); "
              "mean %.2f s, longest %.2f s sim time\n",
              kMoves, worst_position * 1000, worst_yaw * 180 / kPi, worst_odom_position * 1000,
              total_time / kMoves, longest);
}

TEST(GoToPose, DrivesBackwardsToAShortTargetBehind) {
  PhysicsWorld world(defaultWorld());
  GoToPoseController controller;
  const Pose2D start = truth(world);
  controller.setGoal({start.x - 0.04, start.y, start.yaw});
  bool reversed = false;
  const double t0 = world.time();
  MotionFeedback fb;
  while (world.time() - t0 < 10.0) {
    fb = controller.update(odometry(world), kControlPeriod);
    if (fb.done || fb.failed) break;
    reversed = reversed || fb.command.linear < 0;
    applyAndStep(world, fb.command);
  }
  ASSERT_TRUE(fb.done) << fb.reason;
  EXPECT_TRUE(reversed) << "a 4 cm target straight behind is reached backwards, without turning around";
  EXPECT_LT(distance(truth(world), {start.x - 0.04, start.y, 0}), 0.01);
  EXPECT_LT(yawDiff(truth(world).yaw, start.yaw), 3.0 * kPi / 180.0);
}

TEST(Turn, TurnsInPlaceToAHeading) {
  PhysicsWorld world(defaultWorld());
  TurnController turn;
  const Pose2D start = truth(world);
  for (double yaw : {2.5, -1.0, 0.3}) {
    turn.setGoal(yaw);
    const MotionFeedback fb = runMotion(world, turn, 10.0);
    ASSERT_TRUE(fb.done) << fb.reason;
    EXPECT_LT(yawDiff(truth(world).yaw, yaw), 3.0 * kPi / 180.0) << yaw;
    EXPECT_LT(distance(truth(world), start), 0.005) << "turning in place keeps the position";
  }
}

// (b) Cancel: the command after stop() is zero, and the robot comes to rest.
TEST(Stop, NextCommandIsZeroAndTheRobotComesToRest) {
  PhysicsWorld world(defaultWorld());
  GoToPoseController controller;
  controller.setGoal({0.0, -0.05, 0.0});
  for (int i = 0; i < 50; ++i) applyAndStep(world, controller.update(odometry(world), kControlPeriod).command);
  ASSERT_GT(world.bodyLinearVelocity("khepera").norm(), 0.05) << "it is driving when stopped";
  controller.stop();
  const MotionFeedback fb = controller.update(odometry(world), kControlPeriod);
  EXPECT_EQ(fb.command.linear, 0.0);
  EXPECT_EQ(fb.command.angular, 0.0);
  EXPECT_EQ(fb.phase, MotionPhase::Stopped);
  EXPECT_FALSE(controller.active());
  const Pose2D at_stop = truth(world);
  applyAndStep(world, fb.command);  // one control period later
  const double speed_after_one_period = world.bodyLinearVelocity("khepera").norm();
  for (int i = 0; i < 25; ++i) applyAndStep(world, controller.update(odometry(world), kControlPeriod).command);
  EXPECT_LT(world.bodyLinearVelocity("khepera").norm(), 0.002) << "at rest";
  const double coast = distance(truth(world), at_stop);
  EXPECT_LT(coast, 0.005);
  std::printf("[ measured ] stop at 0.15 m/s: %.1f mm/s one control period later, coasted %.2f mm\n",
              speed_after_one_period * 1000, coast * 1000);

  // The other controllers stop the same way.
  PushController push;
  push.stop();
  EXPECT_EQ(push.update(odometry(world), kControlPeriod).command.linear, 0.0);
  PathFollower follower;
  follower.setPath({{0.2, 0.2, 0.0}});
  EXPECT_NE(follower.update(odometry(world), kControlPeriod).command.angular, 0.0);
  follower.stop();
  const MotionFeedback stopped = follower.update(odometry(world), kControlPeriod);
  EXPECT_EQ(stopped.command.linear, 0.0);
  EXPECT_EQ(stopped.command.angular, 0.0);
}

TEST(Controllers, RejectBadGoalsAndSettingsWithASentence) {
  GoToPoseController controller;
  try {
    controller.setGoal({std::nan(""), 0.0, 0.0});
    FAIL() << "a NaN goal is rejected";
  } catch (const ValidationError& e) {
    EXPECT_NE(std::string(e.what()).find("goal.x is NaN"), std::string::npos) << e.what();
  }
  EXPECT_EQ(controller.phase(), MotionPhase::Idle) << "a rejected goal changes nothing";
  EXPECT_THROW(controller.setGoal({0, 0, INFINITY}), ValidationError);
  EXPECT_THROW(controller.update({0, 0, 0}, 0.0), ValidationError);
  EXPECT_THROW(controller.update({0, NAN, 0}, 0.02), ValidationError);
  MotionLimits bad;
  bad.max_linear = -0.1;
  EXPECT_NE(bad.check().find("limits.max_linear"), std::string::npos) << bad.check();
  EXPECT_THROW(controller.setLimits(bad), ValidationError);
  EXPECT_THROW(GoToPoseController{bad}, ValidationError);
  TurnController turn;
  EXPECT_THROW(turn.setGoal(NAN), ValidationError);
  PathFollower follower;
  EXPECT_THROW(follower.setPath({}), ValidationError);
  PushController push;
  PushPlan not_ok;
  not_ok.reason = "whatever";
  EXPECT_THROW(push.start(not_ok), ValidationError);
  // An idle controller commands nothing.
  EXPECT_EQ(controller.update({0, 0, 0}, 0.02).command.linear, 0.0);
}

// (c) Path planning around the cubes, on the default world.
TEST(PathPlanning, ReachesGoalsBehindCubesWithoutTouchingThem) {
  PhysicsWorld world(defaultWorld());
  const std::vector<Obstacle> cubes = cubesOf(world);
  PathPlanner planner(arenaOf(world), kRobotRadius, 0.01);
  planner.setObstacles(cubes);
  PathFollower follower;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-0.4, 0.4), uy(-0.25, 0.25), uyaw(-kPi, kPi);
  std::vector<Pose2D> goals{{0.35, 0.0, kPi}, {0.05, 0.24, -kPi / 2}, {-0.1, -0.15, 0.0}};  // behind blue, red, green
  while (goals.size() < 12) {
    const Pose2D g{ux(rng), uy(rng), uyaw(rng)};
    if (planner.checkFree(g.x, g.y).empty()) goals.push_back(g);
  }
  double worst_position = 0, worst_yaw = 0, worst_cube = 0, total_time = 0;
  std::size_t most_waypoints = 0;
  for (std::size_t i = 0; i < goals.size(); ++i) {
    const PathResult path = planner.plan(odometry(world), goals[i]);
    ASSERT_TRUE(path.ok) << i << ": " << path.reason;
    most_waypoints = std::max(most_waypoints, path.waypoints.size());
    follower.setPath(path.waypoints);
    const double t0 = world.time();
    const MotionFeedback fb = runMotion(world, follower, 60.0);
    total_time += world.time() - t0;
    ASSERT_TRUE(fb.done) << i << ": " << fb.reason;
    const Pose2D real = truth(world);
    worst_position = std::max(worst_position, distance(real, goals[i]));
    worst_yaw = std::max(worst_yaw, yawDiff(real.yaw, goals[i].yaw));
    EXPECT_LT(distance(real, goals[i]), 0.01) << i;
    EXPECT_LT(yawDiff(real.yaw, goals[i].yaw), 3.0 * kPi / 180.0) << i;
    for (const auto& c : cubes) {
      const Pose2D now = truth(world, c.name);
      worst_cube = std::max(worst_cube, std::hypot(now.x - c.x, now.y - c.y));
      EXPECT_LT(std::hypot(now.x - c.x, now.y - c.y), 0.001) << c.name << " was touched on the way to goal " << i;
    }
  }
  std::printf("[ measured ] %zu planned moves among the cubes: worst %.2f mm, %.2f deg; cubes moved <= %.3f mm; "
              "up to %zu waypoints; mean %.2f s sim time\n",
              goals.size(), worst_position * 1000, worst_yaw * 180 / kPi, worst_cube * 1000, most_waypoints,
              total_time / goals.size());
  // The first goal, right behind the blue cube, needs a detour.
  EXPECT_GE(planner.plan({-0.3, 0.0, 0.0}, goals[0]).waypoints.size(), 2u);
}

TEST(PathPlanning, UnreachableGoalsGetReasons) {
  PathPlanner planner(ArenaGeometry{0.9, 0.6}, kRobotRadius, 0.01);
  planner.setObstacles({{"blue_cube", 0.25, 0.0, 0.0, square(0.04)}, {"red_cube", 0.05, 0.15, 0.3, square(0.04)}});
  const Pose2D start{-0.3, 0.0, 0.0};
  auto reason = [&](const Pose2D& goal) {
    const PathResult r = planner.plan(start, goal);
    EXPECT_FALSE(r.ok);
    EXPECT_TRUE(r.waypoints.empty());
    return r.reason;
  };
  EXPECT_NE(reason({0.25, 0.0, 0.0}).find("too close to blue_cube"), std::string::npos);
  EXPECT_NE(reason({0.06, 0.17, 0.0}).find("red_cube"), std::string::npos);
  EXPECT_NE(reason({0.6, 0.0, 0.0}).find("outside the reachable part of the arena"), std::string::npos);
  EXPECT_NE(reason({0.0, 0.28, 0.0}).find("outside"), std::string::npos);
  EXPECT_NE(reason({NAN, 0.0, 0.0}).find("goal.x is NaN"), std::string::npos);
  EXPECT_NE(planner.plan({0.25, 0.01, 0.0}, {0, 0, 0}).reason.find("start (0.25, 0.01) is blocked"), std::string::npos)
      << planner.plan({0.25, 0.01, 0.0}, {0, 0, 0}).reason;
  // A goal walled in by four boxes: free itself, but no way in.
  PathPlanner walled(ArenaGeometry{0.9, 0.6}, kRobotRadius, 0.01);
  walled.setObstacles({{"a", 0.2, 0.12, 0, square(0.1)}, {"b", 0.2, -0.12, 0, square(0.1)},
                       {"c", 0.32, 0, 0, square(0.1)}, {"d", 0.08, 0, 0, square(0.1)},
                       {"e", 0.08, 0.1, 0, square(0.1)}, {"f", 0.08, -0.1, 0, square(0.1)},
                       {"g", 0.32, 0.1, 0, square(0.1)}, {"h", 0.32, -0.1, 0, square(0.1)}});
  ASSERT_EQ(walled.checkFree(0.2, 0.0), "");
  const PathResult enclosed = walled.plan(start, {0.2, 0.0, 0.0});
  EXPECT_FALSE(enclosed.ok);
  EXPECT_NE(enclosed.reason.find("no path from"), std::string::npos) << enclosed.reason;
  EXPECT_THROW(planner.setObstacles({{"x", 0, 0, 0, square(-1)}}), ValidationError);

  EXPECT_EQ(checkTargetInArena({0.9, 0.6}, 0.41, 0.26, kRobotRadius), "");
  EXPECT_NE(checkTargetInArena({0.9, 0.6}, 0.42, 0.0, kRobotRadius), "");
  EXPECT_NE(checkTargetInArena({0.9, 0.6}, 0.40, 0.0, kRobotRadius, 0.02), "");
}

TEST(PathPlanning, LeavesTheMarginFromAStartNextToACube) {
  // Right after a push the robot may be closer than the margin to a cube: it can still get away.
  PathPlanner planner(ArenaGeometry{0.9, 0.6}, kRobotRadius, 0.01);
  planner.setObstacles({{"red_cube", 0.0, 0.0, 0.0, square(0.04)}});
  const PathResult r = planner.plan({-0.056, 0.0, 0.0}, {-0.3, 0.1, 0.0});
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_NEAR(r.waypoints.back().x, -0.3, 1e-12);
}

// (d) Pushes on PhysicsWorld.
namespace {

struct PushOutcome {
  PushFeedback last;
  PushPlan plan;
  double seconds = 0;
  Pose2D before, after;  ///< the pushed cube's ground truth
  std::map<std::string, Pose2D> others_before;
  bool progress_monotonic = true;
};

PushOutcome runPush(PhysicsWorld& world, const PushRequest& request, double limit = 60.0) {
  PushOutcome out;
  const std::vector<Obstacle> cubes = cubesOf(world);
  Obstacle object;
  for (const auto& c : cubes) {
    if (c.name == request.object) object = c;
    else out.others_before[c.name] = truth(world, c.name);
  }
  out.plan = planPush(object, request, kRobotRadius, arenaOf(world), cubes);
  EXPECT_TRUE(out.plan.ok) << out.plan.reason;
  if (!out.plan.ok) return out;
  PathPlanner planner(arenaOf(world), kRobotRadius, 0.01);
  planner.setObstacles(cubes);
  const PathResult path = planner.plan(odometry(world), out.plan.approach);
  EXPECT_TRUE(path.ok) << path.reason;
  PushController controller;
  controller.start(out.plan, path.waypoints);
  out.before = truth(world, request.object);
  const double t0 = world.time();
  double progress = 0;
  while (world.time() - t0 < limit) {
    out.last = controller.update(odometry(world), kControlPeriod);
    if (out.last.progress < progress - 1e-9) out.progress_monotonic = false;
    progress = out.last.progress;
    if (out.last.done || out.last.failed) break;
    applyAndStep(world, out.last.command);
  }
  out.seconds = world.time() - t0;
  for (int i = 0; i < 50; ++i) applyAndStep(world, Velocity2D{});  // 1 s for the cube to settle
  out.after = truth(world, request.object);
  return out;
}

/// Displacement of the pushed cube along and across the push direction.
std::pair<double, double> alongAcross(const PushOutcome& o) {
  const double dx = o.after.x - o.before.x, dy = o.after.y - o.before.y;
  const double c = std::cos(o.plan.direction), s = std::sin(o.plan.direction);
  return {c * dx + s * dy, -s * dx + c * dy};
}

}  // namespace

TEST(Push, CentredPushMovesTheRedCubeAlongThePushDirection) {
  PhysicsWorld world(defaultWorld());
  const PushOutcome o = runPush(world, {"red_cube", "-x", 0.0, 0.08});
  ASSERT_TRUE(o.last.done) << o.last.reason;
  EXPECT_TRUE(o.progress_monotonic);
  EXPECT_DOUBLE_EQ(o.last.progress, 1.0);
  const auto [along, across] = alongAcross(o);
  EXPECT_GT(along, 0.05) << "most of the 8 cm push reaches the cube";
  EXPECT_LT(std::fabs(across), 0.25 * along) << "most of the displacement is along the push direction";
  // Pushing through the centre is balanced but not stable (friction opposes the slip, as in a real push): a
  // slight imbalance turns the cube a little.
  EXPECT_LT(std::fabs(normalizeAngle(o.after.yaw - o.before.yaw)), 3 * kPi / 180.0);
  for (const auto& [name, before] : o.others_before) {
    const Pose2D now = truth(world, name);
    EXPECT_LT(std::hypot(now.x - before.x, now.y - before.y), 0.001) << name << " was not touched";
  }
  std::printf("[ measured ] centred push of red_cube by 80 mm: moved %.1f mm along, %.1f mm across, yaw %.1f deg; "
              "whole push (approach from the start pose .. retreat) %.1f s sim time\n",
              along * 1000, across * 1000, normalizeAngle(o.after.yaw - o.before.yaw) * 180 / kPi, o.seconds);
}

TEST(Push, TheBlueCubeDoesNotMove) {
  PhysicsWorld world(defaultWorld());
  const PushOutcome o = runPush(world, {"blue_cube", "-x", 0.0, 0.05});
  // On odometry the wheels' slip looks like progress, so the push itself may well report done; what
  // matters is the cube.
  EXPECT_TRUE(o.last.done || o.last.failed);
  EXPECT_LT(std::hypot(o.after.x - o.before.x, o.after.y - o.before.y), 0.003);
  std::printf("[ measured ] push of blue_cube: moved %.2f mm; controller %s%s in %.1f s\n",
              std::hypot(o.after.x - o.before.x, o.after.y - o.before.y) * 1000, toString(o.last.phase).c_str(),
              o.last.reason.empty() ? "" : (" (" + o.last.reason + ")").c_str(), o.seconds);
}

TEST(Push, OffCentrePushesRotateTheCubeTheWayTheOffsetSays) {
  // Contact left of the centre (positive offset) turns the cube clockwise (negative yaw), and vice versa, by tens
  // of degrees as a real cube does (friction opposes the slip at every sliding contact, physics.friction_model
  // coulomb; bench/contact.md): the farther off the centre, the more, and the more it slides off sideways.
  std::map<double, double> turn;
  for (double offset : {0.02, -0.02, 0.01}) {
    PhysicsWorld world(defaultWorld());
    const PushOutcome o = runPush(world, {"red_cube", "-x", offset, 0.12});
    ASSERT_TRUE(o.last.done) << offset << ": " << o.last.reason;
    const double turned = normalizeAngle(o.after.yaw - o.before.yaw);
    const auto [along, across] = alongAcross(o);
    turn[offset] = turned;
    EXPECT_GT(std::fabs(turned), (std::fabs(offset) >= 0.02 ? 40 : 15) * kPi / 180.0) << "offset " << offset;
    EXPECT_EQ(turned < 0, offset > 0) << "offset " << offset << " turned " << turned;
    EXPECT_GT(along, 0.06);
    EXPECT_EQ(across < 0, offset > 0) << "a cube pushed left of its centre slides off to the right";
    std::printf("[ measured ] red_cube pushed 120 mm with offset %+.0f mm: turned %+.2f deg, moved %.1f mm along, "
                "%.1f mm across, %.1f s\n",
                offset * 1000, turned * 180 / kPi, along * 1000, across * 1000, o.seconds);
  }
  EXPECT_GT(std::fabs(turn[0.02]), std::fabs(turn[0.01])) << "a larger offset turns it more";
  EXPECT_NEAR(turn[0.02], -turn[-0.02], 10 * kPi / 180.0) << "the turn is symmetric in the offset";
}

TEST(Push, TheSlipperyYellowCubeCanBePushed) {
  PhysicsWorld world(defaultWorld());
  const PushOutcome o = runPush(world, {"yellow_cube", "+x", 0.0, 0.06});
  ASSERT_TRUE(o.last.done) << o.last.reason;
  const auto [along, across] = alongAcross(o);
  EXPECT_GT(along, 0.04);
  EXPECT_LT(std::fabs(across), 0.5 * along);
  std::printf("[ measured ] yellow_cube (yaw 0.4) pushed 60 mm on +x: moved %.1f mm along, %.1f mm across, "
              "turned %+.1f deg, %.1f s\n",
              along * 1000, across * 1000, normalizeAngle(o.after.yaw - o.before.yaw) * 180 / kPi, o.seconds);
}

TEST(Push, BadRequestsAreRejectedWithReasons) {
  const ArenaGeometry arena{0.9, 0.6};
  const Obstacle red{"red_cube", 0.05, 0.15, 0.0, square(0.04)}, green{"green_cube", 0.05, -0.15, 0.0, square(0.04)};
  const Obstacle yellow{"yellow_cube", 0.3, 0.18, 0.4, square(0.04)}, blue{"blue_cube", 0.25, 0.0, 0.0, square(0.04)};
  const std::vector<Obstacle> all{red, green, yellow, blue};
  auto reason = [&](const Obstacle& object, const PushRequest& r, const std::vector<Obstacle>& others) {
    const PushPlan p = planPush(object, r, kRobotRadius, arena, others);
    EXPECT_FALSE(p.ok) << r.side << " " << r.offset << " " << r.distance;
    return p.reason;
  };
  EXPECT_NE(reason(red, {"red_cube", "z", 0, 0.05}, all).find("side is 'z'"), std::string::npos);
  EXPECT_NE(reason(red, {"red_cube", "-x", 0, NAN}, all).find("distance is NaN"), std::string::npos);
  EXPECT_NE(reason(red, {"red_cube", "-x", 0, -0.02}, all).find("greater than zero"), std::string::npos);
  EXPECT_NE(reason(red, {"red_cube", "-x", 0, 0.2}, all).find("at most 0.15"), std::string::npos);
  EXPECT_NE(reason(red, {"red_cube", "-x", 0.03, 0.05}, all).find("offset is 0.03"), std::string::npos);
  EXPECT_NE(reason(red, {"red_cube", "-y", 0, 0.15}, all).find("into the wall"), std::string::npos);
  EXPECT_NE(reason(yellow, {"yellow_cube", "+y", 0, 0.05}, all).find("approach spot"), std::string::npos);
  // Red pushed towards green from 8 cm away: would shove it into green.
  const Obstacle near_green{"red_cube", 0.05, -0.07, 0.0, square(0.04)};
  EXPECT_NE(reason(near_green, {"red_cube", "+y", 0, 0.08}, {near_green, green}).find("into green_cube"),
            std::string::npos);
  // A good request gives consistent poses.
  const PushPlan ok = planPush(red, {"red_cube", "-x", 0.01, 0.05}, kRobotRadius, arena, all);
  ASSERT_TRUE(ok.ok) << ok.reason;
  EXPECT_NEAR(ok.direction, 0.0, 1e-12);
  EXPECT_NEAR(ok.contact.x, 0.05 - 0.02 - kRobotRadius, 1e-12);
  EXPECT_NEAR(ok.contact.y, 0.16, 1e-12) << "positive offset: left of the push direction";
  EXPECT_NEAR(ok.approach.x, ok.contact.x - 0.03, 1e-12);
  EXPECT_NEAR(ok.push_end.x, ok.contact.x + 0.05, 1e-12);
  EXPECT_NEAR(ok.object_end.x, 0.10, 1e-12);
  const PushPlan rotated = planPush(yellow, {"yellow_cube", "-y", 0, 0.03}, kRobotRadius, arena, all);
  EXPECT_NEAR(rotated.direction, 0.4 + kPi / 2, 1e-12);
}

TEST(Controllers, FailWithAReasonWhenTheRobotMakesNoProgress) {
  // A robot that does not move whatever it is told (blocked, or its pose is stuck): the phase fails.
  GoToPoseOptions options;
  options.stall_time = 2.0;
  GoToPoseController controller(MotionLimits{}, options);
  controller.setGoal({0.2, 0.0, 0.0});
  MotionFeedback fb;
  double t = 0;
  for (; t < 10.0 && !fb.failed; t += kControlPeriod) fb = controller.update({0.0, 0.0, 0.0}, kControlPeriod);
  ASSERT_TRUE(fb.failed);
  EXPECT_NEAR(t, 2.0, 0.1);
  EXPECT_NE(fb.reason.find("no progress for 2 s in phase drive"), std::string::npos) << fb.reason;
  EXPECT_EQ(fb.command.linear, 0.0);

  PushPlan plan = planPush({"red_cube", 0.0, 0.0, 0.0, square(0.04)}, {"red_cube", "-x", 0.0, 0.05}, kRobotRadius,
                           {0.9, 0.6}, {});
  ASSERT_TRUE(plan.ok) << plan.reason;
  PushControlOptions push_options;
  push_options.stall_time = 2.0;
  PushController push(MotionLimits{}, push_options);
  push.start(plan);
  PushFeedback pf;
  for (t = 0; t < 10.0 && !pf.failed; t += kControlPeriod) pf = push.update(plan.approach, kControlPeriod);
  ASSERT_TRUE(pf.failed);
  EXPECT_NE(pf.reason.find("failed in contact: no progress along the push line"), std::string::npos) << pf.reason;
  EXPECT_EQ(push.phase(), PushPhase::Failed);

  push_options.timeout = 1.0;
  PushController impatient(MotionLimits{}, push_options);
  impatient.start(plan, {{-0.3, 0.2, 0.0}});
  pf = PushFeedback{};
  for (t = 0; t < 10.0 && !pf.failed; t += kControlPeriod) pf = impatient.update({-0.3, -0.2, 0.0}, kControlPeriod);
  ASSERT_TRUE(pf.failed);
  EXPECT_NEAR(t, 1.0, 0.05);
  EXPECT_NE(pf.reason.find("timeout of 1 s"), std::string::npos) << pf.reason;
}

TEST(Push, AnObjectThatResistsEndsThePushBlockedAndTheRobotBacksOff) {
  // A kinematic robot that moves as commanded until it reaches the face plus 1 cm: there the object stops it.
  PushPlan plan = planPush({"blue_cube", 0.0, 0.0, 0.0, square(0.04)}, {"blue_cube", "-x", 0.0, 0.08}, kRobotRadius,
                           {0.9, 0.6}, {});
  ASSERT_TRUE(plan.ok) << plan.reason;
  PushControlOptions options;
  options.stall_time = 1.0;
  PushController push(MotionLimits{}, options);
  push.start(plan);
  Pose2D pose = plan.approach;
  const double wall_x = plan.contact.x + 0.01;
  PushFeedback fb;
  for (double t = 0; t < 60.0 && !fb.done && !fb.failed; t += kControlPeriod) {
    fb = push.update(pose, kControlPeriod);
    pose.yaw += fb.command.angular * kControlPeriod;
    pose.x = std::min(wall_x, pose.x + std::cos(pose.yaw) * fb.command.linear * kControlPeriod);
    pose.y += std::sin(pose.yaw) * fb.command.linear * kControlPeriod;
  }
  ASSERT_TRUE(fb.done) << fb.reason;
  EXPECT_TRUE(fb.blocked);
  EXPECT_LT(pose.x, wall_x - 0.03) << "the robot did not back off";
}

// (e) Footprints other than the cubes' square: long rectangles and discs.
TEST(Footprints, DistanceToARotatedRectangleAndADisc) {
  // 0.2 x 0.04 m turned by 90 deg: it covers x in [0.08, 0.12], y in [-0.1, 0.1].
  const Obstacle bar{"bar", 0.1, 0.0, kPi / 2, Footprint::rectangle(0.2, 0.04)};
  EXPECT_NEAR(distanceToObstacle(bar, 0.1, 0.15), 0.05, 1e-12);
  EXPECT_NEAR(distanceToObstacle(bar, 0.15, 0.0), 0.03, 1e-12);
  EXPECT_NEAR(distanceToObstacle(bar, 0.1, 0.0), -0.02, 1e-12);
  EXPECT_NEAR(distanceToObstacle(bar, 0.15, 0.14), 0.05, 1e-12) << "to the corner (0.12, 0.1)";
  const Obstacle puck{"puck", -0.1, 0.05, 1.0, Footprint::disc(0.03)};
  EXPECT_NEAR(distanceToObstacle(puck, -0.1, 0.1), 0.02, 1e-12);
  EXPECT_NEAR(distanceToObstacle(puck, -0.1, 0.05), -0.03, 1e-12);
}

TEST(Footprints, ThePathPlannerRoutesAroundADisc) {
  PathPlanner planner(ArenaGeometry{0.9, 0.6}, kRobotRadius, 0.01);
  const Obstacle puck{"puck", 0.0, 0.0, 0.0, Footprint::disc(0.08)};
  planner.setObstacles({puck});
  const Pose2D start{-0.3, 0.0, 0.0}, goal{0.3, 0.0, 0.0};
  const PathResult r = planner.plan(start, goal);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_GE(r.waypoints.size(), 2u) << "the straight line goes through the disc";
  double closest = 1.0;
  Pose2D from = start;
  for (const Pose2D& to : r.waypoints) {
    for (int s = 0; s <= 100; ++s) {
      const double t = s / 100.0;
      closest = std::min(closest, distanceToObstacle(puck, from.x + t * (to.x - from.x), from.y + t * (to.y - from.y)));
    }
    from = to;
  }
  EXPECT_GE(closest, kRobotRadius + 0.01 - 1e-6) << "the path keeps the radius and the margin from the disc";
  EXPECT_NE(planner.plan(start, {0.0, 0.1, 0.0}).reason.find("too close to puck"), std::string::npos);
  EXPECT_THROW(planner.setObstacles({{"bad", 0, 0, 0, Footprint::disc(-0.01)}}), ValidationError);
}

TEST(Footprints, PushPlansForALongRectangleOnEachSide) {
  const ArenaGeometry arena{0.9, 0.6};
  const Obstacle bar{"bar", 0.0, 0.0, 0.0, Footprint::rectangle(0.12, 0.04)};
  const double r = kRobotRadius;
  struct Case {
    std::string side;
    double direction, contact_x, contact_y;  // for offset 0.01
    double max_offset;
  };
  // Contact 1 cm left of the push direction; the robot's centre touches the face straight ahead.
  for (const Case& c : {Case{"-x", 0.0, -0.06 - r, 0.01, 0.02}, Case{"+x", kPi, 0.06 + r, -0.01, 0.02},
                        Case{"-y", kPi / 2, -0.01, -0.02 - r, 0.06}, Case{"+y", -kPi / 2, 0.01, 0.02 + r, 0.06}}) {
    EXPECT_NEAR(maxPushOffset(bar.footprint, c.side), c.max_offset, 1e-12) << c.side;
    const PushPlan p = planPush(bar, {"bar", c.side, 0.01, 0.05}, r, arena, {});
    ASSERT_TRUE(p.ok) << c.side << ": " << p.reason;
    EXPECT_NEAR(normalizeAngle(p.direction - c.direction), 0.0, 1e-12) << c.side;
    EXPECT_NEAR(p.contact.x, c.contact_x, 1e-12) << c.side;
    EXPECT_NEAR(p.contact.y, c.contact_y, 1e-12) << c.side;
    EXPECT_NEAR(p.push_end.x - p.contact.x, 0.05 * std::cos(c.direction), 1e-12) << c.side;
    EXPECT_NEAR(p.push_end.y - p.contact.y, 0.05 * std::sin(c.direction), 1e-12) << c.side;
  }
  // 3 cm off the centre is on the long faces, beyond the ends of the short ones.
  EXPECT_TRUE(planPush(bar, {"bar", "-y", 0.03, 0.05}, r, arena, {}).ok);
  const PushPlan off = planPush(bar, {"bar", "-x", 0.03, 0.05}, r, arena, {});
  EXPECT_FALSE(off.ok);
  EXPECT_NE(off.reason.find("offset is 0.03; it must lie in [-0.02, 0.02]"), std::string::npos) << off.reason;
  EXPECT_NE(off.reason.find("0.12 x 0.04 m rectangle"), std::string::npos) << off.reason;

  // Turned by 90 deg next to the +y wall, the bar reaches 0.1 m along y: the wall check uses that extent.
  const Obstacle standing{"bar", 0.0, 0.1, kPi / 2, Footprint::rectangle(0.2, 0.04)};
  EXPECT_TRUE(planPush(standing, {"bar", "-x", 0.0, 0.08}, r, arena, {}).ok);
  EXPECT_NE(planPush(standing, {"bar", "-x", 0.0, 0.1}, r, arena, {}).reason.find("into the wall"), std::string::npos);
}

TEST(Footprints, PushPlanForADiscPutsTheContactAtTheOffset) {
  const ArenaGeometry arena{0.9, 0.6};
  const double R = 0.03, r = kRobotRadius, offset = 0.01;
  const Obstacle puck{"puck", 0.1, -0.05, 0.0, Footprint::disc(R)};
  EXPECT_NEAR(maxPushOffset(puck.footprint, "-y"), R / 2, 1e-12);
  const PushPlan p = planPush(puck, {"puck", "-x", offset, 0.06}, r, arena, {});
  ASSERT_TRUE(p.ok) << p.reason;
  EXPECT_NEAR(p.direction, 0.0, 1e-12);
  // The discs touch: the contact point lies on the centre line, R from the puck's centre.
  const double cx = p.contact.x - puck.x, cy = p.contact.y - puck.y;
  EXPECT_NEAR(std::hypot(cx, cy), R + r, 1e-12);
  EXPECT_NEAR(R * cy / (R + r), offset, 1e-12) << "the contact point is `offset` left of the push line";
  EXPECT_LT(cx, 0.0) << "behind the puck";
  // Approach, contact, push end and retreat all lie on the displaced line, facing the push direction.
  for (const Pose2D& q : {p.approach, p.contact, p.push_end, p.retreat}) {
    EXPECT_NEAR(q.y, puck.y + offset * (R + r) / R, 1e-12);
    EXPECT_NEAR(q.yaw, 0.0, 1e-12);
  }
  EXPECT_NEAR(p.contact.x - p.approach.x, PushOptions{}.standoff, 1e-12);
  EXPECT_NEAR(p.push_end.x - p.contact.x, 0.06, 1e-12);
  // Beyond half the radius the robot would glance off the side.
  const PushPlan glancing = planPush(puck, {"puck", "-x", 0.016, 0.06}, r, arena, {});
  EXPECT_FALSE(glancing.ok);
  EXPECT_NE(glancing.reason.find("offset is 0.016; it must lie in [-0.015, 0.015]"), std::string::npos)
      << glancing.reason;
  EXPECT_NE(glancing.reason.find("a disc of radius 0.03 m"), std::string::npos) << glancing.reason;
  EXPECT_NE(glancing.reason.find("half its radius"), std::string::npos) << glancing.reason;
}

TEST(Footprints, PushControllerPushesADiscToThePushEnd) {
  // Kinematic: the robot moves as commanded; where it overlaps the puck, the puck is moved out along the
  // centre line (a light puck that slides without friction of its own).
  const double R = 0.025;
  Obstacle puck{"puck", 0.0, 0.0, 0.0, Footprint::disc(R)};
  const PushPlan plan = planPush(puck, {"puck", "+y", 0.0, 0.08}, kRobotRadius, {0.9, 0.6}, {});
  ASSERT_TRUE(plan.ok) << plan.reason;
  PushController push;
  push.start(plan, {{-0.2, 0.2, 0.0}});
  Pose2D pose{-0.2, 0.25, 0.0};
  const double dx = std::cos(plan.direction), dy = std::sin(plan.direction);
  double furthest = -1.0;  // along the push line past the contact pose
  PushFeedback fb;
  for (double t = 0; t < 60.0 && !fb.done && !fb.failed; t += kControlPeriod) {
    fb = push.update(pose, kControlPeriod);
    pose.yaw += fb.command.angular * kControlPeriod;
    pose.x += std::cos(pose.yaw) * fb.command.linear * kControlPeriod;
    pose.y += std::sin(pose.yaw) * fb.command.linear * kControlPeriod;
    const double gap = std::hypot(puck.x - pose.x, puck.y - pose.y), touch = R + kRobotRadius;
    if (gap < touch) {
      puck.x = pose.x + (puck.x - pose.x) * touch / gap;
      puck.y = pose.y + (puck.y - pose.y) * touch / gap;
    }
    furthest = std::max(furthest, (pose.x - plan.contact.x) * dx + (pose.y - plan.contact.y) * dy);
  }
  ASSERT_TRUE(fb.done) << fb.reason;
  EXPECT_FALSE(fb.blocked);
  EXPECT_NEAR(furthest, plan.distance, 0.003) << "the robot drove to the push end";
  EXPECT_NEAR(puck.x, plan.object_end.x, 0.005);
  EXPECT_NEAR(puck.y, plan.object_end.y, 0.005);
  EXPECT_LT(distance(pose, plan.retreat), 0.005);
}
