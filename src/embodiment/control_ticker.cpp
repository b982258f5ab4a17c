#include "xpersif/embodiment/control_ticker.h"

#include <algorithm>
#include <thread>

namespace xpersif {

ControlTicker::ControlTicker(LockstepClient* lockstep, const RobotPoseSource& source, double period,
                             bool uses_observation, std::string observation_participant,
                             std::function<void(const core::Velocity2D&)> publish, double fix_period)
    : lockstep_(lockstep && lockstep->enabled() ? lockstep : nullptr),
      source_(source),
      period_(period),
      dt_(period),
      uses_observation_(uses_observation),
      observation_participant_(std::move(observation_participant)),
      publish_(std::move(publish)),
      fix_period_(fix_period) {}

ControlTicker::~ControlTicker() { finish(); }

std::string ControlTicker::start() {
  last_ = ros::Time::now();
  if (!lockstep_) return "";
  try {
    // The first command is for the ACT phase of the tick join() names: its sensing saw the world as it is
    // now, whichever phase the join landed in and however long the clock stood idle before.
    tick_ = lockstep_->join();
    auto act = lockstep_->reportAndWait(*tick_, {}, {});
    if (!act) return "left the lockstep clock before its first tick";
    tick_ = act;
    last_ = tick_->stamp;
    // The first tick's sensing is fresh when its tick was idle (core/lockstep.h); else ask at once.
    next_fix_ = tick_->stamp.toSec() + (freshObservation() ? fix_period_ : 0.0);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

ros::Time ControlTicker::now() const { return tick_ ? tick_->stamp : ros::Time::now(); }

std::string ControlTicker::sense() {
  if (!tick_) return "";
  // The overhead camera renders only at some ticks: wait for its output when this tick has it.
  const bool fresh_observation =
      uses_observation_ && std::find(tick_->fresh.begin(), tick_->fresh.end(), observation_participant_) != tick_->fresh.end();
  if (!source_.waitFor(tick_->stamp, fresh_observation, 10.0)) {
    return "the robot's sensor data of tick " + std::to_string(tick_->tick) + " did not arrive within 10 s";
  }
  return "";
}

bool ControlTicker::freshObservation() const {
  return tick_ && std::find(tick_->fresh.begin(), tick_->fresh.end(), observation_participant_) != tick_->fresh.end();
}

bool ControlTicker::next(const core::Velocity2D& velocity, const std::function<bool()>& stop) {
  if (!lockstep_) {
    publish_(velocity);
    const ros::Time end = last_ + ros::Duration(period_);
    while (ros::Time::now() < end) {
      if (stop()) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const ros::Time now = ros::Time::now();
    dt_ = std::max(1e-4, (now - last_).toSec());
    last_ = now;
    return !stop();
  }
  LockstepClient::Command command{true, velocity.linear, velocity.angular, {}};
  // A frame when a fix is due at the next tick (the camera renders only on request), or the command asked for one.
  const double next_stamp = tick_->stamp.toSec() + period_;
  const bool fix_due = fix_period_ > 0 && next_stamp + 1e-9 >= next_fix_;
  const bool asked = observation_at_ >= 0 && next_stamp + 1e-9 >= observation_at_;
  if (uses_observation_ && (fix_due || asked)) {
    command.wants_frames.push_back(observation_participant_);
    if (fix_period_ > 0) next_fix_ = next_stamp + fix_period_;
    observation_at_ = -1;
  }
  auto next = lockstep_->reportAndWait(*tick_, command, stop);
  if (!next) return false;
  dt_ = std::max(1e-4, (next->stamp - tick_->stamp).toSec());
  tick_ = next;
  return true;
}

void ControlTicker::finish() {
  if (finished_) return;
  finished_ = true;
  publish_({});
  if (lockstep_ && tick_) {
    lockstep_->report(*tick_, false, false, {true, 0.0, 0.0, {}});  // stopped from the next tick on
    lockstep_->leave();
  }
}

}  // namespace xpersif
