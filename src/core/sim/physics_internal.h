// What the physics world's sources share (physics_world.cpp: stepping and blow-ups; physics_build.cpp: building
// the world; physics_contacts.cpp: contacts and friction; physics_sensors.cpp: wheels, odometry, IR;
// physics_placement.cpp: placement checks; physics_state.cpp: saved states): ODE helpers and PhysicsWorld::Impl.
#pragma once

#include <ode/ode.h>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "xpersif/core/sim/physics_world.h"

namespace xpersif::core {

namespace physics_detail {

/// ODE's global set-up, and its per-thread data in the calling thread: call before using ODE in any thread.
void initOde();

inline Eigen::Isometry3d poseOf(dBodyID body) {
  const dReal* p = dBodyGetPosition(body);
  const dReal* q = dBodyGetQuaternion(body);  // w, x, y, z
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
  t.linear() = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  return t;
}

inline void setPoseOf(dBodyID body, const Eigen::Isometry3d& t) {
  const Eigen::Vector3d p = t.translation();
  const Eigen::Quaterniond q(t.rotation());
  dBodySetPosition(body, p.x(), p.y(), p.z());
  const dQuaternion dq = {q.w(), q.x(), q.y(), q.z()};
  dBodySetQuaternion(body, dq);
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

}  // namespace physics_detail

struct PhysicsWorld::Impl {
  using BodyState = physics_detail::BodyState;
  using GeomInfo = physics_detail::GeomInfo;
  using ObjectState = physics_detail::ObjectState;
  using PendingContact = physics_detail::PendingContact;

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

  // ---- building the world (physics_build.cpp)
  void build();
  void destroy();
  void buildArena();
  void buildRobot();
  void buildObject(const ObjectSpec& object);
  dGeomID addGeom(const Shape& shape, dBodyID body, const Eigen::Isometry3d& offset, double friction, bool robot,
                  int object = -1);

  // ---- contacts and friction (physics_contacts.cpp)
  static void nearCallback(void* data, dGeomID a, dGeomID b);
  /// An object's friction against anything but the floor: one number for its two axes.
  double isotropicFriction(const GeomInfo* info) const;
  /// A touch of the robot after physics.contact_episode_gap without one starts an episode: a redrawn object
  /// gets its friction for it from (redraw seed, object, episode), whatever happened before.
  void updateContactEpisodes();
  /// Friction at one of the step's contacts (see physics_contacts.cpp).
  void setFriction(PendingContact& p) const;
  /// The step's contacts as joints, with the frictions of this step (after any redraw).
  void createContactJoints();

  // ---- wheels and odometry (physics_sensors.cpp)
  void applyWheelCommands();
  /// Wheel angle rates are signed so that positive means "forward" for both wheels.
  double wheelRate(dJointID wheel) const;
  /// The wheels' angles and the odometry, advanced by one step of @p dt at the wheels' rates now.
  void integrateOdometry(double dt);

  // ---- the bodies, stepping and blow-ups (physics_world.cpp)
  void forEachBody(const std::function<void(dBodyID)>& f) const;
  /// The robot's root body or an object's body. @throws ValidationError for unknown names
  dBodyID body(const std::string& name) const;
  std::string bodyName(dBodyID body) const;
  std::string describeBody(dBodyID b) const;
  void saveGoodState();
  void restoreGoodState();
  /// ODE aborts the process on some non-finite inputs, so pending forces are checked before a step.
  Trouble pendingForceProblem() const;
  /// A body may move at max_speed plus twice what a fall from fall_height gives (sqrt(2 g h)): the factor
  /// two leaves room for a collision that passes a falling body's speed on to a lighter one.
  double speedLimit() const;
  /// After a good step or a placement: while every body is slower than max_speed, the highest one sets how
  /// far a body may yet fall; while one is faster (falling), the height it started from stays.
  void updateFallHeight();
  Trouble health() const;
  /// Put a body at rest where it is: no velocity, no pending force. A robot body stops the whole robot.
  void putAtRest(dBodyID body);
  /// One physics step from the current state, not yet committed; what went wrong, if anything.
  Trouble attempt(double dt);
  /// After @p trouble in the step from solver seed @p seed: undo it and try again from a calmer state (see the
  /// .cpp). Says what happened in @p result; false when the world had to halt (time did not advance).
  bool resolveBlowUp(const Trouble& trouble, unsigned long seed, double dt, StepResult& result);
  /// Back to the last good state and the step's solver seed @p seed, every body at rest.
  void restAll(unsigned long seed);
  /// A world that keeps blowing up stays at its last good state, at rest.
  void halt(unsigned long seed, StepResult& result);
};

}  // namespace xpersif::core
