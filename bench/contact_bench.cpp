// How objects answer pushes in XPERSim: every object of a world pushed on its faces at offsets from -max to
// +max (maxPushOffset, as the loop may choose them), reporting the object's turn and displacement. ROS-free:
// core::PhysicsWorld stepped in 2 ms steps, the robot driven by core::PushController every 20 ms of simulated
// time (as MANIPULATION does), on the robot's ground-truth pose (standing in for the camera's fix).
//
//   contact_bench WORLD.yaml [--label NAME] [--objects a,b] [--sides -x,-y] [--offsets N] [--distance D]
//                 [--repeats R] [--seed S] [--friction-model coulomb|pyramid]
//
// Each (object, side, offset) starts from the world as the file builds it; with --repeats R the same push is
// made R times in a row (object and robot put back between pushes, the simulator's state otherwise kept), so
// that an object whose friction is redrawn per contact episode shows its spread and the others show none.
// Prints one line per push (CSV: label,object,side,offset_mm,distance_mm,repeat,dx_mm,dy_mm,dyaw_deg,
// blocked,friction) and a summary per object and side on stderr.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "xpersif/core/common/experiment.h"
#include "xpersif/core/motion/motion.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/common/setup.h"

using namespace xpersif::core;

namespace {

constexpr double kControlPeriod = 0.02;
constexpr double kPi = 3.14159265358979323846;

struct Options {
  std::string world_file, label = "world";
  std::vector<std::string> objects, sides{"-x", "-y"};
  int offsets = 5, repeats = 1;
  double distance = 0.12;
  long long seed = -1;
  std::string friction_model;  ///< "" = the world file's
};

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr,
               "%s\nusage: contact_bench WORLD.yaml [--label NAME] [--objects a,b] [--sides -x,-y] [--offsets N] "
               "[--distance D] [--repeats R] [--seed S] [--friction-model coulomb|pyramid]\n",
               why.c_str());
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--label") o.label = value();
    else if (a == "--objects") o.objects = split(value());
    else if (a == "--sides") o.sides = split(value());
    else if (a == "--offsets") o.offsets = std::atoi(value().c_str());
    else if (a == "--distance") o.distance = std::atof(value().c_str());
    else if (a == "--repeats") o.repeats = std::atoi(value().c_str());
    else if (a == "--seed") o.seed = std::atoll(value().c_str());
    else if (a == "--friction-model") o.friction_model = value();
    else if (!a.empty() && a[0] == '-') usage("unknown option " + a);
    else o.world_file = a;
  }
  if (o.world_file.empty()) usage("no world file");
  if (o.offsets < 1 || o.repeats < 1 || !(o.distance > 0)) usage("--offsets and --repeats must be >= 1, --distance > 0");
  return o;
}

Pose2D truth(const PhysicsWorld& world, const std::string& body) {
  const Eigen::Isometry3d p = world.bodyPose(body);
  return {p.translation().x(), p.translation().y(), yawOf(p)};
}

std::vector<Obstacle> obstaclesOf(const PhysicsWorld& world) {
  std::vector<Obstacle> out;
  for (const auto& o : world.spec().objects) {
    const Pose2D p = truth(world, o.name);
    out.push_back({o.name, p.x, p.y, p.yaw, Footprint::ofShape(o.shape)});
  }
  return out;
}

struct PushResult {
  bool ok = false, blocked = false;
  std::string reason;
  Outcome outcome;
};

PushResult push(PhysicsWorld& world, const SetupCatalogue& cat, const PushRequest& request) {
  PushResult r;
  const std::vector<Obstacle> all = obstaclesOf(world);
  Obstacle object;
  for (const auto& o : all) {
    if (o.name == request.object) object = o;
  }
  const ArenaGeometry arena{cat.arena_size_x, cat.arena_size_y};
  PushOptions options;
  options.max_distance = cat.maxPushDistance();
  const PushPlan plan = planPush(object, request, cat.robot_radius, arena, all, options);
  if (!plan.ok) {
    r.reason = plan.reason;
    return r;
  }
  PathPlanner planner(arena, cat.robot_radius, options.margin);
  planner.setObstacles(all);
  const PathResult path = planner.plan(truth(world, world.spec().robot.name), plan.approach);
  if (!path.ok) {
    r.reason = path.reason;
    return r;
  }
  PushController controller;
  controller.start(plan, path.waypoints);
  ObjectFeatures before{request.object, object.x, object.y, object.yaw, {}};
  const int steps = static_cast<int>(std::lround(kControlPeriod / world.spec().physics.step));
  const double t0 = world.time();
  PushFeedback fb;
  while (world.time() - t0 < 120) {
    fb = controller.update(truth(world, world.spec().robot.name), kControlPeriod);
    if (fb.done || fb.failed) break;
    world.setVelocity(fb.command.linear, fb.command.angular);
    for (int i = 0; i < steps; ++i) world.step();
  }
  world.setVelocity(0, 0);
  for (int i = 0; i < 50 * steps; ++i) world.step();  // 1 s to come to rest
  // A push that stalled (the object resisted) still has an outcome: how far the object went.
  const Pose2D after = truth(world, request.object);
  r.outcome = computeOutcome(before, {request.object, after.x, after.y, after.yaw, {}}, request.side);
  r.blocked = !fb.done || fb.blocked;
  r.ok = true;
  return r;
}

struct Stats {
  std::vector<double> turn, along;
  std::vector<std::pair<double, double>> turn_by_offset;  // (offset, mean turn over repeats)
};

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / v.size();
}

double stddev(const std::vector<double>& v) {
  if (v.size() < 2) return 0;
  const double m = mean(v);
  double s = 0;
  for (double x : v) s += (x - m) * (x - m);
  return std::sqrt(s / (v.size() - 1));
}

}  // namespace

int main(int argc, char** argv) {
  const Options opt = parse(argc, argv);
  WorldSpec spec;
  try {
    spec = loadWorldFile(opt.world_file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  if (opt.friction_model == "pyramid") spec.physics.friction_model = PhysicsSpec::FrictionModel::Pyramid;
  else if (opt.friction_model == "coulomb") spec.physics.friction_model = PhysicsSpec::FrictionModel::Coulomb;
  else if (!opt.friction_model.empty()) usage("--friction-model is coulomb or pyramid");
  std::vector<std::string> objects = opt.objects;
  if (objects.empty()) {
    for (const auto& o : spec.objects) objects.push_back(o.name);
  }
  std::printf("label,object,side,offset_mm,distance_mm,repeat,dx_mm,dy_mm,dyaw_deg,blocked,friction\n");
  for (const auto& name : objects) {
    for (const auto& side : opt.sides) {
      Stats stats;
      std::vector<double> spread_along, spread_turn;
      for (int k = 0; k < opt.offsets; ++k) {
        PhysicsWorld world(spec);
        if (opt.seed >= 0) world.setRedrawSeed(static_cast<std::uint64_t>(opt.seed));
        const SetupCatalogue cat = SetupCatalogue::fromScene(world.scene());
        const CatalogueObject* object = cat.find(name);
        if (!object) {
          std::fprintf(stderr, "%s is not an object of %s\n", name.c_str(), opt.world_file.c_str());
          return 2;
        }
        const double max = maxPushOffset(object->footprint, side);
        const double offset = opt.offsets == 1 ? 0.0 : -max + 2 * max * k / (opt.offsets - 1);
        const double distance = std::min(opt.distance, cat.maxPushDistance());
        const Eigen::Isometry3d object_start = world.bodyPose(name);
        const Eigen::Isometry3d robot_start = world.bodyPose(spec.robot.name);
        std::vector<double> turns, alongs;
        for (int rep = 0; rep < opt.repeats; ++rep) {
          if (rep > 0) {
            // The robot first: after its retreat it may stand where the object started.
            world.setPose(spec.robot.name, robot_start);
            world.setPose(name, object_start);
          }
          const PushResult r = push(world, cat, {name, side, offset, distance});
          if (!r.ok) {
            std::fprintf(stderr, "%s %s offset %+.1f mm: no push (%s)\n", name.c_str(), side.c_str(), offset * 1000,
                         r.reason.c_str());
            continue;
          }
          const double turn = r.outcome.dyaw * 180 / kPi;
          std::printf("%s,%s,%s,%.1f,%.0f,%d,%.1f,%.1f,%.2f,%d,%.3f\n", opt.label.c_str(), name.c_str(), side.c_str(),
                      offset * 1000, distance * 1000, rep, r.outcome.dx * 1000, r.outcome.dy * 1000, turn,
                      r.blocked ? 1 : 0, world.objectFriction(name));
          std::fflush(stdout);
          turns.push_back(turn);
          alongs.push_back(r.outcome.dx * 1000);
        }
        if (turns.empty()) continue;
        stats.turn_by_offset.emplace_back(offset * 1000, mean(turns));
        stats.along.insert(stats.along.end(), alongs.begin(), alongs.end());
        spread_along.push_back(stddev(alongs));
        spread_turn.push_back(stddev(turns));
      }
      if (stats.turn_by_offset.empty()) continue;
      std::string turns;
      for (const auto& [off, t] : stats.turn_by_offset) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%s%+.0fmm:%+.1f", turns.empty() ? "" : " ", off, t);
        turns += buf;
      }
      std::fprintf(stderr, "[%s] %-14s %s  turn (deg) by offset: %s | along %.1f..%.1f mm",
                   opt.label.c_str(), name.c_str(), side.c_str(), turns.c_str(),
                   *std::min_element(stats.along.begin(), stats.along.end()),
                   *std::max_element(stats.along.begin(), stats.along.end()));
      if (opt.repeats > 1) {
        std::fprintf(stderr, " | spread over %d repeats: along sd %.1f mm, turn sd %.1f deg", opt.repeats,
                     mean(spread_along), mean(spread_turn));
      }
      std::fprintf(stderr, "\n");
    }
  }
  return 0;
}
