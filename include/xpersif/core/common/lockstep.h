/**
 * @file lockstep.h
 * @brief The lockstep clock's bookkeeping, ROS-free: who must finish each control tick before simulated time
 *        may advance, and when a tick is complete. XPERSim (the coordinator) owns one; the protocol around it
 *        is in doc/lockstep.md.
 *
 * A tick has two phases. SENSE: physics has advanced to the tick's time; sensing participants (cameras and
 * the perception behind them) render and publish what is due, then report. ACT: every sensor has reported;
 * acting participants (controllers) read the tick's sensor data, compute, and report with their command.
 * Only then may the next tick start, and only if some participant wants time to go on (a command is running,
 * or someone asked for simulated time): an idle loop leaves simulated time where it is, so how long the loop
 * thinks between experiments (wall time) never changes what the physics does.
 *
 * A participant joins between ticks: a sensor first reports in the next SENSE phase; an actor in the next ACT
 * phase after a SENSE phase (the current tick's, joining in SENSE; the next tick's, joining in ACT), so that its
 * first command always follows sensing of the world as it is, however long the clock stood idle before.
 *
 * A participant that does not report within the timeout (wall seconds, from the start of the phase) is dropped: the run goes on without
 * it and the caller reports that. Not thread-safe: one owner.
 */
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace xpersif::core {

/// What an actor's report carries besides "done": whether it drives the robot, and with what command.
struct LockstepCommand {
  bool drives = false;
  double linear = 0, angular = 0;  ///< m/s, rad/s
  /// Sensors it needs a frame from at the next tick, whether or not their own schedule has one due (a controller
  /// that steers by the overhead camera asks for a fix now and then; sensors render on request, not every tick).
  std::vector<std::string> wants_frames;
};

/// Where the wall time of the stepped (not idle) ticks goes: the simulator adds each phase as it ends and shows
/// describe() in its ~status, so anyone can see which side of the protocol a slow loop waits for.
struct LockstepTiming {
  enum Part { kSensing, kActing, kPhysics, kPublishing, kParts };
  double seconds[kParts] = {};   ///< wall s per part, summed over the stepped ticks
  std::uint64_t ticks = 0;       ///< stepped ticks counted (their ACT phase, physics and publishing)
  std::uint64_t sensing_waits = 0;       ///< SENSE phases that began owing a sensor (a camera frame was due)
  double sensing_wait_seconds = 0;       ///< the wall s of those phases (part of seconds[kSensing])

  void addSensing(double wall_seconds, bool owed_a_sensor);
  void addStep(double acting, double physics, double publishing);
  /// "" before the first stepped tick, else one sentence in ms per tick, e.g. "wall ms per stepped tick over 12000
  /// ticks: sensing 0.87 (a sensor waited for on 21 % of ticks, 4.05 ms each), acting 0.81, physics 0.49,
  /// publishing 0.13; 2.30 in all".
  std::string describe() const;
};

class LockstepCoordinator {
 public:
  enum class Role { Sensor, Actor };
  enum class Phase { Sense, Act };

  using Command = LockstepCommand;

  /// @param timeout wall seconds a participant has to report for a phase. @throws ValidationError if not > 0
  explicit LockstepCoordinator(double timeout);

  /// A participant joins (or re-joins with another role). It owes nothing in the current
  /// phase: a sensor first reports in the next SENSE phase, an actor in the next ACT phase that follows a SENSE
  /// phase. An actor joining in an ACT phase makes awaitsTick() true. @throws ValidationError for an empty name
  void join(const std::string& name, Role role);
  /// An actor joined in this ACT phase and waits for the next tick: start it without an idle pause (an idle
  /// tick, unless someone wants time).
  bool awaitsTick() const { return awaits_tick_; }
  /// A participant leaves; a phase waiting only for it completes. True when it was the last actor to drive the
  /// robot: the caller then stops the robot (a controller that is gone commands nothing).
  bool leave(const std::string& name);
  bool has(const std::string& name) const { return roles_.count(name) > 0; }
  std::vector<std::string> participants() const;

  /// Start tick @p tick's SENSE phase at wall time @p now. The sensors whose next frame is due by
  /// @p physics_time (all of them in an @p idle tick), and those an actor asked a frame of in the tick before,
  /// then owe a report; the others are not waited for.
  void startTick(std::uint64_t tick, double now, double physics_time = 0, bool idle = true);
  /// "" when accepted, else why not (unknown participant, another tick or phase, reported twice): the caller
  /// logs it; nothing changes. @p published (SENSE): it published output stamped with the tick's time.
  /// @p wants_time: it needs the next tick. @p command (ACT): its command until the next tick.
  std::string report(const std::string& name, std::uint64_t tick, Phase phase, bool wants_time, bool published,
                     const Command& command = {}, double next_due = 0);
  /// Every participant owed a report for the current phase has given it.
  bool phaseComplete() const { return owed_.empty(); }
  /// The sensors an actor asked a frame of at the current tick (its SENSE ticks say so: requested()).
  const std::vector<std::string>& requested() const { return requested_now_; }
  /// After a complete SENSE phase: start ACT at wall time @p now. Returns the sensors that published output.
  std::vector<std::string> startAct(double now);
  /// Participants whose report for the current phase is owed for the timeout or longer at wall time @p now
  /// (each counted from when it became owed); they are removed (left) and their names returned.
  std::vector<std::string> dropLate(double now);
  /// Names still owed for the current phase, for status and sentences.
  std::vector<std::string> owed() const;

  std::uint64_t tick() const { return tick_; }
  Phase phase() const { return phase_; }
  /// Does someone want the next tick: a report of the current tick said so, or requestTicks() is pending.
  bool wantsTime() const { return wants_time_ || requested_ > 0; }
  /// Ask for @p ticks more ticks of time whether or not a participant wants them (the step operation).
  void requestTicks(std::uint64_t ticks) { requested_ += ticks; }
  /// Called by the coordinator when it starts a tick it was asked for.
  void consumeRequest() {
    if (requested_ > 0) --requested_;
  }
  std::uint64_t requestedTicks() const { return requested_; }
  /// The world's state was restored: every sensor owes a frame at the next tick, as a sensor that just joined.
  void restartSchedules() { next_due_.clear(); }
  /// The robot's command from the current tick's ACT reports (the last driving actor's), if any drives.
  const Command& command() const { return command_; }
  double timeout() const { return timeout_; }

 private:
  void owe(Role role, double now);

  double timeout_;
  std::map<std::string, Role> roles_;
  std::map<std::string, double> next_due_;  // sensors: physics time of their next frame
  std::map<std::string, double> owed_;  // who owes a report for the current phase, since what wall time
  std::vector<std::string> published_;
  std::vector<std::string> requested_next_, requested_now_;  // frames asked for at the next / the current tick
  std::uint64_t tick_ = 0;
  Phase phase_ = Phase::Act;  // tick 0 is complete: nothing is owed until the first tick starts
  bool wants_time_ = false;
  bool awaits_tick_ = false;
  std::uint64_t requested_ = 0;
  Command command_;
  std::string driver_;  // the actor whose command the robot follows
};

}  // namespace xpersif::core
