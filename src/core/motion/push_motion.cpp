// The push planner and the push controller (push_motion.h).
#include "xpersif/core/motion/push_motion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "xpersif/core/common/experiment.h"
#include "xpersif/core/common/validation.h"
#include "motion_internal.h"

namespace xpersif::core {

using namespace motion_detail;

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

namespace {

// The straight line the robot's centre follows through a push: at(0) is the contact pose, s the distance
// along the push direction (negative before the contact).
struct PushLine {
  double cx, cy;     // the robot's centre at contact
  double dx, dy;     // the push direction, a unit vector
  double direction;  // its angle
  Pose2D at(double s) const { return Pose2D{cx + s * dx, cy + s * dy, direction}; }
};

// "" when the request and the setting are valid (the push may still be impossible there), else why not.
std::string checkPushRequest(const Obstacle& object, const PushRequest& request, const std::string& name,
                             double robot_radius, const ArenaGeometry& arena, const PushOptions& options) {
  if (std::string p = options.check(); !p.empty()) return p;
  if (std::string p = arena.check(); !p.empty()) return p;
  if (std::string p = checkPositive("robot_radius", robot_radius); !p.empty()) return p;
  if (std::string p = checkPose(name, Pose2D{object.x, object.y, object.yaw}); !p.empty()) return p;
  if (std::string p = object.footprint.check(name + ".footprint"); !p.empty()) return p;
  if (std::string p = checkPushSide(request.side); !p.empty()) return p;
  if (std::string p = checkPositive("distance", request.distance); !p.empty()) return p;
  if (request.distance > options.max_distance) {
    return "distance is " + num(request.distance) + " m; a push may be at most " + num(options.max_distance) +
           " m long";
  }
  const Footprint& shape = object.footprint;
  const double max_offset = maxPushOffset(shape, request.side);
  if (std::string p = checkInRange("offset", request.offset, -max_offset, max_offset); !p.empty()) {
    return p + " (" + name + " is " + shape.describe() +
           (shape.isDisc() ? ": the contact must stay within half its radius of the push line, on its front)"
                           : ": the contact must stay on the face)");
  }
  return "";
}

PushLine pushLine(const Obstacle& object, const PushRequest& request, double robot_radius) {
  // Push direction: the inward normal of the pushed face, in the world frame.
  double local = 0;
  if (request.side == "+x") local = kPi;
  if (request.side == "-y") local = kPi / 2.0;
  if (request.side == "+y") local = -kPi / 2.0;
  PushLine line;
  line.direction = normalizeAngle(object.yaw + local);
  line.dx = std::cos(line.direction);
  line.dy = std::sin(line.direction);
  const double lx = -line.dy, ly = line.dx;  // left of the push direction
  // Robot centre at contact, relative to the object's centre: `back` behind it along the push, `lateral` to
  // the left. A flat face is touched at the point straight ahead of the robot's centre. Two touching discs
  // touch on their centre line, at the object's radius R from its centre out of R + robot_radius: for the
  // contact to lie `offset` off the push line, the robot's centre lies offset * (R + robot_radius) / R off it.
  const Footprint& shape = object.footprint;
  double back = shape.depth(request.side) + robot_radius, lateral = request.offset;
  if (shape.isDisc()) {
    const double reach = shape.radius + robot_radius;
    lateral = request.offset * reach / shape.radius;
    back = std::sqrt(reach * reach - lateral * lateral);
  }
  line.cx = object.x - back * line.dx + lateral * lx;
  line.cy = object.y - back * line.dy + lateral * ly;
  return line;
}

// "" when neither the robot (from the approach on) nor the object (from the contact on) hits one of @p rest
// along the push line, else which and how. The object's footprint is taken as its circumscribed disc:
// conservative, since the object may turn while pushed.
std::string checkSweptPath(const PushPlan& plan, const PushLine& line, const Obstacle& object,
                           const std::vector<Obstacle>& rest, double robot_radius, const PushOptions& options,
                           const std::string& what) {
  const double object_radius = object.footprint.circumradius();
  const int samples = static_cast<int>(std::ceil((plan.distance + options.standoff) / 0.002));
  for (int s = 0; s <= samples; ++s) {
    const double t = -options.standoff + (plan.distance + options.standoff) * s / samples;
    const Pose2D r = line.at(t);
    for (const auto& o : rest) {
      if (distanceToObstacle(o, r.x, r.y) < robot_radius + 0.002) {
        return "the robot would hit " + o.name + " while pushing " + what;
      }
      if (t >= 0) {
        const double ox = object.x + t * line.dx, oy = object.y + t * line.dy;
        if (distanceToObstacle(o, ox, oy) < object_radius + options.object_clearance) {
          return "pushing " + plan.object + " " + num(plan.distance) + " m from " + what + " would push it into " +
                 o.name;
        }
      }
    }
  }
  return "";
}

// "" when the push fits in the arena beside the other obstacles, else why not.
std::string checkPushRoom(const PushPlan& plan, const PushLine& line, const Obstacle& object, double robot_radius,
                          const ArenaGeometry& arena, const std::vector<Obstacle>& others, const PushOptions& options) {
  const Footprint& shape = object.footprint;
  const std::string what = "the " + plan.side + (shape.isDisc() ? " side" : " face") + " of " + plan.object;
  PathPlanner space(arena, robot_radius, options.margin);
  std::vector<Obstacle> rest;
  for (const auto& o : others) {
    if (o.name != object.name) rest.push_back(o);
  }
  space.setObstacles(rest);
  if (std::string p = space.checkFree(plan.approach.x, plan.approach.y); !p.empty()) {
    return "the approach spot before " + what + " cannot be used: " + p;
  }
  // The object must stay clear of the walls (its footprint's extent along x and y) ...
  double ex = 0, ey = 0;
  worldHalfExtents(shape, object.yaw, ex, ey);
  const double room_x = arena.size_x / 2.0 - ex - options.object_clearance;
  const double room_y = arena.size_y / 2.0 - ey - options.object_clearance;
  if (std::fabs(plan.object_end.x) > room_x || std::fabs(plan.object_end.y) > room_y) {
    return "pushing " + plan.object + " " + num(plan.distance) + " m from " + what +
           " would push it into the wall (it would end at " + point(plan.object_end.x, plan.object_end.y) +
           ", beyond the " + num(options.object_clearance) + " m kept from the walls)";
  }
  // ... and the robot must not reach a wall either.
  if (std::string p = checkTargetInArena(arena, plan.push_end.x, plan.push_end.y, robot_radius, 0.0); !p.empty()) {
    return "the robot would hit the wall while pushing " + plan.object + ": " + p;
  }
  return checkSweptPath(plan, line, object, rest, robot_radius, options, what);
}

}  // namespace

PushPlan planPush(const Obstacle& object, const PushRequest& request, double robot_radius,
                  const ArenaGeometry& arena, const std::vector<Obstacle>& others, const PushOptions& options) {
  PushPlan plan;
  plan.object = request.object.empty() ? object.name : request.object;
  plan.side = request.side;
  plan.offset = request.offset;
  plan.distance = request.distance;
  plan.reason = checkPushRequest(object, request, plan.object, robot_radius, arena, options);
  if (!plan.reason.empty()) return plan;

  const PushLine line = pushLine(object, request, robot_radius);
  plan.direction = line.direction;
  plan.contact = line.at(0);
  plan.approach = line.at(-options.standoff);
  plan.push_end = line.at(request.distance);
  plan.retreat = line.at(request.distance - options.retreat);
  plan.object_end =
      Pose2D{object.x + request.distance * line.dx, object.y + request.distance * line.dy, object.yaw};
  plan.reason = checkPushRoom(plan, line, object, robot_radius, arena, others, options);
  plan.ok = plan.reason.empty();
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

double pastContact(const PushPlan& plan, const Pose2D& pose) {
  return (pose.x - plan.contact.x) * std::cos(plan.direction) + (pose.y - plan.contact.y) * std::sin(plan.direction);
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

PushFeedback PushController::idleFeedback() const {
  PushFeedback fb;
  fb.phase = phase_;
  fb.done = phase_ == PushPhase::Done;
  fb.failed = phase_ == PushPhase::Failed;
  fb.reason = reason_;
  fb.progress = phase_ == PushPhase::Done ? 1.0 : progress_;
  return fb;
}

double PushController::share(double length) const {
  return total_length_ > 0 ? std::clamp(length / total_length_, 0.0, 1.0) : 0.0;
}

PushFeedback PushController::approachFeedback(const MotionFeedback& m) {
  PushFeedback fb;
  fb.command = last_command_ = m.command;
  fb.phase = phase_;
  const double done_length = std::max(0.0, approach_length_ - m.distance_remaining);
  fb.progress = progress_ = std::max(progress_, share(done_length));
  return fb;
}

PushFeedback PushController::followLine(const Pose2D& current, double dt, double pushed, double& along) {
  PushFeedback fb;
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
    }
  }
  return fb;
}

bool PushController::stalled(double along, double dt) {
  // Progress along the line must go on (1 mm per stall_time).
  if (along > best_along_ + 0.001) {
    best_along_ = along;
    since_progress_ = 0;
  } else {
    since_progress_ += dt;
  }
  return options_.stall_time > 0 && since_progress_ > options_.stall_time;
}

void PushController::backOff(double pushed, double back) {
  blocked_ = true;
  const double dx = std::cos(plan_.direction), dy = std::sin(plan_.direction);
  const double from = std::max(0.0, pushed) - back;
  plan_.retreat = {plan_.contact.x + from * dx, plan_.contact.y + from * dy, plan_.direction};
  phase_ = PushPhase::Retreat;
  best_along_ = -std::numeric_limits<double>::infinity();
  since_progress_ = 0;
}

double PushController::doneLength(double pushed, double standoff, double back) const {
  if (phase_ == PushPhase::Contact) return approach_length_ + standoff + std::min(0.0, pushed);
  if (phase_ == PushPhase::Push) return approach_length_ + standoff + std::clamp(pushed, 0.0, plan_.distance);
  if (phase_ == PushPhase::Retreat) {
    return approach_length_ + standoff + plan_.distance + std::clamp(plan_.distance - pushed, 0.0, back);
  }
  return 0;
}

PushFeedback PushController::update(const Pose2D& current, double dt) {
  requireUpdateInput(current, dt);
  if (!active()) return idleFeedback();
  elapsed_ += dt;
  if (options_.timeout > 0 && elapsed_ > options_.timeout) {
    return fail("not finished within the timeout of " + num(options_.timeout) + " s");
  }
  const double standoff =
      std::hypot(plan_.contact.x - plan_.approach.x, plan_.contact.y - plan_.approach.y);
  const double back = std::hypot(plan_.push_end.x - plan_.retreat.x, plan_.push_end.y - plan_.retreat.y);
  const double pushed = pastContact(plan_, current);

  if (phase_ == PushPhase::Approach) {
    MotionFeedback m = follower_.update(current, dt);
    if (approach_length_ < 0) {
      approach_length_ = m.distance_remaining;
      total_length_ = approach_length_ + standoff + plan_.distance + back;
    }
    if (m.failed) return fail(m.reason);
    if (!m.done) return approachFeedback(m);
    phase_ = PushPhase::Contact;
    best_along_ = -std::numeric_limits<double>::infinity();
    since_progress_ = 0;
  }
  double along = 0;
  PushFeedback fb = followLine(current, dt, pushed, along);
  if (fb.done) return fb;
  if (stalled(along, dt)) {
    if (phase_ != PushPhase::Push) {
      return fail("no progress along the push line for " + num(options_.stall_time) +
                  " s: something blocks the robot, or its wheels slip");
    }
    // The object resists (too heavy, or held): that is an outcome, not a failure. Back off from here.
    backOff(pushed, back);
  }
  fb.phase = phase_;
  fb.pushed = std::max(0.0, pushed);
  // Never backwards: turning in place and noise make the measured share wobble.
  fb.progress = progress_ = std::max(progress_, share(doneLength(pushed, standoff, back)));
  return fb;
}

}  // namespace xpersif::core
