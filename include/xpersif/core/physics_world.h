/**
 * @file physics_world.h
 * @brief XPERSim's physics: an ODE world built from a WorldSpec, stepped at a fixed rate. ROS-free.
 *
 * Deterministic: the same spec (and seed) and the same sequence of calls give bit-identical states,
 * also with several worlds in one process (each keeps its own solver random seed). Safe: after every
 * step every body is checked (finite, slower than physics.max_speed); a step that breaks that is undone,
 * the world is put back in its last good state, and the step reports what happened.
 *
 * Not thread-safe: one thread at a time (the simulator node serializes access).
 */
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "xpersif/core/scene.h"
#include "xpersif/core/world_spec.h"

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
    bool ok = true;
    std::string problem;  ///< what blew up, when !ok (the world was restored to its last good state)
  };
  /// Advance one physics step (spec().physics.step seconds).
  StepResult step();
  /// Back to the initial state of the spec, with the initial seed.
  void reset();

  /// Wheel rim speeds in m/s, clamped to +-max_wheel_speed. @throws ValidationError if not finite
  void setWheelSpeeds(double left, double right);
  /// Forward speed (m/s) and turn rate (rad/s), converted to wheel speeds. @throws ValidationError
  void setVelocity(double linear, double angular);
  /// Place the robot (its root link) or an object; velocities become zero. @throws ValidationError
  /// (unknown name, non-finite or non-unit pose, or a place outside the arena)
  void setPose(const std::string& body, const Eigen::Isometry3d& world_from_body);

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

  /// "" when every body is finite and slower than max_speed, else what is wrong.
  std::string checkHealth() const;
  /// Test hook: push a non-finite (or, with @p explode, a huge) force into @p body for the next step.
  void injectFault(const std::string& body, bool explode = false);

 private:
  struct Impl;
  SceneDescription buildScene() const;

  WorldSpec spec_;
  std::uint64_t redraw_seed_;
  SceneDescription scene_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace xpersif::core
