// The motion core: go-to-pose / turn / path following controllers, grid A* path planner, push planner
// and push controller. See motion.h for the conventions.
#include "xpersif/core/motion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <sstream>

#include "xpersif/core/experiment.h"
#include "xpersif/core/validation.h"

namespace xpersif::core {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Controller tuning. The gains are per second (the controller is run every 10-50 ms); the square-root
// profiles keep a decelerating command within the acceleration limits, so the robot does not overshoot.
constexpr double kLinearGain = 1.5;       // 1/s: m/s per m of remaining distance
constexpr double kMinLinear = 0.008;      // m/s: below this the last millimetres take too long
constexpr double kTurnGain = 5.0;         // 1/s: rad/s per rad of heading error
constexpr double kMinAngular = 0.25;      // rad/s
constexpr double kHeadingGain = 4.0;      // 1/s: heading correction while driving
constexpr double kStartDriving = 0.05;    // rad: heading error below which TurnToTarget gives way to Drive
constexpr double kTurnAgain = 0.6;        // rad: heading error above which Drive turns in place again
constexpr double kSteerFade = 0.03;       // m: heading correction fades out closer than this to the target

std::string num(double v) { return describeNumber(v); }

std::string point(double x, double y) {
  std::ostringstream out;
  out.precision(3);
  out << "(" << x << ", " << y << ")";
  return out.str();
}

double clampAbs(double v, double max) { return std::max(-max, std::min(max, v)); }

// |v| reduced so that it can reach zero within @p remaining at @p accel (with a safety factor).
double brakeProfile(double remaining, double accel) { return std::sqrt(2.0 * accel * std::fabs(remaining)) * 0.8; }

Velocity2D limitCommand(Velocity2D wanted, const Velocity2D& last, const MotionLimits& limits, double dt) {
  wanted.linear = clampAbs(wanted.linear, limits.max_linear);
  wanted.angular = clampAbs(wanted.angular, limits.max_angular);
  const double dv = limits.max_linear_acceleration * dt, dw = limits.max_angular_acceleration * dt;
  wanted.linear = std::max(last.linear - dv, std::min(last.linear + dv, wanted.linear));
  wanted.angular = std::max(last.angular - dw, std::min(last.angular + dw, wanted.angular));
  return wanted;
}

// Turn rate for a heading error: proportional, braking-limited, with a floor so that it finishes.
double turnRate(double error, const MotionLimits& limits) {
  double w = std::min({kTurnGain * std::fabs(error), brakeProfile(error, limits.max_angular_acceleration),
                       limits.max_angular});
  w = std::max(w, std::min(kMinAngular, limits.max_angular));
  return error >= 0 ? w : -w;
}

void requireUpdateInput(const Pose2D& current, double dt) {
  throwIfInvalid(checkPose("current", current));
  throwIfInvalid(checkPositive("dt", dt));
}

}  // namespace

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

  const double tol = options_.position_tolerance;
  // Heading error towards the target point, forwards or (when reversing) backwards.
  const double bearing = std::atan2(dy, dx);
  auto headingError = [&](bool reverse) { return normalizeAngle(bearing + (reverse ? kPi : 0.0) - current.yaw); };

  if (phase_ == MotionPhase::TurnToTarget || phase_ == MotionPhase::Drive) {
    // Within the tolerance is not enough for a precise goal: keep going until the target is no longer
    // ahead (or very close), so that the robot stops near the centre of the tolerance, not at its edge.
    const double along = distance * std::cos(headingError(reverse_));
    const bool arrived = distance <= tol && (!options_.align_yaw || along <= 0.001 || distance <= 0.3 * tol);
    if (arrived) {
      phase_ = options_.align_yaw ? MotionPhase::FinalTurn : MotionPhase::Done;
      last_yaw_error_ = yaw_error;
    }
  } else if (phase_ == MotionPhase::FinalTurn && distance > 2.0 * tol) {
    phase_ = MotionPhase::TurnToTarget;  // pushed off the spot: go back to it
  }
  if (phase_ == MotionPhase::Done) return finish(MotionPhase::Done, "", distance, yaw_error);

  if (phase_ == MotionPhase::TurnToTarget) {
    // Decide the driving direction once per approach: backwards only for short targets behind.
    const bool behind = std::fabs(headingError(false)) > kPi / 2.0;
    reverse_ = options_.allow_reverse && behind && distance <= options_.reverse_max_distance;
  }
  const double heading_error = headingError(reverse_);
  if (phase_ == MotionPhase::Drive && std::fabs(heading_error) > kTurnAgain) {
    // Far off the line (e.g. overshot sideways near the target): turn in place again.
    phase_ = MotionPhase::TurnToTarget;
    reverse_ = options_.allow_reverse && std::fabs(headingError(false)) > kPi / 2.0 &&
               distance <= options_.reverse_max_distance;
  }
  if (phase_ == MotionPhase::TurnToTarget && std::fabs(headingError(reverse_)) < kStartDriving) {
    phase_ = MotionPhase::Drive;
  }

  // Progress watch: the phase's own error must shrink by 1 mm or 1 deg every stall_time seconds (the angle
  // baseline restarts with each phase: it measures a different angle).
  if (phase_ != watched_phase_) {
    watched_phase_ = phase_;
    best_yaw_error_ = std::numeric_limits<double>::infinity();
    since_progress_ = 0;
  }
  const double angle_metric =
      phase_ == MotionPhase::FinalTurn ? std::fabs(yaw_error) : std::fabs(headingError(reverse_));
  if (distance < best_distance_ - 0.001 || angle_metric < best_yaw_error_ - kPi / 180.0) {
    best_distance_ = std::min(best_distance_, distance);
    best_yaw_error_ = std::min(best_yaw_error_, angle_metric);
    since_progress_ = 0;
  } else {
    since_progress_ += dt;
  }
  if (options_.stall_time > 0 && since_progress_ > options_.stall_time) {
    return finish(MotionPhase::Failed,
                  "no progress for " + num(options_.stall_time) + " s in phase " + toString(phase_) + " at " +
                      point(current.x, current.y) + ", " + num(distance) +
                      " m from the goal: something blocks the robot or its wheels slip",
                  distance, yaw_error);
  }

  Velocity2D wanted;
  if (phase_ == MotionPhase::TurnToTarget) {
    wanted.angular = turnRate(headingError(reverse_), limits_);
  } else if (phase_ == MotionPhase::Drive) {
    const double e = headingError(reverse_);
    const double along = distance * std::cos(e);  // >= 0 while the target is ahead (behind, when reversing)
    double speed = std::min({kLinearGain * std::fabs(along),
                             brakeProfile(along, limits_.max_linear_acceleration), limits_.max_linear});
    speed = std::max(speed, std::min(kMinLinear, limits_.max_linear));
    if (along < 0) speed = -speed;  // overshot: back up along the heading
    wanted.linear = reverse_ ? -speed : speed;
    // Heading correction towards the point; it fades out near the point, where the bearing gets jumpy.
    const double steer = along < 0 ? normalizeAngle(e - kPi) : e;
    wanted.angular = kHeadingGain * steer * std::min(1.0, distance / kSteerFade);
  } else {  // FinalTurn
    // Done inside the tolerance once close to its centre or once the error changed sign (turned past it).
    const bool crossed = (yaw_error > 0) != (last_yaw_error_ > 0);
    last_yaw_error_ = yaw_error;
    const double abs_error = std::fabs(yaw_error);
    if (abs_error <= options_.yaw_tolerance && (crossed || abs_error <= options_.yaw_tolerance / 3.0)) {
      return finish(MotionPhase::Done, "", distance, yaw_error);
    }
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

// ---- PathPlanner ------------------------------------------------------------------------------------------

PathPlanner::PathPlanner(ArenaGeometry arena, double robot_radius, double margin, double resolution)
    : arena_(arena), robot_radius_(robot_radius), margin_(margin), resolution_(resolution) {
  throwIfInvalid(arena_.check());
  throwIfInvalid(checkPositive("robot_radius", robot_radius));
  throwIfInvalid(checkInRange("margin", margin, 0.0, 1.0));
  throwIfInvalid(checkInRange("resolution", resolution, 0.001, 0.1));
}

void PathPlanner::setObstacles(std::vector<Obstacle> obstacles) {
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    const std::string field = "obstacles[" + std::to_string(i) + "]";
    throwIfInvalid(checkPose(field, Pose2D{obstacles[i].x, obstacles[i].y, obstacles[i].yaw}));
    throwIfInvalid(obstacles[i].footprint.check(field + ".footprint"));
  }
  obstacles_ = std::move(obstacles);
}

double PathPlanner::clearance(double x, double y) const {
  double c = std::min({arena_.size_x / 2.0 - std::fabs(x), arena_.size_y / 2.0 - std::fabs(y)});
  for (const auto& o : obstacles_) c = std::min(c, distanceToObstacle(o, x, y));
  return c;
}

std::string PathPlanner::nearestThing(double x, double y) const {
  std::string name = "the wall";
  double best = std::min(arena_.size_x / 2.0 - std::fabs(x), arena_.size_y / 2.0 - std::fabs(y));
  for (const auto& o : obstacles_) {
    const double d = distanceToObstacle(o, x, y);
    if (d < best) {
      best = d;
      name = o.name.empty() ? std::string("an obstacle") : o.name;
    }
  }
  return name;
}

std::string PathPlanner::checkFree(double x, double y) const {
  std::string outside = checkTargetInArena(arena_, x, y, robot_radius_, margin_);
  if (!outside.empty()) return outside;
  const double c = clearance(x, y);
  if (c >= robot_radius_ + margin_) return "";
  std::ostringstream out;
  out.precision(3);
  out << "the spot " << point(x, y) << " is too close to " << nearestThing(x, y) << ": the robot's centre would be "
      << c << " m from it, less than its radius " << robot_radius_ << " m plus the margin " << margin_ << " m";
  return out.str();
}

PathResult PathPlanner::plan(const Pose2D& start, const Pose2D& goal) const {
  PathResult result;
  if (std::string p = checkPose("start", start); !p.empty()) return result.reason = p, result;
  if (std::string p = checkPose("goal", goal); !p.empty()) return result.reason = p, result;
  if (std::string p = checkFree(goal.x, goal.y); !p.empty()) return result.reason = "goal: " + p, result;
  // The start may be inside the margin (e.g. right after a push) but must not overlap anything.
  constexpr double kSlack = 0.002;  // touching within 2 mm counts as touching, not overlapping
  const double start_clearance = clearance(start.x, start.y);
  if (start_clearance < robot_radius_ - kSlack) {
    std::ostringstream out;
    out.precision(3);
    out << "the start " << point(start.x, start.y) << " is blocked: the robot there overlaps "
        << nearestThing(start.x, start.y) << " (its centre is " << start_clearance << " m from it, radius "
        << robot_radius_ << " m)";
    result.reason = out.str();
    return result;
  }

  const int nx = std::max(1, static_cast<int>(std::floor(arena_.size_x / resolution_)));
  const int ny = std::max(1, static_cast<int>(std::floor(arena_.size_y / resolution_)));
  const double cell_x = arena_.size_x / nx, cell_y = arena_.size_y / ny;
  auto centreX = [&](int i) { return -arena_.size_x / 2.0 + (i + 0.5) * cell_x; };
  auto centreY = [&](int j) { return -arena_.size_y / 2.0 + (j + 0.5) * cell_y; };
  auto cellOf = [&](double x, double y) {
    const int i = std::clamp(static_cast<int>(std::floor((x + arena_.size_x / 2.0) / cell_x)), 0, nx - 1);
    const int j = std::clamp(static_cast<int>(std::floor((y + arena_.size_y / 2.0) / cell_y)), 0, ny - 1);
    return j * nx + i;
  };
  const int n = nx * ny;
  // 0 blocked, 1 free (keeps the margin), 2 "soft" (inside the margin, not overlapping).
  std::vector<double> clear(n);
  std::vector<char> state(n, 0);
  for (int k = 0; k < n; ++k) {
    clear[k] = clearance(centreX(k % nx), centreY(k / nx));
    state[k] = clear[k] >= robot_radius_ + margin_ ? 1 : (clear[k] >= robot_radius_ ? 2 : 0);
  }
  const int start_cell = cellOf(start.x, start.y), goal_cell = cellOf(goal.x, goal.y);
  // Soft cells are usable only to get out of the margin from the start: the soft region around it.
  std::vector<char> usable(n, 0);
  for (int k = 0; k < n; ++k) usable[k] = state[k] == 1;
  {
    std::vector<int> stack{start_cell};
    usable[start_cell] = 1;
    while (!stack.empty()) {
      const int k = stack.back();
      stack.pop_back();
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di) {
          const int i = k % nx + di, j = k / nx + dj;
          if (i < 0 || j < 0 || i >= nx || j >= ny) continue;
          const int m = j * nx + i;
          if (state[m] == 2 && !usable[m]) {
            usable[m] = 1;
            stack.push_back(m);
          }
        }
    }
  }
  usable[goal_cell] = 1;  // the goal itself was checked exactly above

  // A* (8-connected, octile heuristic); soft cells cost more so that the path leaves the margin quickly.
  std::vector<double> g(n, std::numeric_limits<double>::infinity());
  std::vector<int> parent(n, -1);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  auto heuristic = [&](int k) {
    const double ax = std::fabs(centreX(k % nx) - centreX(goal_cell % nx));
    const double ay = std::fabs(centreY(k / nx) - centreY(goal_cell / nx));
    return std::max(ax, ay) + (std::sqrt(2.0) - 1.0) * std::min(ax, ay);
  };
  g[start_cell] = 0;
  open.push({heuristic(start_cell), start_cell});
  while (!open.empty()) {
    const auto [f, k] = open.top();
    open.pop();
    if (k == goal_cell) break;
    if (f > g[k] + heuristic(k) + 1e-12) continue;  // stale entry
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        if (!di && !dj) continue;
        const int i = k % nx + di, j = k / nx + dj;
        if (i < 0 || j < 0 || i >= nx || j >= ny) continue;
        const int m = j * nx + i;
        if (!usable[m]) continue;
        const double step = std::hypot(di * cell_x, dj * cell_y) * (state[m] == 2 ? 5.0 : 1.0);
        if (g[k] + step < g[m]) {
          g[m] = g[k] + step;
          parent[m] = k;
          open.push({g[m] + heuristic(m), m});
        }
      }
  }
  if (!std::isfinite(g[goal_cell])) {
    std::ostringstream out;
    out.precision(3);
    out << "no path from " << point(start.x, start.y) << " to " << point(goal.x, goal.y)
        << ": the obstacles close the way for a robot of radius " << robot_radius_ << " m kept " << margin_
        << " m from everything";
    result.reason = out.str();
    return result;
  }

  // Cell chain start..goal, with the exact start and goal at its ends.
  std::vector<int> cells;
  for (int k = goal_cell; k != -1; k = parent[k]) cells.push_back(k);
  std::reverse(cells.begin(), cells.end());
  struct P {
    double x, y, clear;
  };
  std::vector<P> pts;
  for (int k : cells) pts.push_back({centreX(k % nx), centreY(k / nx), clear[k]});
  pts.front() = {start.x, start.y, start_clearance};
  if (pts.size() == 1) pts.push_back({goal.x, goal.y, clearance(goal.x, goal.y)});
  else pts.back() = {goal.x, goal.y, clearance(goal.x, goal.y)};

  // Line-of-sight simplification: a shortcut must keep as much clearance as the cells it replaces
  // (at least the margin, or what the start region had).
  const double wanted = robot_radius_ + margin_;
  auto segmentOk = [&](std::size_t a, std::size_t b) {
    double need = wanted;
    for (std::size_t k = a; k <= b; ++k) need = std::min(need, pts[k].clear);
    need -= 1e-9;
    const double len = std::hypot(pts[b].x - pts[a].x, pts[b].y - pts[a].y);
    const int samples = std::max(1, static_cast<int>(std::ceil(len / (resolution_ / 4.0))));
    for (int s = 0; s <= samples; ++s) {
      const double t = static_cast<double>(s) / samples;
      if (clearance(pts[a].x + t * (pts[b].x - pts[a].x), pts[a].y + t * (pts[b].y - pts[a].y)) < need) return false;
    }
    return true;
  };
  std::vector<std::size_t> keep{0};
  std::size_t anchor = 0;
  while (anchor + 1 < pts.size()) {
    std::size_t next = anchor + 1;
    for (std::size_t b = pts.size() - 1; b > anchor + 1; --b) {
      if (segmentOk(anchor, b)) {
        next = b;
        break;
      }
    }
    keep.push_back(next);
    anchor = next;
  }
  double px = start.x, py = start.y;
  for (std::size_t idx = 1; idx < keep.size(); ++idx) {
    const P& p = pts[keep[idx]];
    Pose2D w{p.x, p.y, std::atan2(p.y - py, p.x - px)};
    result.length += std::hypot(p.x - px, p.y - py);
    if (idx + 1 == keep.size()) w.yaw = normalizeAngle(goal.yaw);
    result.waypoints.push_back(w);
    px = p.x;
    py = p.y;
  }
  result.ok = true;
  return result;
}

// ---- pushing ------------------------------------------------------------------------------------------------

std::string PushOptions::check() const {
  std::string p = checkPositive("push_options.standoff", standoff);
  if (p.empty()) p = checkPositive("push_options.retreat", retreat);
  if (p.empty()) p = checkInRange("push_options.margin", margin, 0.0, 1.0);
  if (p.empty()) p = checkInRange("push_options.object_clearance", object_clearance, 0.0, 1.0);
  if (p.empty()) p = checkPositive("push_options.max_distance", max_distance);
  return p;
}

std::string checkPushSide(const std::string& side) { return checkOneOf("side", side, pushSides()); }

PushPlan planPush(const Obstacle& object, const PushRequest& request, double robot_radius,
                  const ArenaGeometry& arena, const std::vector<Obstacle>& others, const PushOptions& options) {
  PushPlan plan;
  plan.object = request.object.empty() ? object.name : request.object;
  plan.side = request.side;
  plan.offset = request.offset;
  plan.distance = request.distance;
  auto reject = [&](const std::string& reason) {
    plan.ok = false;
    plan.reason = reason;
    return plan;
  };
  if (std::string p = options.check(); !p.empty()) return reject(p);
  if (std::string p = arena.check(); !p.empty()) return reject(p);
  if (std::string p = checkPositive("robot_radius", robot_radius); !p.empty()) return reject(p);
  if (std::string p = checkPose(plan.object, Pose2D{object.x, object.y, object.yaw}); !p.empty()) return reject(p);
  if (std::string p = object.footprint.check(plan.object + ".footprint"); !p.empty()) return reject(p);
  if (std::string p = checkPushSide(request.side); !p.empty()) return reject(p);
  if (std::string p = checkPositive("distance", request.distance); !p.empty()) return reject(p);
  if (request.distance > options.max_distance) {
    return reject("distance is " + num(request.distance) + " m; a push may be at most " + num(options.max_distance) +
                  " m long");
  }
  const Footprint& shape = object.footprint;
  const double max_offset = maxPushOffset(shape, request.side);
  if (std::string p = checkInRange("offset", request.offset, -max_offset, max_offset); !p.empty()) {
    return reject(p + " (" + plan.object + " is " + shape.describe() +
                  (shape.isDisc() ? ": the contact must stay within half its radius of the push line, on its front)"
                                  : ": the contact must stay on the face)"));
  }

  // Push direction: the inward normal of the pushed face, in the world frame.
  double local = 0;
  if (request.side == "+x") local = kPi;
  if (request.side == "-y") local = kPi / 2.0;
  if (request.side == "+y") local = -kPi / 2.0;
  plan.direction = normalizeAngle(object.yaw + local);
  const double dx = std::cos(plan.direction), dy = std::sin(plan.direction);
  const double lx = -dy, ly = dx;  // left of the push direction
  // Robot centre at contact, relative to the object's centre: `back` behind it along the push, `lateral` to
  // the left. A flat face is touched at the point straight ahead of the robot's centre. Two touching discs
  // touch on their centre line, at the object's radius R from its centre out of R + robot_radius: for the
  // contact to lie `offset` off the push line, the robot's centre lies offset * (R + robot_radius) / R off it.
  double back = shape.depth(request.side) + robot_radius, lateral = request.offset;
  if (shape.isDisc()) {
    const double reach = shape.radius + robot_radius;
    lateral = request.offset * reach / shape.radius;
    back = std::sqrt(reach * reach - lateral * lateral);
  }
  const double cx = object.x - back * dx + lateral * lx;
  const double cy = object.y - back * dy + lateral * ly;
  auto along = [&](double s) { return Pose2D{cx + s * dx, cy + s * dy, plan.direction}; };
  plan.contact = along(0);
  plan.approach = along(-options.standoff);
  plan.push_end = along(request.distance);
  plan.retreat = along(request.distance - options.retreat);
  plan.object_end = Pose2D{object.x + request.distance * dx, object.y + request.distance * dy, object.yaw};

  const std::string what = "the " + request.side + (shape.isDisc() ? " side" : " face") + " of " + plan.object;
  PathPlanner space(arena, robot_radius, options.margin);
  std::vector<Obstacle> rest;
  for (const auto& o : others) {
    if (o.name != object.name) rest.push_back(o);
  }
  space.setObstacles(rest);
  if (std::string p = space.checkFree(plan.approach.x, plan.approach.y); !p.empty()) {
    return reject("the approach spot before " + what + " cannot be used: " + p);
  }
  // The object must stay clear of the walls (its footprint's extent along x and y) ...
  double ex = 0, ey = 0;
  worldHalfExtents(shape, object.yaw, ex, ey);
  const double room_x = arena.size_x / 2.0 - ex - options.object_clearance;
  const double room_y = arena.size_y / 2.0 - ey - options.object_clearance;
  if (std::fabs(plan.object_end.x) > room_x || std::fabs(plan.object_end.y) > room_y) {
    return reject("pushing " + plan.object + " " + num(request.distance) + " m from " + what +
                  " would push it into the wall (it would end at " + point(plan.object_end.x, plan.object_end.y) +
                  ", beyond the " + num(options.object_clearance) + " m kept from the walls)");
  }
  // ... and the robot must not reach a wall either.
  if (std::string p = checkTargetInArena(arena, plan.push_end.x, plan.push_end.y, robot_radius, 0.0); !p.empty()) {
    return reject("the robot would hit the wall while pushing " + plan.object + ": " + p);
  }
  // Neither the object's nor the robot's swept path may hit another obstacle (the object's footprint is
  // taken as its circumscribed disc: conservative, since the object may turn while pushed).
  const double object_radius = shape.circumradius();
  const int samples = static_cast<int>(std::ceil((request.distance + options.standoff) / 0.002));
  for (int s = 0; s <= samples; ++s) {
    const double t = -options.standoff + (request.distance + options.standoff) * s / samples;
    const Pose2D r = along(t);
    for (const auto& o : rest) {
      if (distanceToObstacle(o, r.x, r.y) < robot_radius + 0.002) {
        return reject("the robot would hit " + o.name + " while pushing " + what);
      }
      if (t >= 0) {
        const double ox = object.x + t * dx, oy = object.y + t * dy;
        if (distanceToObstacle(o, ox, oy) < object_radius + options.object_clearance) {
          return reject("pushing " + plan.object + " " + num(request.distance) + " m from " + what +
                        " would push it into " + o.name);
        }
      }
    }
  }
  plan.ok = true;
  return plan;
}

std::string toString(PushPhase phase) {
  switch (phase) {
    case PushPhase::Idle: return "idle";
    case PushPhase::Approach: return "approach";
    case PushPhase::Contact: return "contact";
    case PushPhase::Push: return "push";
    case PushPhase::Retreat: return "retreat";
    case PushPhase::Done: return "done";
    case PushPhase::Stopped: return "stopped";
    case PushPhase::Failed: return "failed";
  }
  return "unknown";
}

std::string PushControlOptions::check() const {
  std::string p = checkPositive("push_control.contact_speed", contact_speed);
  if (p.empty()) p = checkPositive("push_control.push_speed", push_speed);
  if (p.empty()) p = checkPositive("push_control.retreat_speed", retreat_speed);
  if (p.empty()) p = checkInRange("push_control.line_gain", line_gain, 0.0, 1e4);
  if (p.empty()) p = checkInRange("push_control.heading_gain", heading_gain, 0.0, 1e3);
  if (p.empty()) p = checkFinite("push_control.stall_time", stall_time);
  if (p.empty()) p = checkFinite("push_control.timeout", timeout);
  return p;
}

PushController::PushController(MotionLimits limits, PushControlOptions options)
    : limits_(limits), options_(options), follower_(limits) {
  limits_.require();
  throwIfInvalid(options_.check());
}

void PushController::start(const PushPlan& plan, const std::vector<Pose2D>& approach_path) {
  if (!plan.ok) {
    throw ValidationError("the push plan cannot be executed: " +
                          (plan.reason.empty() ? std::string("it was not made by planPush") : plan.reason));
  }
  for (auto [name, pose] : {std::pair<const char*, Pose2D>{"plan.approach", plan.approach},
                            {"plan.contact", plan.contact},
                            {"plan.push_end", plan.push_end},
                            {"plan.retreat", plan.retreat}}) {
    throwIfInvalid(checkPose(name, pose));
  }
  blocked_ = false;
  pushed_most_ = 0;
  std::vector<Pose2D> path = approach_path;
  for (std::size_t i = 0; i < path.size(); ++i) {
    throwIfInvalid(checkPose("approach_path[" + std::to_string(i) + "]", path[i]));
  }
  if (path.empty() || std::hypot(path.back().x - plan.approach.x, path.back().y - plan.approach.y) > 0.001) {
    path.push_back(plan.approach);
  }
  path.back() = plan.approach;  // facing the push direction
  GoToPoseOptions final_options;
  final_options.stall_time = options_.stall_time;
  follower_ = PathFollower(limits_, final_options);
  follower_.setPath(path);
  plan_ = plan;
  phase_ = PushPhase::Approach;
  approach_length_ = -1;  // measured at the first update, from where the robot is
  total_length_ = 0;
  elapsed_ = 0;
  best_along_ = -std::numeric_limits<double>::infinity();
  since_progress_ = 0;
  progress_ = 0;
  reason_.clear();
}

void PushController::stop() {
  follower_.stop();
  if (phase_ != PushPhase::Idle) phase_ = PushPhase::Stopped;
  last_command_ = {};
}

void PushController::setLimits(const MotionLimits& limits) {
  limits.require();
  limits_ = limits;
  follower_.setLimits(limits);
}

bool PushController::active() const {
  return phase_ == PushPhase::Approach || phase_ == PushPhase::Contact || phase_ == PushPhase::Push ||
         phase_ == PushPhase::Retreat;
}

PushFeedback PushController::fail(const std::string& reason) {
  reason_ = "push of " + plan_.object + " failed in " + toString(phase_) + ": " + reason;
  phase_ = PushPhase::Failed;
  last_command_ = {};
  follower_.stop();
  PushFeedback fb;
  fb.phase = phase_;
  fb.failed = true;
  fb.reason = reason_;
  return fb;
}

// Drive along the push line (through plan.contact, direction plan.direction) towards @p to, forwards or
// backwards, holding the heading on the line; with @p brake slowing down before @p to. along_out: signed
// distance of the robot past @p to along the direction of travel (negative while on the way).
PushFeedback PushController::lineControl(const Pose2D& current, double dt, const Pose2D& to, double speed,
                                         bool backwards, bool brake, double& along_out) {
  const double dx = std::cos(plan_.direction), dy = std::sin(plan_.direction);
  const double rx = current.x - plan_.contact.x, ry = current.y - plan_.contact.y;
  const double cross = -dy * rx + dx * ry;  // > 0: left of the line
  const double past = (current.x - to.x) * dx + (current.y - to.y) * dy;
  along_out = backwards ? -past : past;
  const double remaining = -along_out;
  double v = speed;
  if (brake) {
    v = std::min({speed, kLinearGain * remaining, brakeProfile(remaining, limits_.max_linear_acceleration)});
    v = std::max(v, kMinLinear);
  }
  const double heading_error = normalizeAngle(plan_.direction - current.yaw);
  Velocity2D wanted;
  wanted.linear = backwards ? -v : v;
  wanted.angular = options_.heading_gain * heading_error + (backwards ? 1.0 : -1.0) * options_.line_gain * cross;
  last_command_ = limitCommand(wanted, last_command_, limits_, dt);
  PushFeedback fb;
  fb.command = last_command_;
  fb.phase = phase_;
  return fb;
}

PushFeedback PushController::update(const Pose2D& current, double dt) {
  requireUpdateInput(current, dt);
  if (!active()) {
    PushFeedback fb;
    fb.phase = phase_;
    fb.done = phase_ == PushPhase::Done;
    fb.failed = phase_ == PushPhase::Failed;
    fb.reason = reason_;
    fb.progress = phase_ == PushPhase::Done ? 1.0 : progress_;
    return fb;
  }
  elapsed_ += dt;
  if (options_.timeout > 0 && elapsed_ > options_.timeout) {
    return fail("not finished within the timeout of " + num(options_.timeout) + " s");
  }
  const double standoff =
      std::hypot(plan_.contact.x - plan_.approach.x, plan_.contact.y - plan_.approach.y);
  const double back = std::hypot(plan_.push_end.x - plan_.retreat.x, plan_.push_end.y - plan_.retreat.y);
  const double dx = std::cos(plan_.direction), dy = std::sin(plan_.direction);
  const double pushed = (current.x - plan_.contact.x) * dx + (current.y - plan_.contact.y) * dy;

  PushFeedback fb;
  double done_length = 0;  // for progress
  auto share = [&](double length) {
    return total_length_ > 0 ? std::clamp(length / total_length_, 0.0, 1.0) : 0.0;
  };
  if (phase_ == PushPhase::Approach) {
    MotionFeedback m = follower_.update(current, dt);
    if (approach_length_ < 0) {
      approach_length_ = m.distance_remaining;
      total_length_ = approach_length_ + standoff + plan_.distance + back;
    }
    if (m.failed) return fail(m.reason);
    if (!m.done) {
      fb.command = last_command_ = m.command;
      fb.phase = phase_;
      done_length = std::max(0.0, approach_length_ - m.distance_remaining);
      fb.progress = progress_ = std::max(progress_, share(done_length));
      return fb;
    }
    phase_ = PushPhase::Contact;
    best_along_ = -std::numeric_limits<double>::infinity();
    since_progress_ = 0;
  }

  double along = 0;
  if (phase_ == PushPhase::Contact) {
    fb = lineControl(current, dt, plan_.contact, options_.contact_speed, false, false, along);
    if (along >= 0) phase_ = PushPhase::Push;
  }
  if (phase_ == PushPhase::Push) {
    pushed_most_ = std::max(pushed_most_, pushed);
    fb = lineControl(current, dt, plan_.push_end, options_.push_speed, false, true, along);
    if (along >= 0) {
      phase_ = PushPhase::Retreat;
      best_along_ = -std::numeric_limits<double>::infinity();
      since_progress_ = 0;
    }
  }
  if (phase_ == PushPhase::Retreat) {
    fb = lineControl(current, dt, plan_.retreat, options_.retreat_speed, true, true, along);
    if (along >= -0.002) {
      phase_ = PushPhase::Done;
      last_command_ = {};
      fb = PushFeedback{};
      fb.phase = phase_;
      fb.done = true;
      fb.blocked = blocked_;
      fb.progress = 1.0;
      fb.pushed = pushed_most_;
      return fb;
    }
  }
  // Progress along the line must go on (1 mm per stall_time).
  if (along > best_along_ + 0.001) {
    best_along_ = along;
    since_progress_ = 0;
  } else {
    since_progress_ += dt;
  }
  if (options_.stall_time > 0 && since_progress_ > options_.stall_time) {
    if (phase_ != PushPhase::Push) {
      return fail("no progress along the push line for " + num(options_.stall_time) +
                  " s: something blocks the robot, or its wheels slip");
    }
    // The object resists (too heavy, or held): that is an outcome, not a failure. Back off from here.
    blocked_ = true;
    const double from = std::max(0.0, pushed) - back;
    plan_.retreat = {plan_.contact.x + from * dx, plan_.contact.y + from * dy, plan_.direction};
    phase_ = PushPhase::Retreat;
    best_along_ = -std::numeric_limits<double>::infinity();
    since_progress_ = 0;
  }
  fb.phase = phase_;
  fb.pushed = std::max(0.0, pushed);
  if (phase_ == PushPhase::Contact) done_length = approach_length_ + standoff + std::min(0.0, pushed);
  if (phase_ == PushPhase::Push) done_length = approach_length_ + standoff + std::clamp(pushed, 0.0, plan_.distance);
  if (phase_ == PushPhase::Retreat) {
    done_length = approach_length_ + standoff + plan_.distance + std::clamp(plan_.distance - pushed, 0.0, back);
  }
  // Never backwards: turning in place and noise make the measured share wobble.
  fb.progress = progress_ = std::max(progress_, share(done_length));
  return fb;
}

}  // namespace xpersif::core
