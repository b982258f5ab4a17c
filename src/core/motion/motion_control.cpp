// The motion core's shared types and its controllers: go to a pose, turn, follow a path (motion_control.h).
#include "xpersif/core/motion/motion_control.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "xpersif/core/common/validation.h"
#include "motion_internal.h"

namespace xpersif::core {

using namespace motion_detail;

double normalizeAngle(double angle) { return wrapAngle(angle); }

std::string checkPose(const std::string& field, const Pose2D& pose) {
  for (auto [name, value] : {std::pair<const char*, double>{"x", pose.x}, {"y", pose.y}, {"yaw", pose.yaw}}) {
    std::string problem = checkFinite(field + "." + name, value);
    if (!problem.empty()) return problem;
  }
  return "";
}

std::string MotionLimits::check() const {
  for (auto [name, value] : {std::pair<const char*, double>{"max_linear", max_linear},
                             {"max_angular", max_angular},
                             {"max_linear_acceleration", max_linear_acceleration},
                             {"max_angular_acceleration", max_angular_acceleration}}) {
    std::string problem = checkPositive(std::string("limits.") + name, value);
    if (!problem.empty()) return problem;
  }
  return "";
}

void MotionLimits::require() const { throwIfInvalid(check()); }

std::string ArenaGeometry::check() const {
  std::string problem = checkPositive("arena.size_x", size_x);
  return problem.empty() ? checkPositive("arena.size_y", size_y) : problem;
}

double distanceToObstacle(const Obstacle& obstacle, double x, double y) {
  // Into the obstacle's frame, where the footprint knows its own distance.
  const double c = std::cos(obstacle.yaw), s = std::sin(obstacle.yaw);
  const double dx = x - obstacle.x, dy = y - obstacle.y;
  return obstacle.footprint.signedDistance(c * dx + s * dy, -s * dx + c * dy);
}

std::string checkTargetInArena(const ArenaGeometry& arena, double x, double y, double robot_radius, double margin) {
  if (!std::isfinite(x) || !std::isfinite(y)) {
    return "the target " + point(x, y) + " is not a finite point";
  }
  const double hx = arena.size_x / 2.0 - robot_radius - margin, hy = arena.size_y / 2.0 - robot_radius - margin;
  if (std::fabs(x) <= hx && std::fabs(y) <= hy) return "";
  std::ostringstream out;
  out.precision(3);
  out << "the target " << point(x, y) << " is outside the reachable part of the arena: a robot of radius "
      << robot_radius << " m kept " << margin << " m from the walls must stay within x in [" << -hx << ", " << hx
      << "] and y in [" << -hy << ", " << hy << "]";
  return out.str();
}

std::string toString(MotionPhase phase) {
  switch (phase) {
    case MotionPhase::Idle: return "idle";
    case MotionPhase::TurnToTarget: return "turn_to_target";
    case MotionPhase::Drive: return "drive";
    case MotionPhase::FinalTurn: return "final_turn";
    case MotionPhase::Done: return "done";
    case MotionPhase::Stopped: return "stopped";
    case MotionPhase::Failed: return "failed";
  }
  return "unknown";
}

std::string GoToPoseOptions::check() const {
  std::string problem = checkPositive("options.position_tolerance", position_tolerance);
  if (problem.empty()) problem = checkPositive("options.yaw_tolerance", yaw_tolerance);
  if (problem.empty()) problem = checkFinite("options.reverse_max_distance", reverse_max_distance);
  if (problem.empty()) problem = checkFinite("options.stall_time", stall_time);
  if (problem.empty()) problem = checkFinite("options.timeout", timeout);
  return problem;
}

// ---- GoToPoseController ---------------------------------------------------------------------------------

GoToPoseController::GoToPoseController(MotionLimits limits, GoToPoseOptions options)
    : limits_(limits), options_(options) {
  limits_.require();
  throwIfInvalid(options_.check());
}

void GoToPoseController::setGoal(const Pose2D& goal) { setGoal(goal, options_); }

void GoToPoseController::setGoal(const Pose2D& goal, const GoToPoseOptions& options) {
  throwIfInvalid(checkPose("goal", goal));
  throwIfInvalid(options.check());
  goal_ = goal;
  goal_.yaw = normalizeAngle(goal.yaw);
  options_ = options;
  phase_ = MotionPhase::TurnToTarget;
  reverse_ = false;
  watched_phase_ = phase_;
  elapsed_ = 0;
  best_distance_ = std::numeric_limits<double>::infinity();
  best_yaw_error_ = std::numeric_limits<double>::infinity();
  since_progress_ = 0;
  reason_.clear();
  // last_command_ is kept: a new goal (e.g. the next waypoint) continues from the current speed.
}

void GoToPoseController::setLimits(const MotionLimits& limits) {
  limits.require();
  limits_ = limits;
}

void GoToPoseController::stop() {
  if (phase_ != MotionPhase::Idle) phase_ = MotionPhase::Stopped;
  last_command_ = {};
}

bool GoToPoseController::active() const {
  return phase_ == MotionPhase::TurnToTarget || phase_ == MotionPhase::Drive || phase_ == MotionPhase::FinalTurn;
}

MotionFeedback GoToPoseController::finish(MotionPhase phase, const std::string& reason, double distance,
                                          double yaw_error) {
  phase_ = phase;
  if (phase == MotionPhase::Failed) reason_ = reason;
  last_command_ = {};
  MotionFeedback fb;
  fb.phase = phase_;
  fb.done = phase_ == MotionPhase::Done;
  fb.failed = phase_ == MotionPhase::Failed;
  fb.reason = reason_;
  fb.distance_remaining = distance;
  fb.yaw_error = yaw_error;
  return fb;
}

Velocity2D GoToPoseController::limit(Velocity2D wanted, double dt) {
  last_command_ = limitCommand(wanted, last_command_, limits_, dt);
  return last_command_;
}

namespace {

// Heading error towards the target point at @p bearing, forwards or (when reversing) backwards.
double headingError(double bearing, const Pose2D& current, bool reverse) {
  return normalizeAngle(bearing + (reverse ? kPi : 0.0) - current.yaw);
}

}  // namespace

void GoToPoseController::advancePhase(const Pose2D& current, double bearing, double distance, double yaw_error) {
  const double tol = options_.position_tolerance;
  if (phase_ == MotionPhase::TurnToTarget || phase_ == MotionPhase::Drive) {
    // Within the tolerance is not enough for a precise goal: keep going until the target is no longer
    // ahead (or very close), so that the robot stops near the centre of the tolerance, not at its edge.
    const double along = distance * std::cos(headingError(bearing, current, reverse_));
    const bool arrived = distance <= tol && (!options_.align_yaw || along <= 0.001 || distance <= 0.3 * tol);
    if (arrived) {
      phase_ = options_.align_yaw ? MotionPhase::FinalTurn : MotionPhase::Done;
      last_yaw_error_ = yaw_error;
    }
  } else if (phase_ == MotionPhase::FinalTurn && distance > 2.0 * tol) {
    phase_ = MotionPhase::TurnToTarget;  // pushed off the spot: go back to it
  }
  if (phase_ == MotionPhase::Done) return;

  if (phase_ == MotionPhase::TurnToTarget) {
    // Decide the driving direction once per approach: backwards only for short targets behind.
    const bool behind = std::fabs(headingError(bearing, current, false)) > kPi / 2.0;
    reverse_ = options_.allow_reverse && behind && distance <= options_.reverse_max_distance;
  }
  if (phase_ == MotionPhase::Drive && std::fabs(headingError(bearing, current, reverse_)) > kTurnAgain) {
    // Far off the line (e.g. overshot sideways near the target): turn in place again.
    phase_ = MotionPhase::TurnToTarget;
    reverse_ = options_.allow_reverse && std::fabs(headingError(bearing, current, false)) > kPi / 2.0 &&
               distance <= options_.reverse_max_distance;
  }
  if (phase_ == MotionPhase::TurnToTarget && std::fabs(headingError(bearing, current, reverse_)) < kStartDriving) {
    phase_ = MotionPhase::Drive;
  }
}

bool GoToPoseController::stalled(const Pose2D& current, double bearing, double distance, double yaw_error, double dt) {
  // The phase's own error must shrink by 1 mm or 1 deg every stall_time seconds (the angle baseline restarts
  // with each phase: it measures a different angle).
  if (phase_ != watched_phase_) {
    watched_phase_ = phase_;
    best_yaw_error_ = std::numeric_limits<double>::infinity();
    since_progress_ = 0;
  }
  const double angle_metric = phase_ == MotionPhase::FinalTurn ? std::fabs(yaw_error)
                                                               : std::fabs(headingError(bearing, current, reverse_));
  if (distance < best_distance_ - 0.001 || angle_metric < best_yaw_error_ - kPi / 180.0) {
    best_distance_ = std::min(best_distance_, distance);
    best_yaw_error_ = std::min(best_yaw_error_, angle_metric);
    since_progress_ = 0;
  } else {
    since_progress_ += dt;
  }
  return options_.stall_time > 0 && since_progress_ > options_.stall_time;
}

Velocity2D GoToPoseController::approachCommand(const Pose2D& current, double bearing, double distance) const {
  Velocity2D wanted;
  const double e = headingError(bearing, current, reverse_);
  if (phase_ == MotionPhase::TurnToTarget) {
    wanted.angular = turnRate(e, limits_);
    return wanted;
  }
  const double along = distance * std::cos(e);  // >= 0 while the target is ahead (behind, when reversing)
  double speed = std::min({kLinearGain * std::fabs(along), brakeProfile(along, limits_.max_linear_acceleration),
                           limits_.max_linear});
  speed = std::max(speed, std::min(kMinLinear, limits_.max_linear));
  if (along < 0) speed = -speed;  // overshot: back up along the heading
  wanted.linear = reverse_ ? -speed : speed;
  // Heading correction towards the point; it fades out near the point, where the bearing gets jumpy.
  const double steer = along < 0 ? normalizeAngle(e - kPi) : e;
  wanted.angular = kHeadingGain * steer * std::min(1.0, distance / kSteerFade);
  return wanted;
}

bool GoToPoseController::finalTurnDone(double yaw_error) {
  // Done inside the tolerance once close to its centre or once the error changed sign (turned past it).
  const bool crossed = (yaw_error > 0) != (last_yaw_error_ > 0);
  last_yaw_error_ = yaw_error;
  const double abs_error = std::fabs(yaw_error);
  return abs_error <= options_.yaw_tolerance && (crossed || abs_error <= options_.yaw_tolerance / 3.0);
}

MotionFeedback GoToPoseController::update(const Pose2D& current, double dt) {
  requireUpdateInput(current, dt);
  const double dx = goal_.x - current.x, dy = goal_.y - current.y;
  const double distance = std::hypot(dx, dy);
  const double yaw_error = options_.align_yaw ? normalizeAngle(goal_.yaw - current.yaw) : 0.0;
  if (!active()) return finish(phase_, reason_, distance, yaw_error);

  elapsed_ += dt;
  if (options_.timeout > 0 && elapsed_ > options_.timeout) {
    return finish(MotionPhase::Failed,
                  "the goal was not reached within the timeout of " + num(options_.timeout) + " s (" + num(distance) +
                      " m and " + num(yaw_error) + " rad still to go)",
                  distance, yaw_error);
  }
  const double bearing = std::atan2(dy, dx);
  advancePhase(current, bearing, distance, yaw_error);
  if (phase_ == MotionPhase::Done) return finish(MotionPhase::Done, "", distance, yaw_error);
  if (stalled(current, bearing, distance, yaw_error, dt)) {
    return finish(MotionPhase::Failed,
                  "no progress for " + num(options_.stall_time) + " s in phase " + toString(phase_) + " at " +
                      point(current.x, current.y) + ", " + num(distance) +
                      " m from the goal: something blocks the robot or its wheels slip",
                  distance, yaw_error);
  }
  Velocity2D wanted;
  if (phase_ != MotionPhase::FinalTurn) {
    wanted = approachCommand(current, bearing, distance);
  } else if (finalTurnDone(yaw_error)) {
    return finish(MotionPhase::Done, "", distance, yaw_error);
  } else {
    wanted.angular = turnRate(yaw_error, limits_);
  }

  MotionFeedback fb;
  fb.command = limit(wanted, dt);
  fb.phase = phase_;
  fb.distance_remaining = distance;
  fb.yaw_error = yaw_error;
  return fb;
}

// ---- TurnController -------------------------------------------------------------------------------------

TurnController::TurnController(MotionLimits limits, double yaw_tolerance)
    : inner_(limits), yaw_tolerance_(yaw_tolerance) {
  throwIfInvalid(checkPositive("yaw_tolerance", yaw_tolerance));
}

void TurnController::setGoal(double yaw) {
  throwIfInvalid(checkFinite("goal.yaw", yaw));
  // The position is held where the robot is at the first update; until then remember the yaw.
  anchor_ = Pose2D{0, 0, normalizeAngle(yaw)};
  have_goal_ = true;
}

MotionFeedback TurnController::update(const Pose2D& current, double dt) {
  requireUpdateInput(current, dt);
  if (have_goal_) {
    GoToPoseOptions options;
    options.yaw_tolerance = yaw_tolerance_;
    options.position_tolerance = 1.0;  // a pure turn: never drive back to the spot
    options.allow_reverse = false;
    inner_.setGoal(Pose2D{current.x, current.y, anchor_.yaw}, options);
    have_goal_ = false;
  }
  MotionFeedback fb = inner_.update(current, dt);
  fb.distance_remaining = 0;
  return fb;
}

void TurnController::stop() {
  have_goal_ = false;
  inner_.stop();
}

void TurnController::setLimits(const MotionLimits& limits) { inner_.setLimits(limits); }

// ---- PathFollower -----------------------------------------------------------------------------------------

PathFollower::PathFollower(MotionLimits limits, GoToPoseOptions final_options, double waypoint_tolerance)
    : controller_(limits, final_options), final_options_(final_options), waypoint_tolerance_(waypoint_tolerance) {
  throwIfInvalid(checkPositive("waypoint_tolerance", waypoint_tolerance));
}

void PathFollower::setPath(const std::vector<Pose2D>& waypoints) {
  if (waypoints.empty()) throw ValidationError("path is empty; it needs at least the goal pose");
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    throwIfInvalid(checkPose("path[" + std::to_string(i) + "]", waypoints[i]));
  }
  waypoints_ = waypoints;
  index_ = 0;
  startWaypoint();
}

void PathFollower::startWaypoint() {
  if (index_ + 1 >= waypoints_.size()) {
    controller_.setGoal(waypoints_[index_], final_options_);
    return;
  }
  GoToPoseOptions passing = final_options_;
  passing.align_yaw = false;
  passing.allow_reverse = false;
  passing.position_tolerance = waypoint_tolerance_;
  controller_.setGoal(waypoints_[index_], passing);
}

MotionFeedback PathFollower::update(const Pose2D& current, double dt) {
  requireUpdateInput(current, dt);
  MotionFeedback fb = controller_.update(current, dt);
  while (fb.done && index_ + 1 < waypoints_.size()) {
    ++index_;
    startWaypoint();
    fb = controller_.update(current, dt);
  }
  fb.waypoint = index_;
  for (std::size_t i = index_ + 1; i < waypoints_.size(); ++i) {
    fb.distance_remaining +=
        std::hypot(waypoints_[i].x - waypoints_[i - 1].x, waypoints_[i].y - waypoints_[i - 1].y);
  }
  return fb;
}

void PathFollower::stop() { controller_.stop(); }
void PathFollower::setLimits(const MotionLimits& limits) { controller_.setLimits(limits); }
bool PathFollower::active() const { return controller_.active(); }

}  // namespace xpersif::core
