#include "xpersif/component/lockstep_client.h"

#include <algorithm>
#include <stdexcept>
#include <thread>

#include "xpersif/Lockstep.h"
#include "xpersif/LockstepDone.h"

namespace xpersif {

const core::ParameterTable& LockstepClient::parameters() {
  static const core::ParameterTable table(
      "lockstep client",
      {core::textParameter("lockstep_xpersim", "xpersim",
                           "the XPERSim whose lockstep clock this component joins (also found in a parent namespace)")});
  return table;
}

std::string LockstepClient::xpersimOf(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh) {
  std::string key, xpersim = std::get<std::string>(parameters().at("lockstep_xpersim").default_value);
  if (private_nh.searchParam("lockstep_xpersim", key)) private_nh.getParam(key, xpersim);
  return nh.resolveName(xpersim);
}

namespace {
bool clockModeIsLockstep(const std::string& xpersim) {
  std::string mode;
  return ros::param::get(xpersim + "/clock_mode", mode) && mode == "lockstep";
}
}  // namespace

bool LockstepClient::runsInLockstep(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh) {
  return clockModeIsLockstep(xpersimOf(nh, private_nh));
}

LockstepClient::LockstepClient(ros::NodeHandle nh, const ros::NodeHandle& private_nh, std::string name, bool sensor)
    : nh_(std::move(nh)), name_(std::move(name)), xpersim_(xpersimOf(nh_, private_nh)), sensor_(sensor) {
  enabled_ = clockModeIsLockstep(xpersim_);
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

LockstepClient::~LockstepClient() {
  // The tick thread first (stop() waits for a tick in flight), so that no tick is handled while leaving or after.
  if (tick_spinner_) tick_spinner_->stop();
  tick_sub_.shutdown();
  leave();
}

bool LockstepClient::joined() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return joined_;
}

LockstepClient::Tick LockstepClient::join(double timeout) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    left_ = false;
  }
  std::unique_lock<std::mutex> lock(mutex_, std::defer_lock);
  const Tick now = joinLocked(timeout, lock);
  // A SENSE tick of the joined clock that began after the join, heard before its answer: the sensor owes its report
  // (the clock waits for it, and would drop it 10 s later). Served here; the clock waits for nothing else meanwhile.
  std::optional<Tick> owed;
  if (sensor_ && pending_sense_ && pending_sense_clock_ == clock_ && pending_sense_->tick > joined_at_) owed = pending_sense_;
  pending_sense_.reset();
  auto callback = on_tick_;
  lock.unlock();
  if (owed && callback) callback(*this, *owed);
  return now;
}

LockstepClient::Tick LockstepClient::joinLocked(double timeout, std::unique_lock<std::mutex>& lock) {
  if (!enabled_) throw std::runtime_error("the simulator does not run in lockstep");
  const std::string service = xpersim_ + "/lockstep";
  if (!ros::service::waitForService(service, ros::Duration(timeout))) {
    throw std::runtime_error("cannot join the lockstep clock: " + service + " did not appear within " +
                             std::to_string(timeout) + " s");
  }
  // The reports must reach the simulator: wait for the connection before the first one.
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(timeout);
  while (done_pub_.getNumSubscribers() == 0 && ros::WallTime::now() < until) ros::WallDuration(0.01).sleep();
  // And the ticks must reach it: a tick published before its subscription is connected to the simulator (a
  // restarted one) is lost, and the participant is dropped 10 s later for a tick it never heard.
  while (tick_sub_.getNumPublishers() == 0 && ros::WallTime::now() < until) ros::WallDuration(0.01).sleep();
  Lockstep call;
  call.request.participant = name_;
  call.request.role = sensor_ ? Lockstep::Request::SENSOR : Lockstep::Request::ACTOR;
  call.request.join = true;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    joining_ = true;
    pending_sense_.reset();
  }
  const bool answered = ros::service::call(service, call) && call.response.success;
  lock.lock();
  joining_ = false;
  if (!answered) throw std::runtime_error("cannot join the lockstep clock: " + call.response.message);
  // The simulator may go on to the ACT phase the new actor owes before its answer is read here: that tick, heard
  // meanwhile on the tick thread, is kept (it was once dropped, the actor waited for a tick that had passed and
  // was dropped 10 s later: a cold start's settling skipped, in 1 take of 10-20 on a loaded machine).
  if (latest_act_clock_ != call.response.clock) latest_act_.reset();  // ticks of another clock mean nothing now
  joined_ = true;
  clock_ = call.response.clock;
  joined_at_ = call.response.tick;
  Tick now{call.response.tick, call.response.phase, call.response.stamp, {}, {}, false, 0.0};
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
    left_ = true;
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
  auto message = boost::make_shared<LockstepDone>();  // shared: a simulator in this process gets it uncopied
  LockstepDone& done = *message;
  done.participant = name_;
  done.tick = tick.tick;
  done.phase = tick.phase;
  done.wants_time = wants_time;
  done.published = published;
  done.next_due = next_due;
  done.drives = command.drives;
  done.wants_frames = command.wants_frames;
  done.cmd_vel.linear.x = command.linear;
  done.cmd_vel.angular.z = command.angular;
  done_pub_.publish(message);
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

void LockstepClient::onTick(std::function<void(LockstepClient&, const Tick&)> callback) {
  std::lock_guard<std::mutex> lock(mutex_);
  on_tick_ = std::move(callback);
}

void LockstepClient::onTickMessage(const LockstepTick::ConstPtr& message) {
  Tick tick{message->tick, message->phase, message->stamp, message->fresh, message->requested, message->idle != 0,
            message->physics_time, message->epoch};
  std::function<void(LockstepClient&, const Tick&)> callback;
  bool rejoin = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (joining_ && !joined_) {  // the join's answer decides which clock counts: keep the newest ACT tick
      if (message->phase == LockstepTick::ACT && message->clock >= latest_act_clock_) {
        latest_act_ = tick;
        latest_act_clock_ = message->clock;
      }
      const bool listed = std::find(message->participants.begin(), message->participants.end(), name_) !=
                          message->participants.end();
      if (sensor_ && message->phase == LockstepTick::SENSE && listed) {
        pending_sense_ = tick;  // join() serves it once the answer says which clock this is
        pending_sense_clock_ = message->clock;
      }
      return;
    }
    if (!joined_ || message->clock < clock_) return;  // not taking part, or a tick of a clock that is gone
    const bool listed = std::find(message->participants.begin(), message->participants.end(), name_) !=
                        message->participants.end();
    // A newer clock has forgotten everyone; a tick after the join that does not list it means it was dropped.
    const bool newer_clock = message->clock > clock_;
    if (newer_clock || (!listed && message->tick > joined_at_)) {
      ROS_WARN("%s: %s at tick %lu; %s", name_.c_str(),
               newer_clock ? "the lockstep clock was restarted (a new simulator or a new configuration)"
                           : "dropped from the lockstep clock (it answered too late)",
               static_cast<unsigned long>(message->tick), sensor_ ? "joining again" : "its command ends");
      joined_ = false;
      rejoin = sensor_;  // ticks are heard on one thread: no other tick arrives while it joins
    } else {
      if (message->phase == LockstepTick::ACT) {
        latest_act_ = tick;
        latest_act_clock_ = message->clock;
      }
      if (sensor_ && message->phase == LockstepTick::SENSE && listed) callback = on_tick_;
    }
  }
  ticked_.notify_all();
  if (rejoin) {
    // On this client's own tick thread: a join is one service call, and no tick is due from a sensor that has
    // not joined. A failure (the simulator is still coming up) is retried at the next tick heard.
    try {
      std::unique_lock<std::mutex> lock(mutex_, std::defer_lock);
      joinLocked(10.0, lock);
      const bool left = left_;
      lock.unlock();
      if (left) {
        leave();  // left while the join was under way
      } else {
        ROS_WARN("%s: joined the lockstep clock again", name_.c_str());
      }
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(mutex_);
      joined_ = !left_;  // hear the next tick, and try again from it
      ROS_WARN_THROTTLE(5.0, "%s: %s", name_.c_str(), e.what());
    }
    return;
  }
  if (callback) callback(*this, tick);
}

}  // namespace xpersif
