#include "xpersif/component/lockstep_client.h"

#include <algorithm>
#include <stdexcept>
#include <thread>

#include "xpersif/Lockstep.h"
#include "xpersif/LockstepDone.h"

namespace xpersif {

LockstepClient::LockstepClient(ros::NodeHandle nh, const ros::NodeHandle& private_nh, std::string name, bool sensor)
    : nh_(std::move(nh)), name_(std::move(name)), xpersim_("xpersim"), sensor_(sensor) {
  std::string key, mode;
  if (private_nh.searchParam("lockstep_xpersim", key)) private_nh.getParam(key, xpersim_);
  xpersim_ = nh_.resolveName(xpersim_);
  enabled_ = ros::param::get(xpersim_ + "/clock_mode", mode) && mode == "lockstep";
  if (!enabled_) return;
  done_pub_ = nh_.advertise<LockstepDone>(xpersim_ + "/lockstep_done", 100);
  // Its own queue and thread: a tick waits for no other callback of the manager (a cold start once kept every
  // worker busy for 10 s, the participant was dropped and the settling scene got other physics: issue 13).
  ros::NodeHandle tick_nh(nh_);
  tick_nh.setCallbackQueue(&tick_queue_);
  tick_sub_ = tick_nh.subscribe<LockstepTick>(xpersim_ + "/tick", 100, &LockstepClient::onTickMessage, this,
                                              ros::TransportHints().tcpNoDelay());
  tick_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &tick_queue_);
  tick_spinner_->start();
}

LockstepClient::~LockstepClient() { leave(); }

bool LockstepClient::joined() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return joined_;
}

LockstepClient::Tick LockstepClient::join(double timeout) {
  if (!enabled_) throw std::runtime_error("the simulator does not run in lockstep");
  const std::string service = xpersim_ + "/lockstep";
  if (!ros::service::waitForService(service, ros::Duration(timeout))) {
    throw std::runtime_error("cannot join the lockstep clock: " + service + " did not appear within " +
                             std::to_string(timeout) + " s");
  }
  // The reports must reach the simulator: wait for the connection before the first one.
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(timeout);
  while (done_pub_.getNumSubscribers() == 0 && ros::WallTime::now() < until) ros::WallDuration(0.01).sleep();
  Lockstep call;
  call.request.participant = name_;
  call.request.role = sensor_ ? Lockstep::Request::SENSOR : Lockstep::Request::ACTOR;
  call.request.join = true;
  if (!ros::service::call(service, call) || !call.response.success) {
    throw std::runtime_error("cannot join the lockstep clock: " + call.response.message);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  joined_ = true;
  Tick now{call.response.tick, call.response.phase, call.response.stamp, {}, false, 0.0};
  if (!sensor_) {
    // An actor first acts in the ACT phase after a SENSE phase (core/lockstep.h): the current tick's when it
    // joined in SENSE, the next tick's when it joined in ACT. That tick, in SENSE: reportAndWait() waits for it.
    if (call.response.phase == LockstepTick::ACT) ++now.tick;
    now.phase = LockstepTick::SENSE;
  }
  return now;
}

void LockstepClient::leave() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!joined_) return;
    joined_ = false;
  }
  ticked_.notify_all();
  Lockstep call;
  call.request.participant = name_;
  call.request.role = sensor_ ? Lockstep::Request::SENSOR : Lockstep::Request::ACTOR;
  call.request.join = false;
  ros::service::call(xpersim_ + "/lockstep", call);  // best effort: a gone simulator has no participants
}

void LockstepClient::report(const Tick& tick, bool wants_time, bool published, const Command& command,
                            double next_due) {
  LockstepDone done;
  done.participant = name_;
  done.tick = tick.tick;
  done.phase = tick.phase;
  done.wants_time = wants_time;
  done.published = published;
  done.next_due = next_due;
  done.drives = command.drives;
  done.cmd_vel.linear.x = command.linear;
  done.cmd_vel.angular.z = command.angular;
  done_pub_.publish(done);
}

std::optional<LockstepClient::Tick> LockstepClient::reportAndWait(const Tick& tick, const Command& command,
                                                                  const std::function<bool()>& stop, double timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  // A SENSE tick (from join()) owes nothing yet: wait for its ACT phase.
  if (tick.phase == LockstepTick::ACT) {
    lock.unlock();
    report(tick, true, false, command);
    lock.lock();
  }
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(timeout);
  while (true) {
    if (latest_act_ && (latest_act_->tick > tick.tick || (tick.phase == LockstepTick::SENSE && latest_act_->tick == tick.tick))) {
      return latest_act_;
    }
    if (!joined_ || (stop && stop()) || ros::WallTime::now() > until || !ros::ok()) return std::nullopt;
    ticked_.wait_for(lock, std::chrono::milliseconds(50));  // the timeout only re-checks stop()
  }
}

bool LockstepClient::sleepFor(const ros::Duration& duration, const std::function<bool()>& stop) {
  auto stopped = [&] { return stop && stop(); };
  if (!enabled_) {
    const ros::Time end = ros::Time::now() + duration;
    while (ros::Time::now() < end && ros::ok()) {
      if (stopped()) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return !stopped();
  }
  // Counted from the first tick it acts in, not from the tick it joined in: joined in an ACT phase, that is the
  // next tick, and counting from the join's stamp stepped one tick less (a cold start's settling got other physics).
  std::optional<Tick> first = reportAndWait(join(), {}, stop);
  if (!first) {
    leave();
    return false;
  }
  Tick tick = *first;
  const ros::Time end = first->stamp + duration;
  while (tick.stamp < end) {
    auto next = reportAndWait(tick, {}, stop);
    if (!next) {
      leave();
      return false;
    }
    tick = *next;
  }
  report(tick, false, false);
  leave();
  return true;
}

void LockstepClient::onTick(std::function<void(const Tick&)> callback) {
  std::lock_guard<std::mutex> lock(mutex_);
  on_tick_ = std::move(callback);
}

void LockstepClient::onTickMessage(const LockstepTick::ConstPtr& message) {
  Tick tick{message->tick, message->phase, message->stamp, message->fresh, message->idle != 0, message->physics_time};
  std::function<void(const Tick&)> callback;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!joined_) return;
    // Dropped for answering too late: the simulator ignores its reports until it joins again.
    if (std::find(message->participants.begin(), message->participants.end(), name_) == message->participants.end()) {
      ROS_WARN_THROTTLE(5.0, "%s: dropped from the lockstep clock by tick %lu (it answered too late)", name_.c_str(),
                        static_cast<unsigned long>(message->tick));
    }
    if (message->phase == LockstepTick::ACT) latest_act_ = tick;
    if (sensor_ && message->phase == LockstepTick::SENSE) callback = on_tick_;
  }
  ticked_.notify_all();
  if (callback) callback(tick);
}

}  // namespace xpersif
