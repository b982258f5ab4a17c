#include "xpersif/core/sim/physics_world.h"

#include <ode/ode.h>

#include <algorithm>
#include <array>
#include <functional>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "xpersif/core/common/random_stream.h"
#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

void initOde() {
  static std::once_flag once;
  std::call_once(once, [] { dInitODE2(0); });
  // ODE's collision code needs per-thread data in every thread that steps a world.
  thread_local bool allocated = false;
  if (!allocated) allocated = dAllocateODEDataForThread(dAllocateMaskAll) != 0;
}

Eigen::Isometry3d poseOf(dBodyID body) {
  const dReal* p = dBodyGetPosition(body);
  const dReal* q = dBodyGetQuaternion(body);  // w, x, y, z
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
  t.linear() = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  return t;
}

void setPoseOf(dBodyID body, const Eigen::Isometry3d& t) {
  const Eigen::Vector3d p = t.translation();
  const Eigen::Quaterniond q(t.rotation());
  dBodySetPosition(body, p.x(), p.y(), p.z());
  const dQuaternion dq = {q.w(), q.x(), q.y(), q.z()};
  dBodySetQuaternion(body, dq);
}

void setGeomOffset(dGeomID geom, const Eigen::Isometry3d& t) {
  dGeomSetOffsetPosition(geom, t.translation().x(), t.translation().y(), t.translation().z());
  const Eigen::Quaterniond q(t.rotation());
  const dQuaternion dq = {q.w(), q.x(), q.y(), q.z()};
  dGeomSetOffsetQuaternion(geom, dq);
}

dGeomID createGeom(dSpaceID space, const Shape& shape) {
  switch (shape.type) {
    case Shape::Type::Box: return dCreateBox(space, shape.box_size.x(), shape.box_size.y(), shape.box_size.z());
    case Shape::Type::Cylinder: return dCreateCylinder(space, shape.radius, shape.length);
    case Shape::Type::Sphere: return dCreateSphere(space, shape.radius);
  }
  return nullptr;
}

struct BodyState {
  dVector3 position, linear, angular;
  dQuaternion orientation;
};

// Per-geom contact data: friction coefficient, whether it belongs to the robot, and the object it belongs to
// (an index into Impl::object_states, -1 for none) whose frictions then hold.
struct GeomInfo {
  double friction = 1.0;
  bool robot = false;
  bool floor = false;
  int object = -1;
};

// An object's frictions now: the file's, or the last draw of friction_redraw; and its contact episodes.
struct ObjectState {
  double friction_x = 0.5, friction_y = 0.5;
  int episodes = 0;
  double last_touch = -1;  // simulated time of the last step the robot touched it; < 0: never
  bool touched = false;    // during the current step
};

// A contact found by the collision pass, turned into a joint once every touch of the step is known.
struct PendingContact {
  dContact contact;
  dBodyID a, b;
  const GeomInfo *ia, *ib;
};

constexpr int kMaxContacts = 8;
constexpr double kPlacementTolerance = 0.001;  ///< m: how far a placed body may reach into the floor or another body
constexpr double kRestClearance = 0.0001;      ///< m: a body set down on the floor hovers this much above it
constexpr double kMaxPlacementHeight = 10.0;   ///< m: the highest a body may be placed (its lowest point)
constexpr int kMaxBlowUpsInARow = 10;          ///< resolved blow-ups in consecutive steps before the world halts
constexpr double kSlipSpeed = 1e-3;  ///< m/s: a contact slipping slower than this is taken to be at rest
constexpr double kBallSpinDamping = 3.0;  ///< 1/s: how fast a ball's spin decays (ODE has no rolling resistance)

}  // namespace

struct PhysicsWorld::Impl {
  const WorldSpec& spec;
  dWorldID world = nullptr;
  dSpaceID space = nullptr;
  dJointGroupID contacts = nullptr;

  std::vector<dBodyID> robot_bodies;                 // index 0: the root link
  std::map<std::string, dBodyID> link_body;          // every link -> the body it moves with
  std::map<std::string, Eigen::Isometry3d> body_from_link;  // link pose in that body's frame
  std::map<std::string, dJointID> link_joint;        // revolute links -> hinge joint
  std::vector<std::pair<std::string, dBodyID>> objects;
  std::vector<ObjectState> object_states;  // parallel to objects
  std::vector<std::unique_ptr<GeomInfo>> geom_infos;
  std::vector<PendingContact> pending;
  std::uint64_t redraw_seed = 1;

  dJointID left_wheel = nullptr, right_wheel = nullptr;
  double left_command = 0, right_command = 0;  // rim speeds
  double left_angle = 0, right_angle = 0;
  Odometry odometry;

  std::vector<dGeomID> ir_rays;
  std::vector<std::pair<dBodyID, Eigen::Isometry3d>> ir_mounts;

  double time = 0;
  std::uint64_t steps = 0;
  unsigned long random_seed = 1;

  std::vector<BodyState> good_state;
  double good_time = 0, good_left_angle = 0, good_right_angle = 0;
  Odometry good_odometry;
  /// The highest any body's lowest point stood above the floor when every body last moved slower than
  /// max_speed: a fall from there is legal, and bounds how fast a body may legally move (speedLimit()).
  double fall_height = 0;
  /// Steps in a row that blew up (each resolved): a world that keeps blowing up is halted, not nursed forever.
  int blow_ups_in_a_row = 0;

  /// What went wrong in a step, and with which body (nullptr when nothing did).
  struct Trouble {
    dBodyID body = nullptr;
    std::string what;
    bool none() const { return what.empty(); }
  };

  explicit Impl(const WorldSpec& s) : spec(s) {}
  ~Impl() { destroy(); }

  void destroy() {
    for (auto ray : ir_rays) dGeomDestroy(ray);
    ir_rays.clear();
    if (contacts) dJointGroupDestroy(contacts);
    if (space) dSpaceDestroy(space);  // destroys its geoms (cleanup mode is on)
    if (world) dWorldDestroy(world);  // destroys bodies and joints
    contacts = nullptr;
    space = nullptr;
    world = nullptr;
    robot_bodies.clear();
    link_body.clear();
    body_from_link.clear();
    link_joint.clear();
    objects.clear();
    object_states.clear();
    geom_infos.clear();
    pending.clear();
    ir_mounts.clear();
  }

  dGeomID addGeom(const Shape& shape, dBodyID body, const Eigen::Isometry3d& offset, double friction, bool robot,
                  int object = -1) {
    dGeomID geom = createGeom(space, shape);
    geom_infos.push_back(std::make_unique<GeomInfo>(GeomInfo{friction, robot, false, object}));
    dGeomSetData(geom, geom_infos.back().get());
    if (body) {
      dGeomSetBody(geom, body);
      setGeomOffset(geom, offset);
    } else {
      dGeomSetPosition(geom, offset.translation().x(), offset.translation().y(), offset.translation().z());
    }
    return geom;
  }

  void build() {
    initOde();
    random_seed = spec.physics.seed;
    world = dWorldCreate();
    space = dHashSpaceCreate(nullptr);
    contacts = dJointGroupCreate(0);
    dWorldSetGravity(world, 0, 0, spec.physics.gravity);
    dWorldSetQuickStepNumIterations(world, spec.physics.iterations);
    dWorldSetERP(world, 0.2);
    dWorldSetCFM(world, 1e-6);
    dWorldSetContactSurfaceLayer(world, 0.0002);
    dWorldSetContactMaxCorrectingVel(world, 0.5);
    dWorldSetAutoDisableFlag(world, 0);  // disabling bodies would make results depend on history

    buildArena();
    buildRobot();
    for (const auto& object : spec.objects) buildObject(object);
    saveGoodState();
    updateFallHeight();
  }

  void buildArena() {
    const ArenaSpec& a = spec.arena;
    dGeomID floor = dCreatePlane(space, 0, 0, 1, 0);
    geom_infos.push_back(std::make_unique<GeomInfo>(GeomInfo{1.0, false, true, -1}));
    dGeomSetData(floor, geom_infos.back().get());
    for (const Visual& wall : a.walls()) addGeom(wall.shape, nullptr, wall.offset, 0.5, false);
  }

  static void setMass(dBodyID body, const LinkSpec& link) {
    dMass m;
    const Eigen::Matrix3d& i = link.inertia;
    const bool usable = i.trace() > 0 && i.determinant() > 0;
    if (usable) {
      dMassSetParameters(&m, link.mass, 0, 0, 0, i(0, 0), i(1, 1), i(2, 2), i(0, 1), i(0, 2), i(1, 2));
    } else if (!link.collisions.empty()) {
      // No usable inertia in the URDF: take the first collision shape's, with the link's mass.
      const Shape& s = link.collisions[0].shape;
      if (s.type == Shape::Type::Box) {
        dMassSetBoxTotal(&m, link.mass, s.box_size.x(), s.box_size.y(), s.box_size.z());
      } else if (s.type == Shape::Type::Cylinder) {
        dMassSetCylinderTotal(&m, link.mass, 3, s.radius, s.length);
      } else {
        dMassSetSphereTotal(&m, link.mass, s.radius);
      }
    } else {
      dMassSetSphereTotal(&m, link.mass, 0.01);
    }
    dBodySetMass(body, &m);
  }

  void buildRobot() {
    const RobotSpec& robot = spec.robot;
    // World pose of every link at the start, and the lowest point, to set the robot on the floor.
    std::map<std::string, Eigen::Isometry3d> world_from_link;
    double lowest = std::numeric_limits<double>::infinity();
    for (const auto& link : robot.links) {
      world_from_link[link.name] = link.parent.empty() ? robot.pose : world_from_link[link.parent] * link.parent_from_link;
      for (const auto& c : link.collisions) {
        lowest = std::min(lowest, lowestPoint(c.shape, world_from_link[link.name] * c.offset));
      }
    }
    const double lift = std::isfinite(lowest) ? robot.pose.translation().z() - lowest + 0.0001 : 0;
    for (auto& entry : world_from_link) entry.second.translation().z() += lift;
    const Eigen::Isometry3d& start = world_from_link[robot.links[0].name];
    odometry.x = start.translation().x();
    odometry.y = start.translation().y();
    odometry.yaw = yawOf(start);

    for (const auto& link : robot.links) {
      dBodyID body;
      if (link.joint_type == LinkSpec::JointType::Fixed) {
        body = link_body.at(link.parent);
        body_from_link[link.name] = body_from_link.at(link.parent) * link.parent_from_link;
      } else {
        body = dBodyCreate(world);
        setMass(body, link);
        setPoseOf(body, world_from_link[link.name]);
        robot_bodies.push_back(body);
        body_from_link[link.name] = Eigen::Isometry3d::Identity();
        if (link.joint_type == LinkSpec::JointType::Revolute) {
          dJointID hinge = dJointCreateHinge(world, nullptr);
          // ODE measures a hinge's angle and rate as body1 relative to body2: the link is body1.
          dJointAttach(hinge, body, link_body.at(link.parent));
          const Eigen::Vector3d anchor = world_from_link[link.name].translation();
          const Eigen::Vector3d axis = world_from_link[link.name].rotation() * link.axis.normalized();
          dJointSetHingeAnchor(hinge, anchor.x(), anchor.y(), anchor.z());
          dJointSetHingeAxis(hinge, axis.x(), axis.y(), axis.z());
          link_joint[link.name] = hinge;
          if (link.joint == robot.left_wheel_joint) left_wheel = hinge;
          if (link.joint == robot.right_wheel_joint) right_wheel = hinge;
          dJointSetHingeParam(hinge, dParamFMax, robot.max_wheel_torque);
          dJointSetHingeParam(hinge, dParamVel, 0.0);
        }
      }
      link_body[link.name] = body;
      const bool wheel = link.joint == robot.left_wheel_joint || link.joint == robot.right_wheel_joint;
      // Passive links below the body (sliders) slide without friction; wheels grip.
      const bool slider = link.joint_type == LinkSpec::JointType::Fixed && link.mass == 0 && link.visuals.empty();
      const double friction = wheel ? robot.wheel_friction : slider ? 0.0 : robot.body_friction;
      for (const auto& c : link.collisions) addGeom(c.shape, body, body_from_link[link.name] * c.offset, friction, true);
    }
    for (const auto& ir : robot.ir_sensors) {
      ir_mounts.emplace_back(link_body.at(ir), body_from_link.at(ir));
      dGeomID ray = dCreateRay(nullptr, robot.ir_range);
      ir_rays.push_back(ray);
    }
  }

  void buildObject(const ObjectSpec& object) {
    dBodyID body = dBodyCreate(world);
    dMass m;
    switch (object.shape.type) {
      case Shape::Type::Box:
        dMassSetBoxTotal(&m, object.mass, object.shape.box_size.x(), object.shape.box_size.y(), object.shape.box_size.z());
        break;
      case Shape::Type::Cylinder: dMassSetCylinderTotal(&m, object.mass, 3, object.shape.radius, object.shape.length); break;
      case Shape::Type::Sphere: dMassSetSphereTotal(&m, object.mass, object.shape.radius); break;
    }
    dBodySetMass(body, &m);
    Eigen::Isometry3d pose = object.pose;
    pose.translation().z() += -lowestPoint(object.shape, pose) + 0.0001;  // rest on the floor
    setPoseOf(body, pose);
    ObjectState state;
    state.friction_x = object.friction;
    state.friction_y = object.friction_y;
    object_states.push_back(state);
    addGeom(object.shape, body, Eigen::Isometry3d::Identity(), object.friction, false,
            static_cast<int>(object_states.size()) - 1);
    if (object.shape.type == Shape::Type::Sphere) {
      // ODE has no rolling resistance: a ball would roll forever. Damp its spin at kBallSpinDamping per
      // second (whatever the step), down to standstill, so that it comes to rest like a ball on a mat.
      dBodySetAngularDamping(body, 1 - std::exp(-kBallSpinDamping * spec.physics.step));
      dBodySetAngularDampingThreshold(body, 0);
    }
    objects.emplace_back(object.name, body);
  }

  static void nearCallback(void* data, dGeomID a, dGeomID b) {
    auto* self = static_cast<Impl*>(data);
    dBodyID ba = dGeomGetBody(a), bb = dGeomGetBody(b);
    if (ba && bb && dAreConnectedExcluding(ba, bb, dJointTypeContact)) return;
    if (ba == bb) return;
    const auto* ia = static_cast<const GeomInfo*>(dGeomGetData(a));
    const auto* ib = static_cast<const GeomInfo*>(dGeomGetData(b));
    if (ia && ib && ia->robot && ib->robot) return;  // the robot does not collide with itself
    dContact contact[kMaxContacts];
    const int n = dCollide(a, b, kMaxContacts, &contact[0].geom, sizeof(dContact));
    if (n > 0 && ia && ib && (ia->robot || ib->robot)) {
      const GeomInfo* other = ia->robot ? ib : ia;
      if (other->object >= 0) self->object_states[other->object].touched = true;
    }
    for (int i = 0; i < n; ++i) self->pending.push_back({contact[i], ba, bb, ia, ib});
  }

  /// An object's friction against anything but the floor: one number for its two axes.
  double isotropicFriction(const GeomInfo* info) const {
    if (!info) return 1.0;
    if (info->object < 0) return info->friction;
    const ObjectState& s = object_states[info->object];
    return s.friction_x == s.friction_y ? s.friction_x : std::sqrt(s.friction_x * s.friction_y);
  }

  /// A touch of the robot after physics.contact_episode_gap without one starts an episode: a redrawn object
  /// gets its friction for it from (redraw seed, object, episode), whatever happened before.
  void updateContactEpisodes() {
    for (std::size_t i = 0; i < object_states.size(); ++i) {
      ObjectState& s = object_states[i];
      if (!s.touched) continue;
      s.touched = false;
      const bool new_episode = s.last_touch < 0 || time - s.last_touch > spec.physics.contact_episode_gap;
      s.last_touch = time;
      if (!new_episode) continue;
      ++s.episodes;
      const ObjectSpec& o = spec.objects[i];
      if (!o.redrawn()) continue;
      s.friction_x = s.friction_y = redrawnFriction(o, redraw_seed, i, s.episodes);
    }
  }

  /// The contact's slip: the velocity of body a relative to body b at the contact point, in the contact plane.
  static Eigen::Vector3d slipOf(const PendingContact& p, const Eigen::Vector3d& n) {
    const dContactGeom& g = p.contact.geom;
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    dVector3 pv;
    if (p.a) {
      dBodyGetPointVel(p.a, g.pos[0], g.pos[1], g.pos[2], pv);
      v += Eigen::Vector3d(pv[0], pv[1], pv[2]);
    }
    if (p.b) {
      dBodyGetPointVel(p.b, g.pos[0], g.pos[1], g.pos[2], pv);
      v -= Eigen::Vector3d(pv[0], pv[1], pv[2]);
    }
    return v - v.dot(n) * n;
  }

  /// One friction axis (unit, in the contact plane) with coefficient @p mu and none across it.
  static void frictionAlong(PendingContact& p, const Eigen::Vector3d& d, double mu) {
    dSurfaceParameters& surface = p.contact.surface;
    surface.mode |= dContactMu2 | dContactFDir1;
    surface.mu = mu;
    surface.mu2 = 0;
    p.contact.fdir1[0] = d.x();
    p.contact.fdir1[1] = d.y();
    p.contact.fdir1[2] = d.z();
  }

  /**
   * Friction at one of the step's contacts.
   *
   * ODE's friction is a pyramid: two axes in the contact plane, each holding up to mu times the normal force on
   * its own. A contact sliding along one axis can then still hold a force across it, which no real contact does:
   * a box pushed off its centre, sliding along the push, resists turning with friction across the slide and
   * turns a tenth of what a real one does (bench/contact.md). With physics.friction_model coulomb, at every
   * contact of an object that slips, the friction is what Coulomb's law gives: mu times the normal force against
   * the slip, nothing across it (one axis along the slip, the other free); a contact at rest keeps the pyramid,
   * which holds it. An object whose friction differs along its x and y axes (runners, grain) has an elliptic
   * limit, (Fx/mu_x)^2 + (Fy/mu_y)^2 <= N^2 in its own axes; sliding, the force is the point of the ellipse that
   * opposes the slip most (maximum dissipation), F ~ -(mu_x^2 vx, mu_y^2 vy); at rest, a pyramid along its axes.
   * The robot's own contacts with the floor (wheels, sliders) always keep ODE's pyramid.
   */
  void setFriction(PendingContact& p) const {
    dSurfaceParameters& surface = p.contact.surface;
    surface.mode = dContactApprox1 | dContactSoftERP | dContactSoftCFM;
    surface.soft_erp = 0.4;
    surface.soft_cfm = 1e-5;
    surface.mu = std::sqrt(isotropicFriction(p.ia) * isotropicFriction(p.ib));
    const bool object = (p.ia && p.ia->object >= 0) || (p.ib && p.ib->object >= 0);
    if (!object) return;
    const bool coulomb = spec.physics.friction_model == PhysicsSpec::FrictionModel::Coulomb;
    const Eigen::Vector3d n(p.contact.geom.normal[0], p.contact.geom.normal[1], p.contact.geom.normal[2]);
    const Eigen::Vector3d slip = coulomb ? slipOf(p, n) : Eigen::Vector3d::Zero();
    const bool sliding = slip.norm() >= kSlipSpeed;

    // An anisotropic object on the floor: its x axis in the contact plane (unless it stands on its end).
    const GeomInfo* floor = p.ia && p.ia->floor ? p.ia : p.ib && p.ib->floor ? p.ib : nullptr;
    const GeomInfo* other = floor == p.ia ? p.ib : p.ia;
    if (floor && other && other->object >= 0) {
      const ObjectState& s = object_states[other->object];
      if (s.friction_x != s.friction_y) {
        const dReal* r = dBodyGetRotation(floor == p.ia ? p.b : p.a);  // row-major 3x4
        const Eigen::Vector3d x_axis(r[0], r[4], r[8]);
        const Eigen::Vector3d along = x_axis - x_axis.dot(n) * n;
        if (along.norm() > 0.1) {
          const Eigen::Vector3d ex = along.normalized(), ey = n.cross(ex);
          const double mx = std::sqrt(s.friction_x * floor->friction), my = std::sqrt(s.friction_y * floor->friction);
          if (!sliding) {
            frictionAlong(p, ex, mx);
            surface.mu2 = my;
            return;
          }
          const double vx = slip.dot(ex), vy = slip.dot(ey);
          const Eigen::Vector3d force = mx * mx * vx * ex + my * my * vy * ey;
          const double mu = force.norm() / std::hypot(mx * vx, my * vy);
          frictionAlong(p, force.normalized(), mu);
          return;
        }
      }
    }
    if (sliding) frictionAlong(p, slip.normalized(), surface.mu);
  }

  /// The step's contacts as joints, with the frictions of this step (after any redraw).
  void createContactJoints() {
    for (PendingContact& p : pending) {
      setFriction(p);
      dJointID j = dJointCreateContact(world, contacts, &p.contact);
      dJointAttach(j, p.a, p.b);
    }
    pending.clear();
  }

  void forEachBody(const std::function<void(dBodyID)>& f) const {
    for (dBodyID b : robot_bodies) f(b);
    for (const auto& o : objects) f(o.second);
  }

  void saveGoodState() {
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

  void restoreGoodState() {
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

  /// The robot's root body or an object's body. @throws ValidationError for unknown names
  dBodyID body(const std::string& name) const {
    if (name == spec.robot.name) return robot_bodies[0];
    for (const auto& o : objects) {
      if (o.first == name) return o.second;
    }
    requireKnownName("body", name, spec.bodyNames());  // throws with the list of known names
    return nullptr;
  }

  std::string bodyName(dBodyID body) const {
    for (const auto& [link, b] : link_body) {
      if (b == body && body_from_link.at(link).isApprox(Eigen::Isometry3d::Identity())) return spec.robot.name + "/" + link;
    }
    for (const auto& o : objects) {
      if (o.second == body) return o.first;
    }
    return "a body";
  }

  // ODE aborts the process on some non-finite inputs, so pending forces are checked before a step.
  Trouble pendingForceProblem() const {
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

  /// The lowest point of a body's collision geometry (world z), from ODE's bounding boxes, which are exact
  /// in z for boxes, spheres and upright or tilted cylinders' end discs.
  static double lowestOf(dBodyID b) {
    double lowest = std::numeric_limits<double>::infinity();
    for (dGeomID g = dBodyGetFirstGeom(b); g; g = dBodyGetNextGeom(g)) {
      dReal aabb[6];
      dGeomGetAABB(g, aabb);
      lowest = std::min(lowest, static_cast<double>(aabb[4]));
    }
    return std::isfinite(lowest) ? lowest : dBodyGetPosition(b)[2];
  }

  static double speedOf(dBodyID b) {
    const dReal* v = dBodyGetLinearVel(b);
    return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  }

  /// A body may move at max_speed plus twice what a fall from fall_height gives (sqrt(2 g h)): the factor
  /// two leaves room for a collision that passes a falling body's speed on to a lighter one.
  double speedLimit() const {
    return spec.physics.max_speed + 2 * std::sqrt(2 * std::fabs(spec.physics.gravity) * fall_height);
  }

  /// After a good step or a placement: while every body is slower than max_speed, the highest one sets how
  /// far a body may yet fall; while one is faster (falling), the height it started from stays.
  void updateFallHeight() {
    bool calm = true;
    double highest = 0;
    forEachBody([&](dBodyID b) {
      calm = calm && speedOf(b) <= spec.physics.max_speed;
      highest = std::max(highest, lowestOf(b));
    });
    if (calm) fall_height = highest;
  }

  Trouble health() const {
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

  /// Put a body at rest where it is: no velocity, no pending force. A robot body stops the whole robot.
  void putAtRest(dBodyID body) {
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

  /// One physics step from the current state, not yet committed; what went wrong, if anything.
  Trouble attempt(double dt) {
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

  std::string describeBody(dBodyID b) const {
    if (std::find(robot_bodies.begin(), robot_bodies.end(), b) != robot_bodies.end()) return "the robot " + spec.robot.name;
    return bodyName(b);
  }

  void applyWheelCommands() {
    const double r = spec.robot.wheel_radius;
    if (left_wheel) dJointSetHingeParam(left_wheel, dParamVel, left_command / r);
    if (right_wheel) dJointSetHingeParam(right_wheel, dParamVel, right_command / r);
  }

  // Wheel angle rates are signed so that positive means "forward" for both wheels.
  double wheelRate(dJointID wheel) const {
    if (!wheel) return 0;
    return dJointGetHingeAngleRate(wheel);
  }
};

double redrawnFriction(const ObjectSpec& object, std::uint64_t seed, std::size_t object_index, int episode) {
  const std::uint64_t h = streamSeed(seed, object_index, static_cast<std::uint64_t>(episode), StreamPurpose::Friction);
  const double u = static_cast<double>(h >> 11) * 0x1.0p-53;  // uniform in [0, 1), the same on every platform
  return object.friction_redraw_min * std::pow(object.friction_redraw_max / object.friction_redraw_min, u);
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

void PhysicsWorld::setRedrawSeed(std::uint64_t seed) {
  known_state_.clear();
  redraw_seed_ = seed;
  impl_->redraw_seed = seed;
}

double PhysicsWorld::objectFriction(const std::string& object, double* along_y) const {
  requireKnownName("object", object, scene_.objects);
  for (std::size_t i = 0; i < impl_->objects.size(); ++i) {
    if (impl_->objects[i].first != object) continue;
    if (along_y) *along_y = impl_->object_states[i].friction_y;
    return impl_->object_states[i].friction_x;
  }
  return 0;
}

int PhysicsWorld::contactEpisodes(const std::string& object) const {
  requireKnownName("object", object, scene_.objects);
  for (std::size_t i = 0; i < impl_->objects.size(); ++i) {
    if (impl_->objects[i].first == object) return impl_->object_states[i].episodes;
  }
  return 0;
}

PhysicsWorld::StepResult PhysicsWorld::step() {
  known_state_.clear();
  initOde();
  Impl& w = *impl_;
  w.applyWheelCommands();
  const double dt = spec_.physics.step;
  const unsigned long seed = w.random_seed;
  StepResult result;
  Impl::Trouble trouble = w.attempt(dt);
  if (trouble.none()) {
    w.blow_ups_in_a_row = 0;
  } else {
    // A real blow-up: undo the step, then resolve it so that the next try is a different state (never the
    // same failing step again): first the offending body at rest at its last good pose, then every body.
    result.ok = false;
    result.problem = "physics blow-up at t=" + describeNumber(w.time) + " s: " + trouble.what;
    w.restoreGoodState();
    w.random_seed = seed;
    w.putAtRest(trouble.body ? trouble.body : w.robot_bodies.front());
    const std::string rested = trouble.body ? w.describeBody(trouble.body) : std::string("the robot");
    Impl::Trouble again = w.attempt(dt);
    if (++w.blow_ups_in_a_row >= kMaxBlowUpsInARow) {
      w.restoreGoodState();
      w.random_seed = seed;
      w.forEachBody([&](dBodyID b) { w.putAtRest(b); });
      w.saveGoodState();
      w.blow_ups_in_a_row = 0;
      result.halted = true;
      result.problem += "; the world blew up in " + std::to_string(kMaxBlowUpsInARow) +
                        " steps in a row: it stays at its last good state, at rest, until a body is moved or the world reset";
      return result;
    }
    if (again.none()) {
      result.problem += "; the step was undone and " + rested + " put at rest at its last good pose";
    } else {
      w.restoreGoodState();
      w.random_seed = seed;
      w.forEachBody([&](dBodyID b) { w.putAtRest(b); });
      Impl::Trouble still = w.attempt(dt);
      if (still.none()) {
        result.problem += "; with " + rested + " at rest it blew up again (" + again.what +
                          "), so every body was put at rest at its last good pose";
      } else {
        w.restoreGoodState();
        w.random_seed = seed;
        w.forEachBody([&](dBodyID b) { w.putAtRest(b); });
        w.saveGoodState();
        w.blow_ups_in_a_row = 0;
        result.halted = true;
        result.problem += "; it blows up even with every body at rest (" + still.what +
                          "): the world stays at its last good state, at rest, until a body is moved or the world reset";
        return result;
      }
    }
  }
  const double left_rate = w.wheelRate(w.left_wheel), right_rate = w.wheelRate(w.right_wheel);
  w.left_angle += left_rate * dt;
  w.right_angle += right_rate * dt;
  const double r = spec_.robot.wheel_radius;
  const double v = r * (left_rate + right_rate) / 2;
  const double omega = r * (right_rate - left_rate) / spec_.robot.wheel_separation;
  Odometry& o = w.odometry;
  o.x += v * std::cos(o.yaw + omega * dt / 2) * dt;
  o.y += v * std::sin(o.yaw + omega * dt / 2) * dt;
  o.yaw = std::remainder(o.yaw + omega * dt, 2 * M_PI);
  o.linear = v;
  o.angular = omega;
  w.time += dt;
  ++w.steps;
  w.saveGoodState();
  w.updateFallHeight();
  return result;
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

}  // namespace

PhysicsWorld::PlacementCheck PhysicsWorld::checkPlacement(const std::string& body, const Eigen::Isometry3d& pose,
                                                          bool on_floor, Eigen::Isometry3d* placed) const {
  PlacementCheck check;
  if (const std::string why = checkKnownName("body", body, spec_.bodyNames()); !why.empty()) {
    check.problem = PlacementCheck::Problem::Invalid;
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
    check.problem = PlacementCheck::Problem::Invalid;
    check.why = why;
    return check;
  }
  Impl& w = *impl_;
  initOde();
  const bool robot = body == spec_.robot.name;
  struct {
    std::vector<dBodyID> bodies;
    std::vector<Eigen::Isometry3d> poses;
  } placement;
  if (robot) {
    // Every link moves rigidly with the root, the wheels keeping their place relative to the body.
    Eigen::Isometry3d target = pose;
    if (on_floor) target.translation().z() = 0;
    const Eigen::Isometry3d delta = target * poseOf(w.robot_bodies[0]).inverse();
    for (dBodyID b : w.robot_bodies) {
      placement.bodies.push_back(b);
      placement.poses.push_back(delta * poseOf(b));
    }
  } else {
    placement.bodies.push_back(w.body(body));
    placement.poses.push_back(pose);
    if (on_floor) placement.poses.back().translation().z() = 0;
  }
  auto probeAtPlacement = [&] {
    auto probe = std::make_unique<PlacementProbe>();
    for (std::size_t i = 0; i < placement.bodies.size(); ++i) probe->add(placement.bodies[i], placement.poses[i]);
    return probe;
  };
  auto extents = [](const PlacementProbe& probe, double* lo, double* hi) {  // x, y, z of its bounding box
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::numeric_limits<double>::infinity();
      hi[k] = -lo[k];
    }
    for (dGeomID g : probe.geoms()) {
      dReal aabb[6];
      dGeomGetAABB(g, aabb);
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], static_cast<double>(aabb[2 * k]));
        hi[k] = std::max(hi[k], static_cast<double>(aabb[2 * k + 1]));
      }
    }
  };
  double lo[3], hi[3];
  std::unique_ptr<PlacementProbe> probe = probeAtPlacement();
  extents(*probe, lo, hi);
  if (on_floor) {  // set down resting on the floor, as the world file's objects start
    const double lift = kRestClearance - lo[2];
    for (auto& t : placement.poses) t.translation().z() += lift;
    probe = probeAtPlacement();
    extents(*probe, lo, hi);
  }
  const std::string what = robot ? "the robot " + body : body;
  const Eigen::Vector3d where = placement.poses.front().translation();
  const double hx = spec_.arena.size_x / 2, hy = spec_.arena.size_y / 2;
  if (lo[0] < -hx - kPlacementTolerance || hi[0] > hx + kPlacementTolerance || lo[1] < -hy - kPlacementTolerance ||
      hi[1] > hy + kPlacementTolerance) {
    check.problem = PlacementCheck::Problem::Invalid;
    check.why = what + " at " + point(where) + " would reach x " + describeNumber(lo[0]) + ".." + describeNumber(hi[0]) +
                ", y " + describeNumber(lo[1]) + ".." + describeNumber(hi[1]) + ", outside the arena (inside its walls |x| <= " +
                describeNumber(hx) + ", |y| <= " + describeNumber(hy) + ")";
  } else if (lo[2] < -kPlacementTolerance) {
    check.problem = PlacementCheck::Problem::Invalid;
    check.why = what + " at " + point(where) + " would reach " + millimetres(-lo[2]) +
                " under the floor; at this orientation its origin must be at z >= " + describeNumber(where.z() - lo[2]) +
                " (or set it down on the floor with on_floor)";
  } else if (lo[2] > kMaxPlacementHeight) {
    check.problem = PlacementCheck::Problem::Invalid;
    check.why = what + " at " + point(where) + " would float " + describeNumber(lo[2]) + " m above the floor; at most " +
                describeNumber(kMaxPlacementHeight) + " m";
  } else {
    // Every other body's geometry, at its current pose: the robot's links, the objects. (Walls lie outside
    // the arena and the floor below it: the bounds above cover them.)
    double deepest = 0;
    dBodyID other = nullptr;
    const int n = dSpaceGetNumGeoms(w.space);
    for (int i = 0; i < n; ++i) {
      dGeomID g = dSpaceGetGeom(w.space, i);
      dBodyID b = dGeomGetBody(g);
      if (!b || std::find(placement.bodies.begin(), placement.bodies.end(), b) != placement.bodies.end()) continue;
      for (dGeomID m : probe->geoms()) {
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
    if (other && deepest > kPlacementTolerance) {
      check.problem = PlacementCheck::Problem::Overlap;
      check.why = what + " at " + point(where) + " would overlap " + w.describeBody(other) + " by " + millimetres(deepest) +
                  "; choose a free place";
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

double PhysicsWorld::time() const { return impl_->time; }
std::uint64_t PhysicsWorld::stepCount() const { return impl_->steps; }

namespace {
Eigen::Vector3d toVector(const dReal* v) { return Eigen::Vector3d(v[0], v[1], v[2]); }
}  // namespace

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

PhysicsWorld::Odometry PhysicsWorld::odometry() const { return impl_->odometry; }

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

namespace {

using Json = nlohmann::json;

/// A finite number at @p key of @p object, for restoreState's sentences.
double stateNumber(const Json& object, const char* key, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_number()) {
    throw ValidationError("the world state has no number '" + std::string(key) + "' in " + where);
  }
  const double value = it->get<double>();
  if (!std::isfinite(value)) throw ValidationError("the world state's " + where + "." + key + " is not finite");
  return value;
}

template <std::size_t N>
std::array<double, N> stateVector(const Json& object, const char* key, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_array() || it->size() != N) {
    throw ValidationError("the world state's " + where + "." + key + " is not a list of " + std::to_string(N) +
                          " numbers");
  }
  std::array<double, N> values{};
  for (std::size_t k = 0; k < N; ++k) {
    if (!(*it)[k].is_number() || !std::isfinite((*it)[k].get<double>())) {
      throw ValidationError("the world state's " + where + "." + key + "[" + std::to_string(k) +
                            "] is not a finite number");
    }
    values[k] = (*it)[k].get<double>();
  }
  return values;
}

std::uint64_t stateCount(const Json& object, const char* key, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_number_unsigned()) {
    throw ValidationError("the world state has no whole number '" + std::string(key) + "' in " + where);
  }
  return it->get<std::uint64_t>();
}

}  // namespace

std::string PhysicsWorld::saveState() const {
  const Impl& w = *impl_;
  // nlohmann writes the shortest text that reads back as the same double, so numbers survive bit for bit.
  Json state;
  state["world"] = spec_.name;
  state["step"] = spec_.physics.step;
  state["time"] = w.time;
  state["steps"] = w.steps;
  state["solver_seed"] = static_cast<std::uint64_t>(w.random_seed);
  state["redraw_seed"] = redraw_seed_;
  state["wheel_commands"] = {w.left_command, w.right_command};
  state["wheel_angles"] = {w.left_angle, w.right_angle};
  state["odometry"] = {w.odometry.x, w.odometry.y, w.odometry.yaw, w.odometry.linear, w.odometry.angular};
  state["fall_height"] = w.fall_height;
  state["blow_ups_in_a_row"] = w.blow_ups_in_a_row;
  Json bodies = Json::array();
  w.forEachBody([&](dBodyID b) {
    const dReal* p = dBodyGetPosition(b);
    const dReal* q = dBodyGetQuaternion(b);
    const dReal* v = dBodyGetLinearVel(b);
    const dReal* a = dBodyGetAngularVel(b);
    bodies.push_back({{"name", w.bodyName(b)},
                      {"position", {p[0], p[1], p[2]}},
                      {"orientation", {q[0], q[1], q[2], q[3]}},
                      {"linear", {v[0], v[1], v[2]}},
                      {"angular", {a[0], a[1], a[2]}}});
  });
  state["bodies"] = bodies;
  Json objects = Json::array();
  for (std::size_t i = 0; i < w.objects.size(); ++i) {
    const ObjectState& o = w.object_states[i];
    objects.push_back({{"name", w.objects[i].first},
                       {"friction", {o.friction_x, o.friction_y}},
                       {"episodes", o.episodes},
                       {"last_touch", o.last_touch}});
  }
  state["objects"] = objects;
  return state.dump();
}

void PhysicsWorld::restoreState(const std::string& text) {
  Impl& w = *impl_;
  Json state;
  try {
    state = Json::parse(text);
  } catch (const Json::exception& e) {
    throw ValidationError(std::string("the world state is not JSON: ") + e.what());
  }
  if (!state.is_object()) throw ValidationError("the world state is not a JSON object");
  // Everything is read and checked before anything changes.
  const auto world = state.find("world");
  if (world == state.end() || !world->is_string() || world->get<std::string>() != spec_.name) {
    throw ValidationError("the world state is of world '" + (world != state.end() && world->is_string() ? world->get<std::string>() : std::string("?")) +
                          "', not of '" + spec_.name + "'");
  }
  if (stateNumber(state, "step", "the state") != spec_.physics.step) {
    throw ValidationError("the world state was taken with a physics step of " +
                          describeNumber(state["step"].get<double>()) + " s, this world steps " +
                          describeNumber(spec_.physics.step) + " s");
  }
  const double time = stateNumber(state, "time", "the state");
  const std::uint64_t steps = stateCount(state, "steps", "the state");
  const std::uint64_t solver_seed = stateCount(state, "solver_seed", "the state");
  const std::uint64_t redraw_seed = stateCount(state, "redraw_seed", "the state");
  const auto commands = stateVector<2>(state, "wheel_commands", "the state");
  const auto angles = stateVector<2>(state, "wheel_angles", "the state");
  const auto odometry = stateVector<5>(state, "odometry", "the state");
  const double fall_height = stateNumber(state, "fall_height", "the state");
  const std::uint64_t blow_ups = stateCount(state, "blow_ups_in_a_row", "the state");
  std::vector<dBodyID> order;
  w.forEachBody([&](dBodyID b) { order.push_back(b); });
  const auto bodies = state.find("bodies");
  if (bodies == state.end() || !bodies->is_array() || bodies->size() != order.size()) {
    throw ValidationError("the world state does not have this world's " + std::to_string(order.size()) + " bodies");
  }
  std::vector<BodyState> body_states(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    const Json& body = (*bodies)[i];
    const std::string name = w.bodyName(order[i]);
    if (!body.is_object() || !body.contains("name") || body["name"] != name) {
      throw ValidationError("the world state's body " + std::to_string(i) + " is not " + name);
    }
    const auto p = stateVector<3>(body, "position", name), v = stateVector<3>(body, "linear", name),
               a = stateVector<3>(body, "angular", name);
    const auto q = stateVector<4>(body, "orientation", name);
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (std::fabs(norm - 1) > 1e-6) throw ValidationError("the world state's " + name + ".orientation is not a unit quaternion");
    BodyState& s = body_states[i];
    std::copy(p.begin(), p.end(), s.position);
    std::copy(q.begin(), q.end(), s.orientation);
    std::copy(v.begin(), v.end(), s.linear);
    std::copy(a.begin(), a.end(), s.angular);
  }
  const auto objects = state.find("objects");
  if (objects == state.end() || !objects->is_array() || objects->size() != w.objects.size()) {
    throw ValidationError("the world state does not have this world's " + std::to_string(w.objects.size()) + " objects");
  }
  std::vector<ObjectState> object_states(w.objects.size());
  for (std::size_t i = 0; i < w.objects.size(); ++i) {
    const Json& object = (*objects)[i];
    const std::string& name = w.objects[i].first;
    if (!object.is_object() || !object.contains("name") || object["name"] != name) {
      throw ValidationError("the world state's object " + std::to_string(i) + " is not " + name);
    }
    const auto friction = stateVector<2>(object, "friction", name);
    if (friction[0] < 0 || friction[1] < 0) throw ValidationError("the world state's " + name + ".friction is negative");
    object_states[i].friction_x = friction[0];
    object_states[i].friction_y = friction[1];
    object_states[i].episodes = static_cast<int>(stateCount(object, "episodes", name));
    object_states[i].last_touch = stateNumber(object, "last_touch", name);
  }

  for (std::size_t i = 0; i < order.size(); ++i) {
    const BodyState& s = body_states[i];
    dBodySetPosition(order[i], s.position[0], s.position[1], s.position[2]);
    dBodySetQuaternion(order[i], s.orientation);
    dBodySetLinearVel(order[i], s.linear[0], s.linear[1], s.linear[2]);
    dBodySetAngularVel(order[i], s.angular[0], s.angular[1], s.angular[2]);
    dBodySetForce(order[i], 0, 0, 0);
    dBodySetTorque(order[i], 0, 0, 0);
  }
  // ODE moves a geom to the front of its space's list when it first moves after a collision pass, so the list's
  // order (and with it the order of contacts, which the solver's result depends on) is a record of history.
  // Re-adding the bodies' geoms in body order and computing every bounding box makes it a function of the
  // spec alone.
  for (dBodyID b : order) {
    for (dGeomID g = dBodyGetFirstGeom(b); g; g = dBodyGetNextGeom(g)) {
      if (dGeomGetSpace(g) != w.space) continue;
      dSpaceRemove(w.space, g);
      dSpaceAdd(w.space, g);
    }
  }
  dSpaceClean(w.space);
  w.time = time;
  w.steps = steps;
  w.random_seed = static_cast<unsigned long>(solver_seed);
  setRedrawSeed(redraw_seed);
  w.left_command = commands[0];
  w.right_command = commands[1];
  w.left_angle = angles[0];
  w.right_angle = angles[1];
  w.odometry = {odometry[0], odometry[1], odometry[2], odometry[3], odometry[4]};
  w.object_states = object_states;
  w.fall_height = fall_height;
  w.blow_ups_in_a_row = static_cast<int>(blow_ups);
  w.pending.clear();
  w.saveGoodState();
  known_state_ = text;
}

std::string PhysicsWorld::checkpoint() {
  // Unchanged since a restore or a checkpoint: that state is this world exactly. Restoring it once more could
  // move the last bit of a quaternion (ODE renormalises), and a run checkpointed twice at one step (resumed
  // after its knowledge base refused the first) would go on from another world than an uninterrupted one.
  if (!known_state_.empty()) return known_state_;
  const std::string state = saveState();
  restoreState(state);
  return state;
}

std::string PhysicsWorld::checkHealth() const { return impl_->health().what; }

void PhysicsWorld::injectFault(const std::string& body, bool explode) {
  known_state_.clear();
  dBodyID b = impl_->body(body);
  const double f = explode ? 1e9 : std::numeric_limits<double>::quiet_NaN();
  dBodyAddForce(b, f, f, 0);
}

SceneDescription PhysicsWorld::buildScene() const {
  SceneDescription scene;
  const ArenaSpec& a = spec_.arena;
  scene.world_file = spec_.source;
  scene.arena_size_x = a.size_x;
  scene.arena_size_y = a.size_y;
  if (!spec_.robot.links.empty()) scene.robot_root = spec_.robot.links.front().name;
  scene.robot_marker = spec_.robot.heading_marker;
  for (std::size_t i = 1; scene.robot_marker.empty() && i < spec_.robot.links.size(); ++i) {
    const auto& visuals = spec_.robot.links[i].visuals;
    if (visuals.size() == 1 && visuals.front().shape.type == Shape::Type::Box) {
      scene.robot_marker = spec_.robot.links[i].name;
    }
  }
  for (const ObjectSpec& o : spec_.objects) scene.objects.push_back(o.name);
  SceneNode arena;
  arena.name = "arena";
  arena.parent = scene.world_frame;
  Visual floor;
  floor.shape.box_size = Eigen::Vector3d(a.size_x + 2 * a.wall_thickness, a.size_y + 2 * a.wall_thickness, 0.002);
  floor.offset.translation() = Eigen::Vector3d(0, 0, -0.001);
  floor.color = a.floor_color;
  arena.visuals.push_back(floor);
  for (const Visual& wall : a.walls()) arena.visuals.push_back(wall);
  scene.nodes.push_back(arena);

  const FrameTransforms now = dynamicTransforms();
  for (const auto& link : spec_.robot.links) {
    SceneNode node;
    node.name = link.name;
    node.parent = link.parent.empty() ? scene.world_frame : link.parent;
    node.dynamic = link.joint_type != LinkSpec::JointType::Fixed;
    node.parent_from_node = node.dynamic ? now.at(link.name) : link.parent_from_link;
    node.visuals = link.visuals;
    scene.nodes.push_back(node);
  }
  for (std::size_t i = 0; i < spec_.objects.size(); ++i) {
    const ObjectSpec& o = spec_.objects[i];
    SceneNode node;
    node.name = o.name;
    node.parent = scene.world_frame;
    node.dynamic = true;
    node.parent_from_node = now.at(o.name);
    Visual v;
    v.shape = o.shape;
    v.color = o.color;
    node.visuals.push_back(v);
    scene.nodes.push_back(node);
  }
  for (const auto& c : spec_.cameras) {
    SceneNode node;
    node.name = c.model.frame;
    node.parent = c.parent;
    node.parent_from_node = c.parent_from_optical;
    scene.nodes.push_back(node);
    scene.cameras.push_back(c.model);
  }
  return scene;
}

}  // namespace xpersif::core
