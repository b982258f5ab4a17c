// Placing a body: whether the robot or an object may stand at a pose (checkPlacement), and putting it there
// (setPose) (physics_world.h).
#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "physics_internal.h"
#include "xpersif/core/common/validation.h"

namespace xpersif::core {

using namespace physics_detail;

namespace {

/// Copies of the geoms of the bodies a placement would move, at the poses they would have there, outside every
/// space: the check collides these and never moves a body. (Moving a body and back is not bit for bit: ODE
/// normalises the quaternion it is given, so a refused set_pose would change the world in its last bits.)
class PlacementProbe {
 public:
  PlacementProbe() = default;
  PlacementProbe(const PlacementProbe&) = delete;
  PlacementProbe& operator=(const PlacementProbe&) = delete;
  ~PlacementProbe() {
    for (dGeomID g : geoms_) dGeomDestroy(g);
  }

  /// Each geom of body, as it would be with the body at world_from_body.
  void add(dBodyID body, const Eigen::Isometry3d& world_from_body) {
    for (dGeomID g = dBodyGetFirstGeom(body); g; g = dBodyGetNextGeom(g)) {
      dGeomID copy = nullptr;
      switch (dGeomGetClass(g)) {
        case dBoxClass: {
          dVector3 size;
          dGeomBoxGetLengths(g, size);
          copy = dCreateBox(nullptr, size[0], size[1], size[2]);
          break;
        }
        case dCylinderClass: {
          dReal radius, length;
          dGeomCylinderGetParams(g, &radius, &length);
          copy = dCreateCylinder(nullptr, radius, length);
          break;
        }
        case dSphereClass: copy = dCreateSphere(nullptr, dGeomSphereGetRadius(g)); break;
        default: throw std::logic_error("a body's geom of ODE class " + std::to_string(dGeomGetClass(g)) + " cannot be probed");
      }
      geoms_.push_back(copy);
      const dReal* offset_position = dGeomGetOffsetPosition(g);
      dQuaternion offset_q;
      dGeomGetOffsetQuaternion(g, offset_q);
      Eigen::Isometry3d body_from_geom = Eigen::Isometry3d::Identity();
      body_from_geom.translation() = Eigen::Vector3d(offset_position[0], offset_position[1], offset_position[2]);
      body_from_geom.linear() = Eigen::Quaterniond(offset_q[0], offset_q[1], offset_q[2], offset_q[3]).toRotationMatrix();
      const Eigen::Isometry3d t = world_from_body * body_from_geom;
      dGeomSetPosition(copy, t.translation().x(), t.translation().y(), t.translation().z());
      const Eigen::Quaterniond q(t.rotation());
      const dQuaternion dq = {q.w(), q.x(), q.y(), q.z()};
      dGeomSetQuaternion(copy, dq);
    }
  }

  const std::vector<dGeomID>& geoms() const { return geoms_; }

 private:
  std::vector<dGeomID> geoms_;
};

std::string point(const Eigen::Vector3d& p) {
  return "(" + describeNumber(p.x()) + ", " + describeNumber(p.y()) + ", " + describeNumber(p.z()) + ")";
}

std::string millimetres(double metres) { return describeNumber(std::round(metres * 1e4) / 10) + " mm"; }

/// The bodies a placement moves and the pose each would take.
struct Placement {
  std::vector<dBodyID> bodies;
  std::vector<Eigen::Isometry3d> poses;
};

/// The robot's bodies, every link moved rigidly with the root (the root at @p pose), the wheels keeping their
/// place relative to the body; with @p on_floor, the root's z at 0 for now (checkPlacement sets it down).
Placement robotPlacement(const std::vector<dBodyID>& robot_bodies, const Eigen::Isometry3d& pose, bool on_floor) {
  Placement placement;
  Eigen::Isometry3d target = pose;
  if (on_floor) target.translation().z() = 0;
  const Eigen::Isometry3d delta = target * poseOf(robot_bodies[0]).inverse();
  for (dBodyID b : robot_bodies) {
    placement.bodies.push_back(b);
    placement.poses.push_back(delta * poseOf(b));
  }
  return placement;
}

Placement objectPlacement(dBodyID body, const Eigen::Isometry3d& pose, bool on_floor) {
  Placement placement;
  placement.bodies.push_back(body);
  placement.poses.push_back(pose);
  if (on_floor) placement.poses.back().translation().z() = 0;
  return placement;
}

std::unique_ptr<PlacementProbe> probeAt(const Placement& placement) {
  auto probe = std::make_unique<PlacementProbe>();
  for (std::size_t i = 0; i < placement.bodies.size(); ++i) probe->add(placement.bodies[i], placement.poses[i]);
  return probe;
}

/// The bounding box of a probe's geoms: lo and hi in x, y, z.
struct Extents {
  double lo[3], hi[3];
};

Extents extentsOf(const PlacementProbe& probe) {
  Extents e;
  for (int k = 0; k < 3; ++k) {
    e.lo[k] = std::numeric_limits<double>::infinity();
    e.hi[k] = -e.lo[k];
  }
  for (dGeomID g : probe.geoms()) {
    dReal aabb[6];
    dGeomGetAABB(g, aabb);
    for (int k = 0; k < 3; ++k) {
      e.lo[k] = std::min(e.lo[k], static_cast<double>(aabb[2 * k]));
      e.hi[k] = std::max(e.hi[k], static_cast<double>(aabb[2 * k + 1]));
    }
  }
  return e;
}

/// Invalid with a sentence unless @p body is a known name and @p pose finite (z only without @p on_floor) with a
/// unit quaternion.
PhysicsWorld::PlacementCheck checkPlacementRequest(const WorldSpec& spec, const std::string& body,
                                                   const Eigen::Isometry3d& pose, bool on_floor) {
  PhysicsWorld::PlacementCheck check;
  if (const std::string why = checkKnownName("body", body, spec.bodyNames()); !why.empty()) {
    check.problem = PhysicsWorld::PlacementCheck::Problem::Invalid;
    check.why = why;
    return check;
  }
  const Eigen::Vector3d p = pose.translation();
  const Eigen::Quaterniond q(pose.rotation());
  std::string why = checkFinite("pose.x", p.x());
  if (why.empty()) why = checkFinite("pose.y", p.y());
  if (why.empty() && !on_floor) why = checkFinite("pose.z", p.z());
  if (why.empty()) why = checkUnitQuaternion("pose.orientation", q.x(), q.y(), q.z(), q.w());
  if (!why.empty()) {
    check.problem = PhysicsWorld::PlacementCheck::Problem::Invalid;
    check.why = why;
  }
  return check;
}

/// Invalid with a sentence when @p what (its origin at @p where, its geometry within @p box) would reach outside
/// the arena's walls, under the floor or too high above it.
PhysicsWorld::PlacementCheck checkBounds(const ArenaSpec& arena, const std::string& what, const Eigen::Vector3d& where,
                                         const Extents& box) {
  const double* lo = box.lo;
  const double* hi = box.hi;
  PhysicsWorld::PlacementCheck check;
  const double hx = arena.size_x / 2, hy = arena.size_y / 2;
  if (lo[0] < -hx - kPlacementTolerance || hi[0] > hx + kPlacementTolerance || lo[1] < -hy - kPlacementTolerance ||
      hi[1] > hy + kPlacementTolerance) {
    check.problem = PhysicsWorld::PlacementCheck::Problem::Invalid;
    check.why = what + " at " + point(where) + " would reach x " + describeNumber(lo[0]) + ".." + describeNumber(hi[0]) +
                ", y " + describeNumber(lo[1]) + ".." + describeNumber(hi[1]) + ", outside the arena (inside its walls |x| <= " +
                describeNumber(hx) + ", |y| <= " + describeNumber(hy) + ")";
  } else if (lo[2] < -kPlacementTolerance) {
    check.problem = PhysicsWorld::PlacementCheck::Problem::Invalid;
    check.why = what + " at " + point(where) + " would reach " + millimetres(-lo[2]) +
                " under the floor; at this orientation its origin must be at z >= " + describeNumber(where.z() - lo[2]) +
                " (or set it down on the floor with on_floor)";
  } else if (lo[2] > kMaxPlacementHeight) {
    check.problem = PhysicsWorld::PlacementCheck::Problem::Invalid;
    check.why = what + " at " + point(where) + " would float " + describeNumber(lo[2]) + " m above the floor; at most " +
                describeNumber(kMaxPlacementHeight) + " m";
  }
  return check;
}

/// How deep the probe's geoms reach into any other body's geometry in @p space (the robot's links, the objects),
/// and into which (@p other; nullptr and 0 when they touch nothing). Walls lie outside the arena and the floor
/// below it: checkBounds covers them.
double deepestOverlap(dSpaceID space, const PlacementProbe& probe, const std::vector<dBodyID>& moved, dBodyID& other) {
  double deepest = 0;
  other = nullptr;
  const int n = dSpaceGetNumGeoms(space);
  for (int i = 0; i < n; ++i) {
    dGeomID g = dSpaceGetGeom(space, i);
    dBodyID b = dGeomGetBody(g);
    if (!b || std::find(moved.begin(), moved.end(), b) != moved.end()) continue;
    for (dGeomID m : probe.geoms()) {
      dContactGeom contact[kMaxContacts];
      const int hits = dCollide(m, g, kMaxContacts, contact, sizeof(dContactGeom));
      for (int k = 0; k < hits; ++k) {
        if (contact[k].depth > deepest) {
          deepest = contact[k].depth;
          other = b;
        }
      }
    }
  }
  return deepest;
}

}  // namespace

PhysicsWorld::PlacementCheck PhysicsWorld::checkPlacement(const std::string& body, const Eigen::Isometry3d& pose,
                                                          bool on_floor, Eigen::Isometry3d* placed) const {
  PlacementCheck check = checkPlacementRequest(spec_, body, pose, on_floor);
  if (!check.ok()) return check;
  Impl& w = *impl_;
  initOde();
  const bool robot = body == spec_.robot.name;
  Placement placement =
      robot ? robotPlacement(w.robot_bodies, pose, on_floor) : objectPlacement(w.body(body), pose, on_floor);
  std::unique_ptr<PlacementProbe> probe = probeAt(placement);
  Extents box = extentsOf(*probe);
  if (on_floor) {  // set down resting on the floor, as the world file's objects start
    const double lift = kRestClearance - box.lo[2];
    for (auto& t : placement.poses) t.translation().z() += lift;
    probe = probeAt(placement);
    box = extentsOf(*probe);
  }
  const std::string what = robot ? "the robot " + body : body;
  const Eigen::Vector3d where = placement.poses.front().translation();
  check = checkBounds(spec_.arena, what, where, box);
  if (check.ok()) {
    dBodyID other = nullptr;
    const double deepest = deepestOverlap(w.space, *probe, placement.bodies, other);
    if (other && deepest > kPlacementTolerance) {
      check.problem = PlacementCheck::Problem::Overlap;
      check.why = what + " at " + point(where) + " would overlap " + w.describeBody(other) + " by " +
                  millimetres(deepest) + "; choose a free place";
    }
  }
  if (placed) *placed = placement.poses.front();
  return check;
}

void PhysicsWorld::setPose(const std::string& body, const Eigen::Isometry3d& pose, bool on_floor) {
  known_state_.clear();
  Eigen::Isometry3d placed;
  const PlacementCheck check = checkPlacement(body, pose, on_floor, &placed);
  if (!check.ok()) throw ValidationError(check.why);
  Impl& w = *impl_;
  auto place = [](dBodyID b, const Eigen::Isometry3d& t) {
    setPoseOf(b, t);
    dBodySetLinearVel(b, 0, 0, 0);
    dBodySetAngularVel(b, 0, 0, 0);
    dBodySetForce(b, 0, 0, 0);
    dBodySetTorque(b, 0, 0, 0);
  };
  if (body == spec_.robot.name) {
    // Move every link rigidly with the root, keeping the wheels where they are relative to the body.
    const Eigen::Isometry3d delta = placed * poseOf(w.robot_bodies[0]).inverse();
    for (dBodyID b : w.robot_bodies) place(b, delta * poseOf(b));
    w.odometry = Odometry{};
    w.odometry.x = placed.translation().x();
    w.odometry.y = placed.translation().y();
    w.odometry.yaw = yawOf(placed);
  } else {
    place(w.body(body), placed);
  }
  w.saveGoodState();
  w.updateFallHeight();
}

}  // namespace xpersif::core
