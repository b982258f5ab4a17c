/**
 * @file physics_world.h
 * @brief XPERSim's physics: an ODE world built from a WorldSpec, stepped at a fixed rate. ROS-free.
 *
 * Deterministic: the same spec (and seed) and the same sequence of calls give bit-identical states,
 * also with several worlds in one process (each keeps its own solver random seed). Safe: after every
 * step every body is checked: finite, and no faster than physics.max_speed plus twice what a fall from the
 * highest body's height gives (so a body dropped from high up falls, legally). A step that breaks that is a
 * blow-up: it is undone, then resolved (the offending body, or else every body, put at rest at its last
 * good pose, and the step taken again), and the step reports what happened. It never fails the same way
 * forever: if even a world at rest blows up, the step says so (halted) and the caller must pause.
 *
 * Not thread-safe: one thread at a time (the simulator node serializes access).
 */
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "xpersif/core/common/scene.h"
#include "xpersif/core/sim/world_spec.h"

namespace xpersif::core {

/// The friction object @p object_index (@p object, the world's objects[object_index]) gets for its contact
/// episode @p episode (1, 2, ...) when its friction is redrawn (ObjectSpec::redrawn()): log-uniform in
/// [friction_redraw_min, friction_redraw_max] from streamSeed(@p seed, object_index, episode, Friction). A pure
/// function of its arguments, so the same seed gives the same draws whatever else happened.
double redrawnFriction(const ObjectSpec& object, std::uint64_t seed, std::size_t object_index, int episode);

class PhysicsWorld {
 public:
  /// @throws WorldError when the spec cannot be simulated
  explicit PhysicsWorld(WorldSpec spec);
  ~PhysicsWorld();
  PhysicsWorld(const PhysicsWorld&) = delete;
  PhysicsWorld& operator=(const PhysicsWorld&) = delete;

  struct StepResult {
    bool ok = true;        ///< false after a blow-up (then problem says what and how it was resolved)
    bool halted = false;   ///< the blow-up could not be resolved: time did not advance; the world is at rest
    std::string problem;   ///< one sentence, when !ok
  };
  /// Advance one physics step (spec().physics.step seconds); a resolved blow-up still advances time.
  StepResult step();
  /// Back to the initial state of the spec, with the initial seed.
  void reset();

  /// Wheel rim speeds in m/s, clamped to +-max_wheel_speed. @throws ValidationError if not finite
  void setWheelSpeeds(double left, double right);
  /// Forward speed (m/s) and turn rate (rad/s), converted to wheel speeds. @throws ValidationError
  void setVelocity(double linear, double angular);
  /// Whether a body may be placed at a pose, and if not, one sentence naming it and why.
  struct PlacementCheck {
    enum class Problem { None, Invalid, Overlap };
    Problem problem = Problem::None;  ///< Invalid: malformed or out of bounds whatever the scene; Overlap: occupied now
    std::string why;
    bool ok() const { return problem == Problem::None; }
  };
  /// Checks a placement without changing anything: a known name, a finite pose with a unit quaternion, the
  /// body's geometry inside the arena's walls (1 mm tolerance), not under the floor (1 mm), its lowest point at
  /// most 10 m up, and overlapping no other body (the robot's links, the objects) by more than 1 mm. Above the
  /// floor is allowed: the body falls. With @p on_floor, z is ignored and the body is set down on the floor.
  /// @param placed if given, receives the pose the body would take (z set when on_floor)
  PlacementCheck checkPlacement(const std::string& body, const Eigen::Isometry3d& world_from_body, bool on_floor = false,
                                Eigen::Isometry3d* placed = nullptr) const;
  /// Place the robot (its root link, the other links moving rigidly with it) or an object, at rest.
  /// @throws ValidationError with checkPlacement's sentence when the placement is refused
  void setPose(const std::string& body, const Eigen::Isometry3d& world_from_body, bool on_floor = false);

  double time() const;
  std::uint64_t stepCount() const;
  const WorldSpec& spec() const { return spec_; }
  /// Nodes, shapes, colours and cameras: what clients need to render the scene.
  const SceneDescription& scene() const { return scene_; }
  /// parent_from_node of every dynamic scene node, now.
  FrameTransforms dynamicTransforms() const;
  /// World pose of the robot's root link or of an object. @throws ValidationError for unknown names
  Eigen::Isometry3d bodyPose(const std::string& body) const;
  Eigen::Vector3d bodyLinearVelocity(const std::string& body) const;
  Eigen::Vector3d bodyAngularVelocity(const std::string& body) const;

  /// Distance along each IR sensor's ray to the nearest thing that is not the robot (ir_range if none).
  std::vector<double> irRanges() const;

  /// Pose integrated from the wheels' rotation since the start (or the last reset/setPose of the robot).
  struct Odometry {
    double x = 0, y = 0, yaw = 0;
    double linear = 0, angular = 0;  ///< current speeds from the wheels
  };
  Odometry odometry() const;

  struct WheelState {
    double left_angle = 0, right_angle = 0;  ///< rad, unwrapped
    double left_rate = 0, right_rate = 0;    ///< rad/s
    double left_command = 0, right_command = 0;  ///< commanded rim speeds, m/s
  };
  WheelState wheels() const;

  /// The seed of the stream objects' frictions are redrawn from (world file `friction_redraw`): draw k of
  /// object i comes from streamSeed(seed, i, k, Friction), so the same seed and the same pushes give the same
  /// frictions. Defaults to physics.seed; kept across reset(). Takes effect for the next draws.
  void setRedrawSeed(std::uint64_t seed);
  std::uint64_t redrawSeed() const { return redraw_seed_; }
  /// An object's friction against the floor now, along its x axis (and @p along_y across it): the file's,
  /// or the last draw. For tests and benchmarks only: XPERSim never publishes it, the loop has to find out.
  /// @throws ValidationError for unknown names
  double objectFriction(const std::string& object, double* along_y = nullptr) const;
  /// How many contact episodes with the robot an object has had since the start or the last reset.
  int contactEpisodes(const std::string& object) const;

  /// Everything the world's future depends on, as JSON text with exact numbers: every body's pose, velocity and
  /// name, the physics clock and step count, the solver's random seed, the redraw seed, the wheels' commands and
  /// angles, odometry, the objects' frictions and contact episodes, and the blow-up bookkeeping.
  std::string saveState() const;
  /// Puts this world in a state saveState() gave, of a world of the same spec (the same bodies in the same order,
  /// the same physics step and solver). ODE's collision order, which depends on the history of moves, is put in a
  /// canonical order, so that from here on this world continues bit for bit as any other world of the spec
  /// restored from the same state, in this process or another one (see checkpoint()).
  /// @throws ValidationError with one sentence, and nothing changed, when the text is not such a state
  void restoreState(const std::string& state);
  /// saveState(), then restoreState() of it: the world goes on exactly as a fresh world restored from the returned
  /// text will. A run that may have to be resumed takes one at every experiment boundary. A world unchanged since
  /// its last restore or checkpoint gives that state again, and is not touched.
  std::string checkpoint();

  /// "" when every body is finite and slower than max_speed, else what is wrong.
  std::string checkHealth() const;
  /// Test hook: push a non-finite (or, with @p explode, a huge) force into @p body for the next step.
  void injectFault(const std::string& body, bool explode = false);

 private:
  struct Impl;
  SceneDescription buildScene() const;

  WorldSpec spec_;
  std::uint64_t redraw_seed_;
  std::string known_state_;  ///< the state this world is exactly in, since restoreState(); cleared by any change
  SceneDescription scene_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace xpersif::core
