/**
 * @file motion_control.h
 * @brief The motion core's shared types (limits, arena, obstacles) and its controllers: go to a pose, turn,
 *        follow a path. Part of the motion core (motion.h), ROS-free and physics-free.
 *
 * Everything works on a planar pose (x, y, yaw in the world frame, metres and radians), whatever measured
 * it (wheel odometry, the overhead camera). A caller runs a controller at a fixed control period:
 * `update(pose, dt)` returns the velocity to send to the robot, plus feedback. Controllers never sleep,
 * never talk to the simulator, and are deterministic (same inputs, same outputs).
 *
 * Bad goals and settings throw ValidationError with one sentence (controllers' setGoal/start, limits);
 * plans that cannot be made (unreachable goal, a push into a wall) are results with a reason sentence,
 * because they are ordinary outcomes that become rejected goals.
 *
 * Conventions: the robot is a disc of radius `robot_radius` that drives along its +x axis (yaw); an
 * Obstacle is an object's footprint (footprint.h: a rectangle or a disc) centred at (x, y) and rotated by
 * yaw; the arena is size_x by size_y (inner extents) centred on the world origin.
 */
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "xpersif/core/common/footprint.h"
#include "xpersif/core/common/pose2d.h"

namespace xpersif::core {

struct Velocity2D {
  double linear = 0;   ///< m/s along the robot's heading (negative: backwards)
  double angular = 0;  ///< rad/s, counter-clockwise positive
};

/// Angle wrapped into (-pi, pi] (the same as wrapAngle, pose2d.h).
double normalizeAngle(double angle);
/// "" when x, y and yaw are finite, else a sentence naming @p field (e.g. "goal.x is NaN; ...").
std::string checkPose(const std::string& field, const Pose2D& pose);

/// Speed and acceleration limits for every controller (the RELOCATION "set maximum velocity" operation).
struct MotionLimits {
  double max_linear = 0.15;                ///< m/s
  double max_angular = 3.0;                ///< rad/s
  double max_linear_acceleration = 0.5;    ///< m/s^2
  double max_angular_acceleration = 10.0;  ///< rad/s^2

  /// "" when every limit is finite and > 0, else a sentence naming the field (prefix "limits.").
  std::string check() const;
  /// @throws ValidationError with check()'s sentence
  void require() const;
};

struct ArenaGeometry {
  double size_x = 0.9, size_y = 0.6;  ///< inner extents, centred on the world origin

  /// "" when both sizes are finite and > 0.
  std::string check() const;
};

/// An object on the floor (its footprint, placed and turned) that the planners keep the robot away from.
struct Obstacle {
  std::string name;
  double x = 0, y = 0, yaw = 0;  ///< centre and rotation in the world frame
  Footprint footprint;           ///< in the object's frame
};

/// Signed distance from the world point (x, y) to the obstacle's footprint (negative inside), m.
double distanceToObstacle(const Obstacle& obstacle, double x, double y);

/**
 * @brief "" when a disc of @p robot_radius centred at (x, y) lies inside the arena with at least
 *        @p margin to every wall, else a sentence saying where the reachable region is.
 */
std::string checkTargetInArena(const ArenaGeometry& arena, double x, double y, double robot_radius,
                               double margin = 0.0);

// ---- controllers --------------------------------------------------------------------------------------

enum class MotionPhase {
  Idle,          ///< no goal yet
  TurnToTarget,  ///< turning in place towards the target point (or away from it, when reversing)
  Drive,         ///< driving with heading correction, slowing down near the target
  FinalTurn,     ///< turning in place to the goal's yaw
  Done,          ///< goal reached; command is zero
  Stopped,       ///< stop() was called; command is zero
  Failed,        ///< gave up (reason says why); command is zero
};
std::string toString(MotionPhase phase);  ///< "idle", "turn_to_target", "drive", "final_turn", ...

struct MotionFeedback {
  Velocity2D command;               ///< send this to the robot
  bool done = false;                ///< reached the goal (phase Done)
  bool failed = false;              ///< gave up (phase Failed); reason says why
  MotionPhase phase = MotionPhase::Idle;
  double distance_remaining = 0;    ///< m, to the goal position (PathFollower: along the remaining path)
  double yaw_error = 0;             ///< rad, goal yaw minus current yaw, wrapped
  std::size_t waypoint = 0;         ///< PathFollower: index of the waypoint being driven to
  std::string reason;               ///< why it failed
};

struct GoToPoseOptions {
  double position_tolerance = 0.005;             ///< m
  double yaw_tolerance = 1.5 * 3.14159265358979 / 180.0;  ///< rad
  bool align_yaw = true;             ///< false: done on arrival, whatever the heading (waypoints)
  bool allow_reverse = true;         ///< drive backwards to targets behind the robot ...
  double reverse_max_distance = 0.06;  ///< ... that are at most this far away
  double stall_time = 5.0;           ///< s with no progress (1 mm or 1 deg) before failing; <= 0: never
  double timeout = 0;                ///< s for the whole goal before failing; <= 0: no limit

  std::string check() const;  ///< "" when consistent (tolerances > 0, finite)
};

/**
 * @brief Drive to a planar pose: turn towards the target point, drive to it with heading correction
 *        (slowing down near it), then turn in place to the goal's yaw. Short targets behind the robot are
 *        reached driving backwards.
 */
class GoToPoseController {
 public:
  /// @throws ValidationError for bad limits or options
  explicit GoToPoseController(MotionLimits limits = {}, GoToPoseOptions options = {});

  /// Start driving to @p goal (replaces any goal). @throws ValidationError (non-finite goal or options)
  void setGoal(const Pose2D& goal);
  void setGoal(const Pose2D& goal, const GoToPoseOptions& options);
  /// One control period: @p current is the measured pose, @p dt the time since the last update (s, > 0).
  /// @throws ValidationError if @p current or @p dt is not finite (dt must be > 0)
  MotionFeedback update(const Pose2D& current, double dt);
  /// Cancel: from now on every update returns a zero command (phase Stopped) until the next setGoal.
  void stop();

  /// @throws ValidationError; takes effect at the next update
  void setLimits(const MotionLimits& limits);
  const MotionLimits& limits() const { return limits_; }
  const GoToPoseOptions& options() const { return options_; }
  const Pose2D& goal() const { return goal_; }
  MotionPhase phase() const { return phase_; }
  /// Has a goal and is neither done, stopped nor failed.
  bool active() const;

 private:
  MotionFeedback finish(MotionPhase phase, const std::string& reason, double distance, double yaw_error);
  Velocity2D limit(Velocity2D wanted, double dt);
  // update()'s steps; @p bearing is the direction from the robot to the goal's position.
  /// The phase this update runs in: arrived, turned in place, or driving.
  void advancePhase(const Pose2D& current, double bearing, double distance, double yaw_error);
  /// Watches the phase's progress; true when there was none for options_.stall_time.
  bool stalled(const Pose2D& current, double bearing, double distance, double yaw_error, double dt);
  /// The wanted command while turning towards the goal or driving to it.
  Velocity2D approachCommand(const Pose2D& current, double bearing, double distance) const;
  /// The final turn's end: within the yaw tolerance and near its centre or turned past it.
  bool finalTurnDone(double yaw_error);

  MotionLimits limits_;
  GoToPoseOptions options_;
  Pose2D goal_;
  MotionPhase phase_ = MotionPhase::Idle;
  MotionPhase watched_phase_ = MotionPhase::Idle;  ///< phase the progress watch's baseline belongs to
  Velocity2D last_command_;
  bool reverse_ = false;
  double last_yaw_error_ = 0;
  double elapsed_ = 0;
  double best_distance_ = 0, best_yaw_error_ = 0, since_progress_ = 0;
  std::string reason_;
};

/// Turn in place to a heading (yaw tolerance and stall/timeout as in GoToPoseOptions).
class TurnController {
 public:
  explicit TurnController(MotionLimits limits = {}, double yaw_tolerance = 1.5 * 3.14159265358979 / 180.0);

  /// @throws ValidationError if @p yaw is not finite
  void setGoal(double yaw);
  /// @throws ValidationError if @p current or @p dt is bad
  MotionFeedback update(const Pose2D& current, double dt);
  void stop();
  void setLimits(const MotionLimits& limits);
  const MotionLimits& limits() const { return inner_.limits(); }
  MotionPhase phase() const { return inner_.phase(); }
  bool active() const { return inner_.active(); }

 private:
  GoToPoseController inner_;
  double yaw_tolerance_;
  bool have_goal_ = false;
  Pose2D anchor_;  ///< where the turn started: the position is held there
};

/**
 * @brief Follow waypoints (e.g. from PathPlanner) with a GoToPoseController: intermediate waypoints are
 *        passed without a final turn (tolerance @p waypoint_tolerance), the last one is reached precisely
 *        with its yaw (the controller's options).
 */
class PathFollower {
 public:
  explicit PathFollower(MotionLimits limits = {}, GoToPoseOptions final_options = {},
                        double waypoint_tolerance = 0.01);

  /// @throws ValidationError if @p waypoints is empty or a waypoint is not finite
  void setPath(const std::vector<Pose2D>& waypoints);
  MotionFeedback update(const Pose2D& current, double dt);
  void stop();
  void setLimits(const MotionLimits& limits);
  const MotionLimits& limits() const { return controller_.limits(); }
  const std::vector<Pose2D>& path() const { return waypoints_; }
  MotionPhase phase() const { return controller_.phase(); }
  bool active() const;

 private:
  void startWaypoint();

  GoToPoseController controller_;
  GoToPoseOptions final_options_;
  double waypoint_tolerance_;
  std::vector<Pose2D> waypoints_;
  std::size_t index_ = 0;
};

}  // namespace xpersif::core
