// Simulation speed: how many simulated seconds per wall second (real-time factor, RTF).
//
//   sim_speed local <world.yaml> [sim_seconds=60] [repetitions=3]
//       (a) a bare ODE loop: the world's bodies, hinges and geoms built with raw ODE calls from the same
//           WorldSpec, the same step, quickstep iterations, contact callback and wheel motors; nothing else
//       (b) core::PhysicsWorld stepping the same world with the same commands
//       Runs a, b, a, b, ... interleaved; prints one JSON line per run and a summary line.
//   sim_speed node [wall_seconds=10] [status_topic=/xpersim/status] [clock_subscriber=0]
//       (c) a running xpersim node (fast mode): reads simulated time t from the node's ~status (5 Hz,
//           wall-stamped) over the wall interval; publishes the same wheel command on wheel_speeds.
//           With clock_subscriber=1 it also subscribes /clock (as any use_sim_time node would), which
//           makes the simulator serialize and send every /clock message.
//
// The command in every case: wheel rim speeds left 0.20, right 0.15 m/s from t = 0 (the robot drives a
// circle of ~0.19 m radius and runs into the arena's wall).
#include <ode/ode.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <regex>
#include <string>
#include <vector>

#include "xpersif/ComponentStatus.h"
#include "xpersif/WheelSpeeds.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/sim/world_spec.h"

using xpersif::core::LinkSpec;
using xpersif::core::Shape;
using xpersif::core::WorldSpec;

namespace {

constexpr double kLeft = 0.20, kRight = 0.15;

// ---- (a) the bare ODE world ---------------------------------------------------------------------------

void setPoseOf(dBodyID body, const Eigen::Isometry3d& t) {
  dBodySetPosition(body, t.translation().x(), t.translation().y(), t.translation().z());
  const Eigen::Quaterniond q(t.rotation());
  const dQuaternion dq = {q.w(), q.x(), q.y(), q.z()};
  dBodySetQuaternion(body, dq);
}

dGeomID createGeom(dSpaceID space, const Shape& shape) {
  switch (shape.type) {
    case Shape::Type::Box: return dCreateBox(space, shape.box_size.x(), shape.box_size.y(), shape.box_size.z());
    case Shape::Type::Cylinder: return dCreateCylinder(space, shape.radius, shape.length);
    case Shape::Type::Sphere: return dCreateSphere(space, shape.radius);
  }
  return nullptr;
}

struct GeomInfo {
  double friction;
  bool robot;
};

struct BareWorld {
  const WorldSpec& spec;
  dWorldID world;
  dSpaceID space;
  dJointGroupID contacts;
  std::vector<std::unique_ptr<GeomInfo>> infos;
  std::vector<dBodyID> bodies;  // robot bodies, then objects
  dJointID left = nullptr, right = nullptr;

  dGeomID geom(const Shape& shape, dBodyID body, const Eigen::Isometry3d& offset, double friction, bool robot) {
    dGeomID g = createGeom(space, shape);
    infos.push_back(std::make_unique<GeomInfo>(GeomInfo{friction, robot}));
    dGeomSetData(g, infos.back().get());
    if (body) {
      dGeomSetBody(g, body);
      dGeomSetOffsetPosition(g, offset.translation().x(), offset.translation().y(), offset.translation().z());
      const Eigen::Quaterniond q(offset.rotation());
      const dQuaternion dq = {q.w(), q.x(), q.y(), q.z()};
      dGeomSetOffsetQuaternion(g, dq);
    } else {
      dGeomSetPosition(g, offset.translation().x(), offset.translation().y(), offset.translation().z());
    }
    return g;
  }

  explicit BareWorld(const WorldSpec& s) : spec(s) {
    world = dWorldCreate();
    space = dHashSpaceCreate(nullptr);
    contacts = dJointGroupCreate(0);
    dWorldSetGravity(world, 0, 0, spec.physics.gravity);
    dWorldSetQuickStepNumIterations(world, spec.physics.iterations);
    dWorldSetERP(world, 0.2);
    dWorldSetCFM(world, 1e-6);
    dWorldSetContactSurfaceLayer(world, 0.0002);
    dWorldSetContactMaxCorrectingVel(world, 0.5);
    dWorldSetAutoDisableFlag(world, 0);

    // Plane and four walls.
    dGeomID floor = dCreatePlane(space, 0, 0, 1, 0);
    infos.push_back(std::make_unique<GeomInfo>(GeomInfo{1.0, false}));
    dGeomSetData(floor, infos.back().get());
    for (const auto& wall : spec.arena.walls()) geom(wall.shape, nullptr, wall.offset, 0.5, false);

    // Robot: revolute links are bodies with hinges (velocity motors); fixed links merge into their parent.
    const auto& robot = spec.robot;
    std::map<std::string, Eigen::Isometry3d> world_from_link, body_from_link;
    std::map<std::string, dBodyID> link_body;
    double lowest = std::numeric_limits<double>::infinity();
    for (const auto& link : robot.links) {
      world_from_link[link.name] = link.parent.empty() ? robot.pose : world_from_link[link.parent] * link.parent_from_link;
      for (const auto& c : link.collisions) {
        lowest = std::min(lowest, xpersif::core::lowestPoint(c.shape, world_from_link[link.name] * c.offset));
      }
    }
    const double lift = std::isfinite(lowest) ? robot.pose.translation().z() - lowest + 0.0001 : 0;
    for (auto& e : world_from_link) e.second.translation().z() += lift;
    for (const auto& link : robot.links) {
      dBodyID body;
      if (link.joint_type == LinkSpec::JointType::Fixed) {
        body = link_body.at(link.parent);
        body_from_link[link.name] = body_from_link.at(link.parent) * link.parent_from_link;
      } else {
        body = dBodyCreate(world);
        dMass m;
        const Eigen::Matrix3d& i = link.inertia;
        if (i.trace() > 0 && i.determinant() > 0) {
          dMassSetParameters(&m, link.mass, 0, 0, 0, i(0, 0), i(1, 1), i(2, 2), i(0, 1), i(0, 2), i(1, 2));
        } else {
          dMassSetSphereTotal(&m, link.mass, 0.01);  // not used by the Khepera URDF (all have inertia)
        }
        dBodySetMass(body, &m);
        setPoseOf(body, world_from_link[link.name]);
        bodies.push_back(body);
        body_from_link[link.name] = Eigen::Isometry3d::Identity();
        if (link.joint_type == LinkSpec::JointType::Revolute) {
          dJointID hinge = dJointCreateHinge(world, nullptr);
          dJointAttach(hinge, body, link_body.at(link.parent));
          const Eigen::Vector3d anchor = world_from_link[link.name].translation();
          const Eigen::Vector3d axis = world_from_link[link.name].rotation() * link.axis.normalized();
          dJointSetHingeAnchor(hinge, anchor.x(), anchor.y(), anchor.z());
          dJointSetHingeAxis(hinge, axis.x(), axis.y(), axis.z());
          dJointSetHingeParam(hinge, dParamFMax, robot.max_wheel_torque);
          dJointSetHingeParam(hinge, dParamVel, 0.0);
          if (link.joint == robot.left_wheel_joint) left = hinge;
          if (link.joint == robot.right_wheel_joint) right = hinge;
        }
      }
      link_body[link.name] = body;
      const bool wheel = link.joint == robot.left_wheel_joint || link.joint == robot.right_wheel_joint;
      const bool slider = link.joint_type == LinkSpec::JointType::Fixed && link.mass == 0 && link.visuals.empty();
      const double friction = wheel ? robot.wheel_friction : slider ? 0.0 : robot.body_friction;
      for (const auto& c : link.collisions) geom(c.shape, body, body_from_link[link.name] * c.offset, friction, true);
    }

    // Objects (cubes).
    for (const auto& o : spec.objects) {
      dBodyID body = dBodyCreate(world);
      dMass m;
      dMassSetBoxTotal(&m, o.mass, o.shape.box_size.x(), o.shape.box_size.y(), o.shape.box_size.z());
      dBodySetMass(body, &m);
      Eigen::Isometry3d pose = o.pose;
      pose.translation().z() += -xpersif::core::lowestPoint(o.shape, pose) + 0.0001;
      setPoseOf(body, pose);
      geom(o.shape, body, Eigen::Isometry3d::Identity(), o.friction, false);
      bodies.push_back(body);
    }
  }

  ~BareWorld() {
    dJointGroupDestroy(contacts);
    dSpaceDestroy(space);
    dWorldDestroy(world);
  }

  static void nearCallback(void* data, dGeomID a, dGeomID b) {
    auto* self = static_cast<BareWorld*>(data);
    dBodyID ba = dGeomGetBody(a), bb = dGeomGetBody(b);
    if (ba && bb && dAreConnectedExcluding(ba, bb, dJointTypeContact)) return;
    if (ba == bb) return;
    const auto* ia = static_cast<const GeomInfo*>(dGeomGetData(a));
    const auto* ib = static_cast<const GeomInfo*>(dGeomGetData(b));
    if (ia->robot && ib->robot) return;
    dContact contact[8];
    const int n = dCollide(a, b, 8, &contact[0].geom, sizeof(dContact));
    const double mu = std::sqrt(ia->friction * ib->friction);
    for (int i = 0; i < n; ++i) {
      contact[i].surface.mode = dContactApprox1 | dContactSoftERP | dContactSoftCFM;
      contact[i].surface.mu = mu;
      contact[i].surface.soft_erp = 0.4;
      contact[i].surface.soft_cfm = 1e-5;
      dJointAttach(dJointCreateContact(self->world, self->contacts, &contact[i]), ba, bb);
    }
  }

  void step(double l, double r) {
    dJointSetHingeParam(left, dParamVel, l / spec.robot.wheel_radius);
    dJointSetHingeParam(right, dParamVel, r / spec.robot.wheel_radius);
    dSpaceCollide(space, this, &nearCallback);
    dWorldQuickStep(world, spec.physics.step);
    dJointGroupEmpty(contacts);
  }
};

using WallClock = std::chrono::steady_clock;

double seconds(WallClock::duration d) { return std::chrono::duration<double>(d).count(); }

struct Run {
  double wall = 0, rtf = 0;
  double x = 0, y = 0;  // robot root position at the end
};

Run runBare(const WorldSpec& spec, double sim_seconds) {
  dRandSetSeed(spec.physics.seed);  // PhysicsWorld keeps its own solver seed per world, starting from this
  BareWorld w(spec);
  const long steps = std::lround(sim_seconds / spec.physics.step);
  const auto start = WallClock::now();
  for (long i = 0; i < steps; ++i) w.step(kLeft, kRight);
  Run run;
  run.wall = seconds(WallClock::now() - start);
  run.rtf = steps * spec.physics.step / run.wall;
  const dReal* p = dBodyGetPosition(w.bodies[0]);
  run.x = p[0];
  run.y = p[1];
  return run;
}

Run runWorld(const WorldSpec& spec, double sim_seconds) {
  xpersif::core::PhysicsWorld w(spec);
  w.setWheelSpeeds(kLeft, kRight);
  const long steps = std::lround(sim_seconds / spec.physics.step);
  long blowups = 0;
  const auto start = WallClock::now();
  for (long i = 0; i < steps; ++i) blowups += !w.step().ok;
  Run run;
  run.wall = seconds(WallClock::now() - start);
  run.rtf = steps * spec.physics.step / run.wall;
  const Eigen::Vector3d p = w.bodyPose(spec.robot.name).translation();
  run.x = p.x();
  run.y = p.y();
  if (blowups) std::fprintf(stderr, "PhysicsWorld: %ld blow-ups\n", blowups);
  return run;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
}

int local(const std::string& path, double sim_seconds, int reps) {
  dInitODE2(0);
  dAllocateODEDataForThread(dAllocateMaskAll);
  const WorldSpec spec = xpersif::core::loadWorldFile(path);
  std::vector<double> bare, world;
  Run last_bare, last_world;
  runBare(spec, sim_seconds / 4);  // warm-up (caches, CPU frequency), not counted
  runWorld(spec, sim_seconds / 4);
  for (int r = 0; r < reps; ++r) {
    last_bare = runBare(spec, sim_seconds);
    bare.push_back(last_bare.rtf);
    std::printf("{\"run\":\"bare_ode\",\"rep\":%d,\"sim_s\":%.1f,\"wall_s\":%.3f,\"rtf\":%.3g,\"robot_x\":%.6f,\"robot_y\":%.6f}\n", r,
                sim_seconds, last_bare.wall, last_bare.rtf, last_bare.x, last_bare.y);
    last_world = runWorld(spec, sim_seconds);
    world.push_back(last_world.rtf);
    std::printf("{\"run\":\"physics_world\",\"rep\":%d,\"sim_s\":%.1f,\"wall_s\":%.3f,\"rtf\":%.3g,\"robot_x\":%.6f,\"robot_y\":%.6f}\n", r,
                sim_seconds, last_world.wall, last_world.rtf, last_world.x, last_world.y);
    std::fflush(stdout);
  }
  const double a = median(bare), b = median(world);
  std::printf("{\"summary\":\"local\",\"world\":\"%s\",\"step\":%g,\"iterations\":%d,\"bodies\":%zu,\"bare_rtf_median\":%.3g,"
              "\"world_rtf_median\":%.3g,\"world_overhead_pct\":%.1f,\"same_end_position\":%s,\"end_position_diff_m\":%.3g}\n",
              path.c_str(), spec.physics.step, spec.physics.iterations, spec.objects.size() + 3, a, b, (a / b - 1) * 100,
              (last_bare.x == last_world.x && last_bare.y == last_world.y) ? "true" : "false",
              std::hypot(last_bare.x - last_world.x, last_bare.y - last_world.y));
  return 0;
}

// ---- (c) a running xpersim node -----------------------------------------------------------------------

int node(int argc, char** argv, double wall_seconds, const std::string& status_topic, bool clock_subscriber) {
  ros::init(argc, argv, "sim_speed", ros::init_options::AnonymousName);
  ros::NodeHandle nh;
  ros::Publisher wheels = nh.advertise<xpersif::WheelSpeeds>("wheel_speeds", 1);
  struct Point {
    double wall, sim;
  };
  std::vector<Point> points;
  const std::regex t_re("t=([0-9.eE+-]+) s");
  ros::Subscriber status = nh.subscribe<xpersif::ComponentStatus>(status_topic, 100, [&](const xpersif::ComponentStatus::ConstPtr& s) {
    for (const auto& part : s->parts) {
      std::smatch m;
      if (part.name == "physics" && std::regex_search(part.message, m, t_re)) {
        points.push_back({s->header.stamp.toSec(), std::stod(m[1])});
      }
    }
  });
  std::uint64_t clocks = 0;
  ros::Subscriber clock;
  if (clock_subscriber) {
    clock = nh.subscribe<rosgraph_msgs::Clock>("/clock", 1000, [&](const rosgraph_msgs::Clock::ConstPtr&) { ++clocks; },
                                                ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }
  // Send the command until it has surely arrived, then measure.
  const ros::WallTime begin = ros::WallTime::now();
  xpersif::WheelSpeeds cmd;
  cmd.left = kLeft;
  cmd.right = kRight;
  while (ros::ok() && ros::WallTime::now() - begin < ros::WallDuration(1.0)) {
    wheels.publish(cmd);
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  points.clear();
  clocks = 0;
  const ros::WallTime start = ros::WallTime::now();
  while (ros::ok() && ros::WallTime::now() - start < ros::WallDuration(wall_seconds)) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
  if (points.size() < 2) {
    std::printf("{\"run\":\"xpersim_node\",\"error\":\"fewer than 2 status messages with t= on %s\"}\n", status_topic.c_str());
    return 2;
  }
  const double wall = points.back().wall - points.front().wall, sim = points.back().sim - points.front().sim;
  std::printf("{\"run\":\"xpersim_node\",\"clock_subscriber\":%s,\"wall_s\":%.3f,\"sim_s\":%.3f,\"rtf\":%.3g,\"clock_msgs_per_s\":%.0f}\n",
              clock_subscriber ? "true" : "false", wall, sim, sim / wall, clocks / (ros::WallTime::now() - start).toSec());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string what = argc > 1 ? argv[1] : "";
  if (what == "local" && argc > 2) {
    return local(argv[2], argc > 3 ? std::stod(argv[3]) : 60.0, argc > 4 ? std::stoi(argv[4]) : 3);
  }
  if (what == "node") {
    return node(argc, argv, argc > 2 ? std::stod(argv[2]) : 10.0, argc > 3 ? argv[3] : "/xpersim/status",
                argc > 4 && std::string(argv[4]) == "1");
  }
  std::fprintf(stderr, "usage: sim_speed local <world.yaml> [sim_seconds] [reps] | sim_speed node [wall_s] [status_topic] [clock_sub 0|1]\n");
  return 1;
}
