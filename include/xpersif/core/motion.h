/**
 * @file motion.h
 * @brief The motion core behind RELOCATION and MANIPULATION, ROS-free and physics-free: controllers
 *        that turn a measured planar pose into a velocity command, a grid path planner around the arena's
 *        walls and the objects, and a push planner + controller for pushing an object (a box on one of its
 *        faces, or a cylinder or sphere along a side's axis).
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

#include "xpersif/core/footprint.h"
#include "xpersif/core/pose2d.h"

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

// ---- path planning ------------------------------------------------------------------------------------

struct PathResult {
  bool ok = false;
  std::string reason;               ///< why there is no path (when !ok)
  std::vector<Pose2D> waypoints;    ///< after the start, ending with the goal (its yaw); intermediate
                                    ///< waypoints' yaw is the direction of travel
  double length = 0;                ///< m, along the waypoints
};

/**
 * @brief Grid A* over the arena (8-connected, @p resolution cells) for a disc robot kept @p margin away
 *        from walls and obstacles, simplified to few waypoints by line of sight. A start that is
 *        closer than the margin (but not overlapping anything) may leave its corner: the robot is allowed
 *        to move out of the margin, at a higher cost.
 */
class PathPlanner {
 public:
  /// @throws ValidationError for a bad arena, radius, margin or resolution
  PathPlanner(ArenaGeometry arena, double robot_radius, double margin = 0.01, double resolution = 0.01);

  /// @throws ValidationError for a non-finite pose or a bad footprint (Footprint::check)
  void setObstacles(std::vector<Obstacle> obstacles);
  const std::vector<Obstacle>& obstacles() const { return obstacles_; }

  /// Never throws for geometric reasons: non-finite poses, goals outside the arena, inside or too close to
  /// an obstacle, a blocked start and unreachable goals all come back as !ok with a reason sentence.
  PathResult plan(const Pose2D& start, const Pose2D& goal) const;

  /// Clearance of a robot centred at (x, y): distance from its centre to the nearest wall or obstacle.
  double clearance(double x, double y) const;
  /// "" when a robot at (x, y) keeps the margin to everything, else which thing is too close.
  std::string checkFree(double x, double y) const;

  double robotRadius() const { return robot_radius_; }
  double margin() const { return margin_; }
  const ArenaGeometry& arena() const { return arena_; }

 private:
  std::string nearestThing(double x, double y) const;

  ArenaGeometry arena_;
  double robot_radius_, margin_, resolution_;
  std::vector<Obstacle> obstacles_;
};

// ---- pushing ------------------------------------------------------------------------------------------

struct PushRequest {
  std::string object;   ///< name of the object to push
  std::string side;     ///< face pushed, in the object's frame: "-x", "+x", "-y" or "+y"; the push goes
                        ///< along that face's inward normal ("-x": along the object's +x axis); for a disc
                        ///< the side only names that direction
  double offset = 0;    ///< contact point's lateral offset from the push line through the object's centre,
                        ///< m, positive to the LEFT of the push direction; |offset| <= maxPushOffset
  double distance = 0.05;  ///< m pushed after contact, in (0, PushOptions::max_distance]
};

struct PushOptions {
  double standoff = 0.03;     ///< gap between the robot's front and the face at the approach pose, m
  double retreat = 0.04;      ///< how far the robot backs off after the push, m
  double margin = 0.01;       ///< kept between the robot and walls/other obstacles (as the path planner)
  double object_clearance = 0.005;  ///< kept between the pushed object and walls/other obstacles at the end
  double max_distance = 0.15;       ///< largest accepted push distance, m (callers derive it from the arena)

  std::string check() const;
};

/// Where the robot goes for one push. Poses are the robot centre's; all face along `direction`.
struct PushPlan {
  bool ok = false;
  std::string reason;    ///< why the push cannot be done (when !ok)
  std::string object;
  std::string side;
  double offset = 0, distance = 0;
  double direction = 0;  ///< yaw of the push direction (world frame)
  Pose2D approach;       ///< standoff before the face, facing the push direction
  Pose2D contact;        ///< the robot's front touches the face (a disc: its rim at the contact point)
  Pose2D push_end;       ///< after pushing `distance`
  Pose2D retreat;        ///< backed off after the push
  Pose2D object_end;     ///< where the object's centre ends if it slides straight along (yaw unchanged)
};

/// "" when @p side is one of "-x", "+x", "-y", "+y".
std::string checkPushSide(const std::string& side);


/**
 * @brief Plan a push of @p object. Never throws for bad requests: an unknown side, a bad footprint, a
 *        non-finite, non-positive or too long distance, |offset| beyond maxPushOffset (footprint.h), an approach or retreat spot
 *        outside the arena or too close to another obstacle, the robot's or the object's path hitting
 *        another obstacle, or the object being pushed into a wall give !ok with a reason sentence.
 * @param others obstacles other than @p object (an entry with object's name is ignored)
 */
PushPlan planPush(const Obstacle& object, const PushRequest& request, double robot_radius,
                  const ArenaGeometry& arena, const std::vector<Obstacle>& others,
                  const PushOptions& options = {});

enum class PushPhase { Idle, Approach, Contact, Push, Retreat, Done, Stopped, Failed };
std::string toString(PushPhase phase);  ///< "idle", "approach", "contact", "push", "retreat", "done", ...

struct PushFeedback {
  Velocity2D command;
  PushPhase phase = PushPhase::Idle;
  double progress = 0;     ///< [0, 1], share of the planned path (approach path, contact, push, retreat) done
  double pushed = 0;       ///< m driven along the push line past the contact pose (PUSH and later); at Done the farthest it got
  bool done = false;       ///< phase Done
  bool failed = false;     ///< phase Failed; reason says why (and in which phase)
  /// Done, but the object resisted: the push stalled (no progress for stall_time) and the robot backed off.
  bool blocked = false;
  std::string reason;
};

struct PushControlOptions {
  double contact_speed = 0.03;  ///< m/s while closing in on the face (CONTACT)
  double push_speed = 0.04;     ///< m/s while pushing (PUSH)
  double retreat_speed = 0.05;  ///< m/s backing off (RETREAT)
  double line_gain = 30.0;      ///< rad/s of turn per m of cross-track error (holds the push line)
  double heading_gain = 3.0;    ///< rad/s of turn per rad of heading error
  double stall_time = 5.0;      ///< s without 1 mm of progress along the line before a phase fails
  double timeout = 120.0;       ///< s for the whole push before failing

  std::string check() const;
};

/**
 * @brief Executes a PushPlan: APPROACH (follow @p approach_path to plan.approach with PathFollower),
 *        CONTACT (straight, slowly, until the robot reaches plan.contact, where it touches the object), PUSH (straight on for the
 *        push distance, holding the push line), RETREAT (backwards to plan.retreat), DONE.
 */
class PushController {
 public:
  /// @throws ValidationError for bad limits or options
  explicit PushController(MotionLimits limits = {}, PushControlOptions options = {});

  /// @p approach_path: waypoints from the current pose to plan.approach, typically PathPlanner::plan(current,
  /// plan.approach).waypoints with every object (the pushed one included) as an obstacle; empty means "drive
  /// straight to plan.approach". The last waypoint is replaced by plan.approach (facing the push direction)
  /// and reached with GoToPoseOptions' defaults (5 mm, 1.5 deg). @throws ValidationError if !plan.ok or a
  /// pose is not finite
  void start(const PushPlan& plan, const std::vector<Pose2D>& approach_path = {});
  /// @throws ValidationError if @p current or @p dt is bad
  PushFeedback update(const Pose2D& current, double dt);
  /// Cancel: the next command (and every one after) is zero, phase Stopped.
  void stop();
  void setLimits(const MotionLimits& limits);
  const MotionLimits& limits() const { return limits_; }
  PushPhase phase() const { return phase_; }
  const PushPlan& plan() const { return plan_; }
  bool active() const;

 private:
  PushFeedback fail(const std::string& reason);
  PushFeedback lineControl(const Pose2D& current, double dt, const Pose2D& to, double speed, bool backwards,
                           bool brake, double& along_out);

  MotionLimits limits_;
  PushControlOptions options_;
  PathFollower follower_;
  PushPlan plan_;
  PushPhase phase_ = PushPhase::Idle;
  double approach_length_ = 0, total_length_ = 0;
  double elapsed_ = 0, best_along_ = 0, since_progress_ = 0, progress_ = 0;
  bool blocked_ = false;
  double pushed_most_ = 0;  // m, the farthest the robot got past the contact pose while pushing
  Velocity2D last_command_;
  std::string reason_;
};

}  // namespace xpersif::core
