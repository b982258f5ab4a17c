// The robot's wheels and what it senses of itself and around it: wheel commands, the wheels' angles and the
// odometry integrated from them, the IR rays (physics_world.h).
#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "physics_internal.h"
#include "xpersif/core/common/validation.h"

namespace xpersif::core {

using namespace physics_detail;

void PhysicsWorld::Impl::applyWheelCommands() {
  const double r = spec.robot.wheel_radius;
  if (left_wheel) dJointSetHingeParam(left_wheel, dParamVel, left_command / r);
  if (right_wheel) dJointSetHingeParam(right_wheel, dParamVel, right_command / r);
}

double PhysicsWorld::Impl::wheelRate(dJointID wheel) const {
  if (!wheel) return 0;
  return dJointGetHingeAngleRate(wheel);
}

void PhysicsWorld::Impl::integrateOdometry(double dt) {
  const double left_rate = wheelRate(left_wheel), right_rate = wheelRate(right_wheel);
  left_angle += left_rate * dt;
  right_angle += right_rate * dt;
  const double r = spec.robot.wheel_radius;
  const double v = r * (left_rate + right_rate) / 2;
  const double omega = r * (right_rate - left_rate) / spec.robot.wheel_separation;
  Odometry& o = odometry;
  o.x += v * std::cos(o.yaw + omega * dt / 2) * dt;
  o.y += v * std::sin(o.yaw + omega * dt / 2) * dt;
  o.yaw = std::remainder(o.yaw + omega * dt, 2 * M_PI);
  o.linear = v;
  o.angular = omega;
}

void PhysicsWorld::setWheelSpeeds(double left, double right) {
  requireFinite("left wheel speed", left);
  requireFinite("right wheel speed", right);
  const double max = spec_.robot.max_wheel_speed;
  const double l = std::clamp(left, -max, max), r = std::clamp(right, -max, max);
  // The same command again changes nothing: a standing world stays the state it was checkpointed in.
  if (l != impl_->left_command || r != impl_->right_command) known_state_.clear();
  impl_->left_command = l;
  impl_->right_command = r;
}

void PhysicsWorld::setVelocity(double linear, double angular) {
  requireFinite("linear velocity", linear);
  requireFinite("angular velocity", angular);
  const double half = spec_.robot.wheel_separation / 2;
  setWheelSpeeds(linear - angular * half, linear + angular * half);
}

PhysicsWorld::WheelState PhysicsWorld::wheels() const {
  WheelState s;
  s.left_angle = impl_->left_angle;
  s.right_angle = impl_->right_angle;
  s.left_rate = impl_->wheelRate(impl_->left_wheel);
  s.right_rate = impl_->wheelRate(impl_->right_wheel);
  s.left_command = impl_->left_command;
  s.right_command = impl_->right_command;
  return s;
}

PhysicsWorld::Odometry PhysicsWorld::odometry() const { return impl_->odometry; }

std::vector<double> PhysicsWorld::irRanges() const {
  initOde();
  const Impl& w = *impl_;
  std::vector<double> ranges;
  struct Query {
    const Impl* world;
    double nearest;
  };
  for (std::size_t i = 0; i < w.ir_rays.size(); ++i) {
    const Eigen::Isometry3d sensor = poseOf(w.ir_mounts[i].first) * w.ir_mounts[i].second;
    const Eigen::Vector3d origin = sensor.translation();
    const Eigen::Vector3d direction = sensor.rotation().col(0);
    dGeomRaySet(w.ir_rays[i], origin.x(), origin.y(), origin.z(), direction.x(), direction.y(), direction.z());
    Query query{&w, spec_.robot.ir_range};
    dSpaceCollide2(w.ir_rays[i], reinterpret_cast<dGeomID>(w.space), &query, [](void* data, dGeomID ray, dGeomID other) {
      auto* q = static_cast<Query*>(data);
      const auto* info = static_cast<const GeomInfo*>(dGeomGetData(other));
      if (info && info->robot) return;
      dContactGeom hit;
      if (dCollide(ray, other, 1, &hit, sizeof(dContactGeom)) > 0) q->nearest = std::min(q->nearest, static_cast<double>(hit.depth));
    });
    ranges.push_back(query.nearest);
  }
  return ranges;
}

}  // namespace xpersif::core
