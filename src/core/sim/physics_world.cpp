// XPERSim's physics world: its bodies, stepping, and what happens when a step blows up (physics_world.h). The
// other concerns have their own files (physics_internal.h lists them).
#include "xpersif/core/sim/physics_world.h"

#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>

#include "physics_internal.h"
#include "xpersif/core/common/validation.h"

namespace xpersif::core {

using namespace physics_detail;

namespace physics_detail {

void initOde() {
  static std::once_flag once;
  std::call_once(once, [] { dInitODE2(0); });
  // ODE's collision code needs per-thread data in every thread that steps a world.
  thread_local bool allocated = false;
  if (!allocated) allocated = dAllocateODEDataForThread(dAllocateMaskAll) != 0;
}

}  // namespace physics_detail

namespace {

/// The lowest point of a body's collision geometry (world z), from ODE's bounding boxes, which are exact
/// in z for boxes, spheres and upright or tilted cylinders' end discs.
double lowestOf(dBodyID b) {
  double lowest = std::numeric_limits<double>::infinity();
  for (dGeomID g = dBodyGetFirstGeom(b); g; g = dBodyGetNextGeom(g)) {
    dReal aabb[6];
    dGeomGetAABB(g, aabb);
    lowest = std::min(lowest, static_cast<double>(aabb[4]));
  }
  return std::isfinite(lowest) ? lowest : dBodyGetPosition(b)[2];
}

double speedOf(dBodyID b) {
  const dReal* v = dBodyGetLinearVel(b);
  return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

Eigen::Vector3d toVector(const dReal* v) { return Eigen::Vector3d(v[0], v[1], v[2]); }

}  // namespace

void PhysicsWorld::Impl::forEachBody(const std::function<void(dBodyID)>& f) const {
  for (dBodyID b : robot_bodies) f(b);
  for (const auto& o : objects) f(o.second);
}

dBodyID PhysicsWorld::Impl::body(const std::string& name) const {
  if (name == spec.robot.name) return robot_bodies[0];
  for (const auto& o : objects) {
    if (o.first == name) return o.second;
  }
  requireKnownName("body", name, spec.bodyNames());  // throws with the list of known names
  return nullptr;
}

std::string PhysicsWorld::Impl::bodyName(dBodyID body) const {
  for (const auto& [link, b] : link_body) {
    if (b == body && body_from_link.at(link).isApprox(Eigen::Isometry3d::Identity())) return spec.robot.name + "/" + link;
  }
  for (const auto& o : objects) {
    if (o.second == body) return o.first;
  }
  return "a body";
}

std::string PhysicsWorld::Impl::describeBody(dBodyID b) const {
  if (std::find(robot_bodies.begin(), robot_bodies.end(), b) != robot_bodies.end()) return "the robot " + spec.robot.name;
  return bodyName(b);
}

void PhysicsWorld::Impl::saveGoodState() {
  good_state.clear();
  forEachBody([&](dBodyID b) {
    BodyState s;
    std::copy_n(dBodyGetPosition(b), 3, s.position);
    std::copy_n(dBodyGetQuaternion(b), 4, s.orientation);
    std::copy_n(dBodyGetLinearVel(b), 3, s.linear);
    std::copy_n(dBodyGetAngularVel(b), 3, s.angular);
    good_state.push_back(s);
  });
  good_time = time;
  good_left_angle = left_angle;
  good_right_angle = right_angle;
  good_odometry = odometry;
}

void PhysicsWorld::Impl::restoreGoodState() {
  std::size_t i = 0;
  forEachBody([&](dBodyID b) {
    const BodyState& s = good_state[i++];
    dBodySetPosition(b, s.position[0], s.position[1], s.position[2]);
    dBodySetQuaternion(b, s.orientation);
    dBodySetLinearVel(b, s.linear[0], s.linear[1], s.linear[2]);
    dBodySetAngularVel(b, s.angular[0], s.angular[1], s.angular[2]);
    dBodySetForce(b, 0, 0, 0);
    dBodySetTorque(b, 0, 0, 0);
  });
  time = good_time;
  left_angle = good_left_angle;
  right_angle = good_right_angle;
  odometry = good_odometry;
}

PhysicsWorld::Impl::Trouble PhysicsWorld::Impl::pendingForceProblem() const {
  Trouble trouble;
  forEachBody([&](dBodyID b) {
    if (!trouble.none()) return;
    const dReal* f = dBodyGetForce(b);
    const dReal* t = dBodyGetTorque(b);
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(f[k]) || !std::isfinite(t[k])) {
        trouble = {b, bodyName(b) + " has a non-finite force or torque"};
        return;
      }
    }
  });
  return trouble;
}

double PhysicsWorld::Impl::speedLimit() const {
  return spec.physics.max_speed + 2 * std::sqrt(2 * std::fabs(spec.physics.gravity) * fall_height);
}

void PhysicsWorld::Impl::updateFallHeight() {
  bool calm = true;
  double highest = 0;
  forEachBody([&](dBodyID b) {
    calm = calm && speedOf(b) <= spec.physics.max_speed;
    highest = std::max(highest, lowestOf(b));
  });
  if (calm) fall_height = highest;
}

PhysicsWorld::Impl::Trouble PhysicsWorld::Impl::health() const {
  Trouble trouble;
  const double limit = speedLimit();
  forEachBody([&](dBodyID b) {
    if (!trouble.none()) return;
    const dReal* p = dBodyGetPosition(b);
    const dReal* q = dBodyGetQuaternion(b);
    const dReal* v = dBodyGetLinearVel(b);
    const dReal* w = dBodyGetAngularVel(b);
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(p[k]) || !std::isfinite(v[k]) || !std::isfinite(w[k]) || !std::isfinite(q[k]) || !std::isfinite(q[3])) {
        trouble = {b, bodyName(b) + " has a non-finite position, orientation or velocity"};
        return;
      }
    }
    const double speed = speedOf(b);
    if (speed > limit) {
      trouble = {b, bodyName(b) + " moves at " + describeNumber(speed) + " m/s, faster than " + describeNumber(limit) +
                        " m/s (physics.max_speed " + describeNumber(spec.physics.max_speed) +
                        (fall_height > 0 ? " plus twice what a fall from " + describeNumber(fall_height) + " m gives"
                                         : std::string()) +
                        ")"};
    }
  });
  return trouble;
}

void PhysicsWorld::Impl::putAtRest(dBodyID body) {
  auto rest = [](dBodyID b) {
    dBodySetLinearVel(b, 0, 0, 0);
    dBodySetAngularVel(b, 0, 0, 0);
    dBodySetForce(b, 0, 0, 0);
    dBodySetTorque(b, 0, 0, 0);
  };
  if (std::find(robot_bodies.begin(), robot_bodies.end(), body) != robot_bodies.end()) {
    for (dBodyID b : robot_bodies) rest(b);
  } else {
    rest(body);
  }
}

PhysicsWorld::Impl::Trouble PhysicsWorld::Impl::attempt(double dt) {
  Trouble trouble = pendingForceProblem();
  if (!trouble.none()) return trouble;
  dSpaceCollide(space, this, &Impl::nearCallback);
  updateContactEpisodes();
  createContactJoints();
  // ODE's solver shuffles constraints with a process-wide generator; keep a private seed per world.
  dRandSetSeed(random_seed);
  dWorldQuickStep(world, dt);
  random_seed = dRandGetSeed();
  dJointGroupEmpty(contacts);
  return health();
}

// A real blow-up: undo the step, then resolve it so that the next try is a different state (never the same
// failing step again): first the offending body at rest at its last good pose, then every body.
bool PhysicsWorld::Impl::resolveBlowUp(const Trouble& trouble, unsigned long seed, double dt, StepResult& result) {
  result.ok = false;
  result.problem = "physics blow-up at t=" + describeNumber(time) + " s: " + trouble.what;
  restoreGoodState();
  random_seed = seed;
  putAtRest(trouble.body ? trouble.body : robot_bodies.front());
  const std::string rested = trouble.body ? describeBody(trouble.body) : std::string("the robot");
  const Trouble again = attempt(dt);
  if (++blow_ups_in_a_row >= kMaxBlowUpsInARow) {
    halt(seed, result);
    result.problem += "; the world blew up in " + std::to_string(kMaxBlowUpsInARow) +
                      " steps in a row: it stays at its last good state, at rest, until a body is moved or the world reset";
    return false;
  }
  if (again.none()) {
    result.problem += "; the step was undone and " + rested + " put at rest at its last good pose";
    return true;
  }
  restAll(seed);
  const Trouble still = attempt(dt);
  if (still.none()) {
    result.problem += "; with " + rested + " at rest it blew up again (" + again.what +
                      "), so every body was put at rest at its last good pose";
    return true;
  }
  halt(seed, result);
  result.problem += "; it blows up even with every body at rest (" + still.what +
                    "): the world stays at its last good state, at rest, until a body is moved or the world reset";
  return false;
}

void PhysicsWorld::Impl::restAll(unsigned long seed) {
  restoreGoodState();
  random_seed = seed;
  forEachBody([&](dBodyID b) { putAtRest(b); });
}

void PhysicsWorld::Impl::halt(unsigned long seed, StepResult& result) {
  restAll(seed);
  saveGoodState();
  blow_ups_in_a_row = 0;
  result.halted = true;
}

PhysicsWorld::PhysicsWorld(WorldSpec spec)
    : spec_(std::move(spec)), redraw_seed_(spec_.physics.seed), impl_(std::make_unique<Impl>(spec_)) {
  impl_->redraw_seed = redraw_seed_;
  impl_->build();
  scene_ = buildScene();
}

PhysicsWorld::~PhysicsWorld() = default;

void PhysicsWorld::reset() {
  known_state_.clear();
  impl_->destroy();
  impl_ = std::make_unique<Impl>(spec_);
  impl_->redraw_seed = redraw_seed_;
  impl_->build();
}

PhysicsWorld::StepResult PhysicsWorld::step() {
  known_state_.clear();
  initOde();
  Impl& w = *impl_;
  w.applyWheelCommands();
  const double dt = spec_.physics.step;
  const unsigned long seed = w.random_seed;
  StepResult result;
  const Impl::Trouble trouble = w.attempt(dt);
  if (trouble.none()) {
    w.blow_ups_in_a_row = 0;
  } else if (!w.resolveBlowUp(trouble, seed, dt, result)) {
    return result;  // halted: time does not advance
  }
  w.integrateOdometry(dt);
  w.time += dt;
  ++w.steps;
  w.saveGoodState();
  w.updateFallHeight();
  return result;
}

double PhysicsWorld::time() const { return impl_->time; }

std::uint64_t PhysicsWorld::stepCount() const { return impl_->steps; }

Eigen::Isometry3d PhysicsWorld::bodyPose(const std::string& body) const { return poseOf(impl_->body(body)); }

Eigen::Vector3d PhysicsWorld::bodyLinearVelocity(const std::string& body) const {
  return toVector(dBodyGetLinearVel(impl_->body(body)));
}

Eigen::Vector3d PhysicsWorld::bodyAngularVelocity(const std::string& body) const {
  return toVector(dBodyGetAngularVel(impl_->body(body)));
}

FrameTransforms PhysicsWorld::dynamicTransforms() const {
  FrameTransforms out;
  const Impl& w = *impl_;
  for (const auto& link : spec_.robot.links) {
    if (link.joint_type == LinkSpec::JointType::Fixed) continue;
    const Eigen::Isometry3d world_from_link = poseOf(w.link_body.at(link.name));
    if (link.parent.empty()) {
      out[link.name] = world_from_link;
    } else {
      const Eigen::Isometry3d world_from_parent =
          poseOf(w.link_body.at(link.parent)) * w.body_from_link.at(link.parent);
      out[link.name] = world_from_parent.inverse() * world_from_link;
    }
  }
  for (const auto& o : w.objects) out[o.first] = poseOf(o.second);
  return out;
}

std::string PhysicsWorld::checkHealth() const { return impl_->health().what; }

void PhysicsWorld::injectFault(const std::string& body, bool explode) {
  known_state_.clear();
  dBodyID b = impl_->body(body);
  const double f = explode ? 1e9 : std::numeric_limits<double>::quiet_NaN();
  dBodyAddForce(b, f, f, 0);
}

}  // namespace xpersif::core
