/**
 * @file push_motion.h
 * @brief Pushing an object: the push planner (approach, contact and push poses for a face of a box, or a side of
 *        a cylinder or sphere) and the push controller that drives it. Part of the motion core (motion.h).
 */
#pragma once

#include <string>
#include <vector>

#include "xpersif/core/motion/path_planner.h"

namespace xpersif::core {

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

/// Signed m @p pose lies past @p plan's contact pose along the push direction (negative before contact).
double pastContact(const PushPlan& plan, const Pose2D& pose);

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
  // update()'s steps.
  /// The feedback of a push that is not running (idle, done, stopped or failed).
  PushFeedback idleFeedback() const;
  /// Driving to the approach pose, not there yet.
  PushFeedback approachFeedback(const MotionFeedback& m);
  /// Contact, push and retreat along the push line, in turn as each ends; a done feedback when the retreat ends.
  PushFeedback followLine(const Pose2D& current, double dt, double pushed, double& along);
  /// Watches the progress along the line; true when there was none for options_.stall_time.
  bool stalled(double along, double dt);
  /// The object resists: retreat from where the robot is (@p pushed past the contact), marked blocked.
  void backOff(double pushed, double back);
  /// How much of the whole way (approach, standoff, push, retreat of @p back) is behind the robot.
  double doneLength(double pushed, double standoff, double back) const;
  /// @p length as a share of the whole way, 0..1.
  double share(double length) const;

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
