#include "xpersif/core/common/lockstep.h"

#include <algorithm>
#include <cstdio>
#include <iterator>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

LockstepCoordinator::LockstepCoordinator(double timeout) : timeout_(timeout) {
  requirePositive("lockstep timeout", timeout);
}

void LockstepCoordinator::join(const std::string& name, Role role) {
  if (name.empty()) throw ValidationError("a lockstep participant needs a name");
  roles_[name] = role;
  // A join owes nothing in the current phase, also when the name owed a report: a component that was restarted
  // (its manager died) joins under its old name, and must not be dropped for what the dead one owed.
  owed_.erase(name);
  next_due_.erase(name);
  // An actor's first report is for the ACT phase of the next tick to start (or of this one, joining in SENSE),
  // so its first command always follows a SENSE phase that saw the world as it is now. Had it acted on the
  // current ACT phase, it would have seen whatever the sensors last published: a frame of the standing world
  // when an idle tick happened to pass before the join, an older frame otherwise (issue 13: one take in ten).
  if (role == Role::Actor && phase_ == Phase::Act) awaits_tick_ = true;
}

bool LockstepCoordinator::leave(const std::string& name) {
  roles_.erase(name);
  next_due_.erase(name);
  owed_.erase(name);
  if (driver_ != name) return false;
  driver_.clear();
  return true;
}

std::vector<std::string> LockstepCoordinator::participants() const {
  std::vector<std::string> out;
  for (const auto& [name, role] : roles_) out.push_back(name);
  return out;
}

std::vector<std::string> LockstepCoordinator::owed() const {
  std::vector<std::string> out;
  for (const auto& [name, since] : owed_) out.push_back(name);
  return out;
}

void LockstepCoordinator::owe(Role role, double now) {
  owed_.clear();
  for (const auto& [name, r] : roles_) {
    if (r == role) owed_.emplace(name, now);
  }
}

void LockstepCoordinator::startTick(std::uint64_t tick, double now, double physics_time, bool idle) {
  tick_ = tick;
  phase_ = Phase::Sense;
  wants_time_ = false;
  awaits_tick_ = false;
  published_.clear();
  command_ = {};
  owe(Role::Sensor, now);
  requested_now_.clear();
  for (const auto& name : requested_next_) {
    if (owed_.count(name)) requested_now_.push_back(name);  // only sensors taking part can be asked
  }
  requested_next_.clear();
  if (idle) return;
  for (auto it = owed_.begin(); it != owed_.end();) {
    const auto due = next_due_.find(it->first);
    const bool asked = std::find(requested_now_.begin(), requested_now_.end(), it->first) != requested_now_.end();
    it = !asked && due != next_due_.end() && due->second > physics_time + 1e-9 ? owed_.erase(it) : std::next(it);
  }
}

std::vector<std::string> LockstepCoordinator::startAct(double now) {
  phase_ = Phase::Act;
  owe(Role::Actor, now);
  return published_;
}

std::string LockstepCoordinator::report(const std::string& name, std::uint64_t tick, Phase phase, bool wants_time,
                                        bool published, const Command& command, double next_due) {
  if (!roles_.count(name)) return "'" + name + "' reported tick " + std::to_string(tick) + " but has not joined";
  if (tick != tick_ || phase != phase_) {
    return "'" + name + "' reported tick " + std::to_string(tick) + (phase == Phase::Sense ? " (sense)" : " (act)") +
           " while tick " + std::to_string(tick_) + (phase_ == Phase::Sense ? " (sense)" : " (act)") + " runs";
  }
  // A participant may always say it wants time (a controller starting between ticks), even when not owed.
  wants_time_ = wants_time_ || wants_time;
  if (!owed_.erase(name)) return "";
  if (phase == Phase::Sense && published) published_.push_back(name);
  if (phase == Phase::Sense) next_due_[name] = next_due;
  if (phase == Phase::Act) {
    for (const auto& sensor : command.wants_frames) {
      if (std::find(requested_next_.begin(), requested_next_.end(), sensor) == requested_next_.end()) {
        requested_next_.push_back(sensor);
      }
    }
  }
  if (phase == Phase::Act && command.drives) {
    command_ = command;
    driver_ = name;
  }
  return "";
}

std::vector<std::string> LockstepCoordinator::dropLate(double now) {
  std::vector<std::string> late;
  for (const auto& [name, since] : owed_) {
    if (now - since >= timeout_) late.push_back(name);
  }
  for (const auto& name : late) {
    if (leave(name)) command_ = Command{true, 0.0, 0.0};  // a dropped controller commands nothing
  }
  return late;
}

void LockstepTiming::addSensing(double wall_seconds, bool owed_a_sensor) {
  seconds[kSensing] += wall_seconds;
  if (!owed_a_sensor) return;
  ++sensing_waits;
  sensing_wait_seconds += wall_seconds;
}

void LockstepTiming::addStep(double acting, double physics, double publishing) {
  ++ticks;
  seconds[kActing] += acting;
  seconds[kPhysics] += physics;
  seconds[kPublishing] += publishing;
}

std::string LockstepTiming::describe() const {
  if (ticks == 0) return "";
  const double n = static_cast<double>(ticks);
  auto ms = [n](double s) { return 1e3 * s / n; };
  char text[320];
  std::snprintf(text, sizeof text,
                "wall ms per stepped tick over %llu ticks: sensing %.2f (a sensor waited for on %.0f %% of ticks, %.2f ms "
                "each), acting %.2f, physics %.2f, publishing %.2f; %.2f in all",
                static_cast<unsigned long long>(ticks), ms(seconds[kSensing]), 100.0 * sensing_waits / n,
                sensing_waits ? 1e3 * sensing_wait_seconds / sensing_waits : 0.0, ms(seconds[kActing]),
                ms(seconds[kPhysics]), ms(seconds[kPublishing]),
                ms(seconds[kSensing] + seconds[kActing] + seconds[kPhysics] + seconds[kPublishing]));
  return text;
}

}  // namespace xpersif::core
