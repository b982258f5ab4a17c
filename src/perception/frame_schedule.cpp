#include "xpersif/perception/frame_schedule.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace xpersif {

namespace {
constexpr double kTfPatience = 5.0;  // s of wall time; a dead simulator costs the camera this much once
// Before the first tf, the subscription may not be connected yet: the frame is skipped as before, soon (the next
// idle tick renders), rather than holding the clock at start-up.
constexpr double kFirstTfPatience = 2.0;
}  // namespace

core::ParameterSpec FrameSchedule::modeParameter() {
  return core::textParameter("lockstep_frames", "on_request",
                             "lockstep: on_request renders when an actor asks (a controller's fix) and whenever the "
                             "world stands; periodic renders besides at ~rate Hz of physics time (doc/lockstep.md)",
                             {"on_request", "periodic"});
}

void FrameSchedule::start(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh, double rate,
                          double max_wall_rate, bool periodic) {
  rate_ = rate;
  periodic_ = periodic;
  max_wall_rate_ = max_wall_rate;
  lockstep_ = std::make_unique<LockstepClient>(nh, private_nh, private_nh.getNamespace(), true);
  if (!lockstep_->enabled()) {
    timer_ = private_nh.createTimer(ros::Duration(1.0 / rate_), [this](const ros::TimerEvent&) { onTimer(); });
    return;
  }
  next_due_ = 0;
  lockstep_->onTick([this](LockstepClient& client, const LockstepClient::Tick& t) { onTick(client, t); });
  lockstep_->join();
}

void FrameSchedule::stop() {
  timer_.stop();
  lockstep_.reset();  // leaves the clock
}

void FrameSchedule::onTimer() {
  const ros::WallTime now = ros::WallTime::now();
  if ((now - last_wall_).toSec() < 1.0 / max_wall_rate_) return;
  if (render_(ros::Time())) last_wall_ = now;
}

void FrameSchedule::onTick(LockstepClient& client, const LockstepClient::Tick& t) {
  if (t.epoch != epoch_) {  // the world's state was restored: start the schedule again, as a fresh sensor does
    epoch_ = t.epoch;
    next_due_ = 0;
  }
  const bool asked = std::find(t.requested.begin(), t.requested.end(), client.name()) != t.requested.end();
  if (!t.idle && !asked && t.physics_time + 1e-9 < next_due_) return;
  bool published = false;
  auto camera = camera_.camera();
  // A skipped frame makes a different experiment (doc/lockstep.md): wait long for the tick's tf, yet within the
  // clock's patience (XPerSim's ~participant_timeout, 10 s by default), and say so when it never came.
  if (camera) {
    const double patience = camera->tracker().framesReceived() > 0 ? kTfPatience : kFirstTfPatience;
    if (camera->tracker().waitForStamp(t.stamp, patience)) {
      published = render_(t.stamp);
    } else {
      ROS_WARN("%s: tick %llu: no tf of t = %.3f s within %.0f s of wall time; this tick has no frame (a different "
               "experiment from here on unless the world stands)", client.name().c_str(),
               static_cast<unsigned long long>(t.tick), t.stamp.toSec(), patience);
    }
  }
  if (!t.idle) {
    next_due_ = periodic_ ? (std::floor(t.physics_time * rate_ + 1e-6) + 1) / rate_
                          : std::numeric_limits<double>::infinity();
  }
  client.report(t, false, published, {}, next_due_);
}

}  // namespace xpersif
