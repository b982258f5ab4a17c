// The motion core closed-loop on XPERSim's real physics: the controllers run every 20 ms of simulated time
// on the wheel odometry (as the RELOCATION / MANIPULATION nodelets do), physics steps in between, and the
// results are checked against the simulator's ground truth (bodyPose). Planners and bad input too.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "xpersif/core/motion.h"
#include "xpersif/core/physics_world.h"
#include "xpersif/core/validation.h"

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

std::vector<BoxObstacle> cubesOf(const PhysicsWorld& world) {
  std::vector<BoxObstacle> boxes;
  for (const auto& o : world.spec().objects) {
    const Pose2D p = truth(world, o.name);
    boxes.push_back({o.name, p.x, p.y, p.yaw, o.shape.box_size.x()});
  }
  return boxes;
}

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
      std::printf("move %d took %.2f truth err %.2f mm %.2f deg, odom-truth %.2f mm %.2f deg\n", i, took, dp * 1000,
                  dyaw * 180 / kPi, distance(odometry(world), real) * 1000, yawDiff(odometry(world).yaw, real.yaw) * 180 / kPi);
    EXPECT_LT(dp, 0.01) << "move " << i;
    EXPECT_LT(dyaw, 3.0 * kPi / 180.0) << "move " << i;
  }
  std::printf("[ measured ] %d moves: worst ground-truth error %.2f mm, %.2f deg (odometry %.2f mm); "
              "mean %.2f s, longest %.2f s sim time\n",
              kMoves, worst_position * 1000, worst_yaw * 180 / kPi, worst_odom_position * 1000,
              total_time / kMoves, longest);
}
