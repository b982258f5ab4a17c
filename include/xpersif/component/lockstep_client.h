/**
 * @file lockstep_client.h
 * @brief A component's side of XPERSim's lockstep clock (doc/lockstep.md): join as a sensor or an actor,
 *        hear each tick, report it done. Any component can take part. When the simulator does not run in
 *        lockstep (its `clock_mode` parameter), enabled() is false and callers keep their timers.
 *
 * Actors (controllers) run a command as: join() → compute at the returned tick → reportAndWait(command) →
 * compute at the next tick → ... → finish() (a last report that wants no more time, then leave). Sensors
 * (cameras) join once and report each SENSE tick from onTick()'s callback. Waiting is on a condition variable
 * woken by the tick subscriber: nothing polls. Ticks are heard on a thread of the client's own, so a busy
 * nodelet manager (every worker in a long callback) never delays a participant's report.
 *
 * Forgotten participants: a tick of a newer clock (the simulator's manager restarted, or XPERSim was configured
 * again) or one that no longer lists this participant (dropped for answering too late) means the simulator no
 * longer waits for it. A sensor joins again at once, from its tick thread, with a warning; an actor's wait ends
 * (reportAndWait() returns nothing), so its command fails with a sentence instead of driving a robot that no
 * longer listens.
 */
#pragma once

#include "xpersif/core/common/parameters.h"

#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "xpersif/LockstepTick.h"
#include "xpersif/core/common/lockstep.h"

namespace xpersif {

class LockstepClient {
 public:
  /// ~lockstep_xpersim (also found in a parent namespace): the XPERSim whose clock to join.
  static const core::ParameterTable& parameters();

  struct Tick {
    std::uint64_t tick = 0;
    std::uint8_t phase = LockstepTick::ACT;
    ros::Time stamp;
    std::vector<std::string> fresh;  ///< ACT: sensors that published output stamped `stamp`
    std::vector<std::string> requested;  ///< SENSE: sensors an actor asked a frame of at this tick
    bool idle = false;               ///< the physics did not advance in this tick
    double physics_time = 0;         ///< seconds the physics has run (excludes idle ticks)
    std::uint64_t epoch = 0;         ///< counts restores of the world's state: frame schedules start again
  };
  using Command = core::LockstepCommand;

  /**
   * @param nh the component's node handle (the simulator's namespace `xpersim` is resolved in it, or the
   *        `lockstep_xpersim` parameter searched upwards from @p private_nh)
   * @param name the participant's unique name (the component's private namespace is a good one)
   * @param sensor true: reports in the SENSE phase; false: an actor, reports in the ACT phase
   */
  LockstepClient(ros::NodeHandle nh, const ros::NodeHandle& private_nh, std::string name, bool sensor);
  ~LockstepClient();

  /// Whether XPERSim runs in lockstep (read from its `clock_mode` parameter when this client was made).
  bool enabled() const { return enabled_; }
  /// Whether the XPERSim a component of @p nh / @p private_nh would join runs in lockstep, without joining (for a
  /// component that only needs to know, as EXECUTION does when it waits for a frame).
  static bool runsInLockstep(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);
  const std::string& name() const { return name_; }

  /// Join the clock. A sensor gets the current tick; an actor the tick whose ACT phase it first owes, marked
  /// SENSE (pass it to reportAndWait()). @throws std::runtime_error with a sentence when the simulator refuses
  Tick join(double timeout = 10.0);
  /// Leave (no-op when not joined). Never throws.
  void leave();
  bool joined() const;

  /// Actor: report @p tick done (with @p command; wanting the next tick) and wait for the next ACT tick. Empty
  /// when @p stop becomes true or no tick comes within @p timeout wall seconds (the simulator stopped).
  std::optional<Tick> reportAndWait(const Tick& tick, const Command& command, const std::function<bool()>& stop,
                                    double timeout = 30.0);
  /// Report @p tick done without waiting. @p wants_time false: this participant needs no more time.
  void report(const Tick& tick, bool wants_time, bool published, const Command& command = {}, double next_due = 0);
  /// Let @p duration of simulated time pass: in lockstep, take part as an actor that wants time until it has
  /// passed (time never passes on its own there); otherwise sleep on ROS time. False when @p stop says so.
  bool sleepFor(const ros::Duration& duration, const std::function<bool()>& stop = nullptr);
  /// Sensor: called (in the client's own tick thread) for every SENSE tick while joined; it must call report() on
  /// the client it is given. (Not through the owner's pointer to the client: a tick in flight while the owner resets
  /// that pointer found it null, and a deactivated OBSERVATION took its whole manager down: SIGSEGV.)
  void onTick(std::function<void(LockstepClient& client, const Tick& tick)> callback);

 private:
  void onTickMessage(const LockstepTick::ConstPtr& message);
  /// The join call itself; @p lock held on return. Throws as join() does.
  Tick joinLocked(double timeout, std::unique_lock<std::mutex>& lock);
  /// The resolved name of the XPERSim a component of @p nh / @p private_nh joins (~lockstep_xpersim).
  static std::string xpersimOf(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);

  ros::CallbackQueue tick_queue_;  // first: destroyed last
  ros::NodeHandle nh_;
  std::string name_, xpersim_;
  bool sensor_ = false, enabled_ = false;
  mutable std::mutex mutex_;
  std::condition_variable ticked_;
  bool joined_ = false;
  std::uint64_t clock_ = 0;         // the clock joined (LockstepTick.clock)
  std::uint64_t joined_at_ = 0;     // the tick it was joined at: older ticks may not list it yet
  bool left_ = false;               // leave() was called: a rejoin under way must not stay joined
  std::optional<Tick> latest_act_;  // the newest ACT tick heard
  std::uint64_t latest_act_clock_ = 0;  // the clock latest_act_ is of
  bool joining_ = false;  // a join call is under way: its first ACT tick may come before its answer
  // A sensor's: the newest SENSE tick heard while its join call was under way. The clock may start the tick the
  // new sensor owes before the join's answer is read (in one process it nearly always does); it is served then.
  std::optional<Tick> pending_sense_;
  std::uint64_t pending_sense_clock_ = 0;
  std::function<void(LockstepClient&, const Tick&)> on_tick_;
  ros::Publisher done_pub_;
  std::unique_ptr<ros::AsyncSpinner> tick_spinner_;  // serves tick_queue_ only
  ros::Subscriber tick_sub_;  // last: destroyed first
};

}  // namespace xpersif
