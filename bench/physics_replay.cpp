// The physics-only cost of a campaign: the same ODE steps with the same wheel commands, and nothing else.
//
//   physics_replay <world.yaml> <trace file> [tick_period=0.02] [seed=-1] [repetitions=3]
//
// The trace is XPERSim's (~trace_file, launch argument trace_file:=): after every stepped lockstep tick one line
// with the tick's command ("tick K drives=D v=V w=W ...") and every body's pose, and a line for each event that
// changed the world between ticks (set_pose, restore, checkpoint). This program builds core::PhysicsWorld from
// the same world file, and for each tick applies the recorded command and takes the same physics steps; after an
// event it puts every body where the trace says it was (a restore puts the world back to a whole saved state,
// which the trace does not hold; the poses are that state's bodies). Only the physics steps are timed: no
// messaging, no rendering, no controller. bench/run_loop_speed.sh divides the loop's wall time per stepped tick
// by this figure (bench/loop_speed.md).
//
// Prints one line per repetition and a JSON summary: ticks, steps, wall s of physics, ms per tick, and how far the
// replayed bodies were from the traced ones before each event (a check that the replay did the same work: the
// robot follows its commands to the millimetre; a pushed object may end elsewhere, since a placement resets its
// velocities and contacts, which the trace does not hold, and frictions are redrawn per contact episode).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/sim/world_spec.h"

namespace {

struct Pose {
  std::string body;
  Eigen::Isometry3d pose;
};

struct Event {
  bool tick = false;        // a stepped tick (else an event between ticks)
  bool command = false;     // a cmd_vel between ticks (a controller stopping the robot as it leaves)
  bool drives = false;
  double linear = 0, angular = 0;
  std::vector<Pose> poses;  // every traced node after it
};

double parseHex(const std::string& text) { return std::strtod(text.c_str(), nullptr); }  // %a round-trips

std::vector<Event> readTrace(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read the trace " + path);
  std::vector<Event> events;
  std::string line;
  bool keep = false;  // the current header is a tick or a world-moving event
  while (std::getline(in, line)) {
    if (line.rfind("  ", 0) == 0) {
      if (!keep || events.empty()) continue;
      std::istringstream fields(line);
      std::string name, v[7];
      fields >> name >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6];
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.translation() = Eigen::Vector3d(parseHex(v[0]), parseHex(v[1]), parseHex(v[2]));
      pose.linear() = Eigen::Quaterniond(parseHex(v[3]), parseHex(v[4]), parseHex(v[5]), parseHex(v[6]))
                          .normalized().toRotationMatrix();
      events.back().poses.push_back({name, pose});
      continue;
    }
    // "step N t=T EVENT": the event starts after the third field.
    std::istringstream fields(line);
    std::string step, count, time, what;
    fields >> step >> count >> time >> what;
    keep = false;
    if (what == "tick") {
      Event e;
      e.tick = true;
      std::string k, drives, v, w;
      fields >> k >> drives >> v >> w;
      e.drives = drives == "drives=1";
      e.linear = parseHex(v.substr(2));
      e.angular = parseHex(w.substr(2));
      events.push_back(e);
      keep = true;
    } else if (what == "cmd_vel") {
      Event e;
      e.command = true;
      std::string v, w;
      fields >> v >> w;
      e.linear = parseHex(v.substr(2));
      e.angular = parseHex(w.substr(2));
      events.push_back(e);
    } else if (what == "set_pose" || what == "restore" || what == "checkpoint" || what == "configure") {
      events.push_back(Event{});
      keep = true;
    }
  }
  return events;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: physics_replay <world.yaml> <trace file> [tick_period=0.02] [seed=-1] [repetitions=3]\n";
    return 2;
  }
  try {
    const xpersif::core::WorldSpec spec = xpersif::core::loadWorldFile(argv[1]);
    const std::vector<Event> events = readTrace(argv[2]);
    const double tick_period = argc > 3 ? std::atof(argv[3]) : 0.02;
    const long seed = argc > 4 ? std::atol(argv[4]) : -1;
    const int repetitions = argc > 5 ? std::atoi(argv[5]) : 3;
    std::vector<std::string> bodies = spec.bodyNames();
    auto isBody = [&](const std::string& name) {
      for (const auto& b : bodies) if (b == name) return true;
      return false;
    };
    std::size_t ticks = 0;
    for (const auto& e : events) ticks += e.tick ? 1 : 0;
    if (ticks == 0) throw std::runtime_error("the trace has no stepped tick: was trace_file set in lockstep mode?");

    // The steps of one tick, as XPERSim counts them (whole physics steps per tick_period).
    const int per_tick = std::max(1, static_cast<int>(std::lround(tick_period / spec.physics.step)));
    double best = 1e300, total = 0;
    const std::string robot = spec.robot.links.at(0).name;
    double worst_drift = 0, object_drift = 0, object_drift_max = 0;
    std::uint64_t steps = 0;
    for (int r = 0; r < repetitions; ++r) {
      xpersif::core::PhysicsWorld world(spec);
      if (seed >= 0) world.setRedrawSeed(static_cast<std::uint64_t>(seed));
      double physics = 0;
      std::uint64_t steps_run = 0;
      double robot_drift = 0;
      std::vector<double> object_drifts;
      const Event* previous_tick = nullptr;
      for (const auto& e : events) {
        if (e.command) {
          world.setVelocity(e.linear, e.angular);
          continue;
        }
        if (!e.tick) {
          // Where the replay stands against the trace before the event moves bodies, then the traced poses.
          if (previous_tick) {
            for (const auto& p : previous_tick->poses) {
              if (!isBody(p.body)) continue;
              const double d = (world.bodyPose(p.body).translation() - p.pose.translation()).head<2>().norm();
              if (p.body == robot) {
                robot_drift = std::max(robot_drift, d);
              } else {
                object_drifts.push_back(d);
              }
            }
          }
          for (const auto& p : e.poses) {
            if (isBody(p.body)) world.setPose(p.body, p.pose);
          }
          continue;
        }
        const auto began = std::chrono::steady_clock::now();
        if (e.drives) world.setVelocity(e.linear, e.angular);
        for (int i = 0; i < per_tick; ++i) world.step();
        physics += std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
        steps_run += per_tick;
        previous_tick = &e;
      }
      best = std::min(best, physics);
      total += physics;
      steps = steps_run;
      worst_drift = std::max(worst_drift, robot_drift);
      if (!object_drifts.empty()) {
        std::sort(object_drifts.begin(), object_drifts.end());
        object_drift = object_drifts[object_drifts.size() / 2];
        object_drift_max = object_drifts.back();
      }
      std::printf("repetition %d: %zu ticks, %llu steps, %.3f s of physics = %.3f ms per tick\n", r + 1, ticks,
                  static_cast<unsigned long long>(steps_run), physics, 1e3 * physics / ticks);
    }
    std::printf("{\"ticks\": %zu, \"steps\": %llu, \"physics_s_best\": %.4f, \"physics_s_mean\": %.4f, "
                "\"ms_per_tick_best\": %.4f, \"ms_per_tick_mean\": %.4f, \"robot_drift_max_m\": %.4f, "
                "\"object_drift_median_m\": %.4f, \"object_drift_max_m\": %.4f}\n",
                ticks, static_cast<unsigned long long>(steps), best, total / repetitions, 1e3 * best / ticks,
                1e3 * total / repetitions / ticks, worst_drift, object_drift, object_drift_max);
  } catch (const std::exception& e) {
    std::cerr << "physics_replay: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
