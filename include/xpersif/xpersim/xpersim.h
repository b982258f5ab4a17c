/**
 * @file xpersim.h
 * @brief XPERSim, the simulator, as a component: an ODE world (core::PhysicsWorld) stepped at a fixed
 *        rate in its own thread, published as tf so that every client renders the scene itself.
 *
 * Parameters: XPerSim::parameters() (read on configure; doc/parameters.md).
 *
 * Publishes: /clock, /tf (dynamic nodes, one TFMessage per frame), /tf_static (latched), `~scene`
 * (latched), `~markers` (latched, frame-locked, arena and objects), `~ground_truth`, and the robot's
 * driver topics `odom`, `ir`, `joint_states`; sets `robot_description`. Subscribes `cmd_vel` and
 * `wheel_speeds`. Operations: `~pause`, `~resume`, `~step`, `~reset`, `~set_pose`, `~get_scene`,
 * `~checkpoint`, `~restore`.
 *
 * Lockstep mode (doc/lockstep.md): simulated time advances one control tick (`~tick_period`, s of simulated
 * time, default 0.02) at a time, and only when every participant (joined through `~lockstep`) has reported the
 * tick on `~lockstep_done` and one of them wants time to go on. Each tick publishes /clock, /tf and the robot's
 * sensors once, then `~tick` (SENSE), then `~tick` (ACT) once every sensor has reported; the robot's command is
 * the one a driving actor reported. A participant silent for `~participant_timeout` wall seconds (default 10)
 * is dropped with a sentence on `~events` and in `~status`. `~step` asks for ticks there (and waits for them).
 * When nobody wants time for `~idle_period` wall seconds (default 0.05), an idle tick advances the clock but
 * not the physics: ROS timers (actionlib's status among them) keep running while the world stands still.
 */
#pragma once

#include <geometry_msgs/Twist.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "xpersif/GetScene.h"
#include "xpersif/InjectFault.h"
#include "xpersif/Lockstep.h"
#include "xpersif/LockstepDone.h"
#include "xpersif/SetPose.h"
#include "xpersif/Step.h"
#include "xpersif/WheelSpeeds.h"
#include "xpersif/WorldState.h"
#include "xpersif/component/component.h"
#include "xpersif/core/common/lockstep.h"
#include "xpersif/core/sim/physics_world.h"

namespace xpersif {

class XPerSim : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  XPerSim(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~XPerSim() override;

  enum class ClockMode { RealTime, Fast, Lockstep };

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;
  void fillStatus(ComponentStatus& status) override;

 private:
  struct Settings;
  /// Bind each operation's contract, validation and handler (below), in the order get_contracts lists them.
  void declareOperations();

  // Contracts whose preconditions look at the world.
  ContractChecker<Lockstep::Request> lockstepContract();
  /// checkpoint and restore both change the world's state (a checkpoint restores its own), so both wait for a
  /// world that stands: @p contract with precondition standing(sim), checked on arrival and again under the lock.
  ContractChecker<WorldState::Request> standingContract(core::Contract contract);
  ContractChecker<SetPose::Request> setPoseContract();
  /// "" when no command moves the world, else why (world_mutex_ held).
  std::string whyWorldMovesLocked() const;
  /// Throws core::UnavailableError while a command moves the world (world_mutex_ held).
  void requireStandingWorldLocked() const;
  /// set_pose: a known body, a finite pose inside the arena and above the floor.
  void validateSetPose(const SetPose::Request& request);
  /// inject_fault: a known body.
  void validateInjectFault(const InjectFault::Request& request);

  // The operations' handlers, called once the contract's checks passed (Component::addOperation).
  /// pause: stop advancing simulated time.
  void pause(const std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  /// resume: advance simulated time again (a halted world is tried again).
  void resume(const std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  /// step: in lockstep with participants, whole ticks through them (waits for them); else pause and step the physics.
  void step(const Step::Request& request, Step::Response& response);
  /// lockstep: a participant joins or leaves the clock; answers where the clock stands.
  void joinOrLeaveLockstep(const Lockstep::Request& request, Lockstep::Response& response);
  /// reset: the world back to its initial state, at t=0, with a new lineage.
  void reset(const std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  /// checkpoint: the world's whole state, from which it goes on as a restored world would.
  void checkpoint(const WorldState::Request& request, WorldState::Response& response);
  /// restore: the world back in a state checkpoint gave; the clock never runs backwards.
  void restore(const WorldState::Request& request, WorldState::Response& response);
  /// set_pose: place a body (a halted world runs again) and show it at once.
  void setPose(const SetPose::Request& request, SetPose::Response& response);
  /// get_scene: the scene description clients render from (also when not ACTIVE).
  void getScene(const GetScene::Request& request, GetScene::Response& response);
  /// inject_fault (test hook): a non-finite or huge force on a body.
  void injectFault(const InjectFault::Request& request, InjectFault::Response& response);

  // Configure's steps.
  Settings readSettings();
  /// Clock mode, rates and the lockstep coordinator from @p settings (world_mutex_ held, world_ the new world).
  void applySettingsLocked(const Settings& settings);
  /// ~trace_file: open it (appending) or close the old one; throws when it cannot be written.
  void openTraceLocked(const Settings& settings);
  /// Advertise the topics and subscribe to the robot's commands (once).
  void connect();
  void onCmdVel(const geometry_msgs::Twist::ConstPtr& twist);
  void onWheelSpeeds(const WheelSpeeds::ConstPtr& speeds);
  /// A halted world runs again (the user moved or reset it), and whoever waits for it is woken.
  void unhaltLocked();

  void stopThread();
  void loop();
  /// One physics step and whatever is due to be published. Call with world_mutex_ held.
  void stepLocked();
  void publishFrameLocked();
  void publishSensorsLocked();
  void publishDescriptionLocked();
  /// Physics steps only (no publishing); false when the physics halted (a blow-up that putting bodies at rest did
  /// not resolve: the simulator is paused, with the reason on ~status and ~events); a resolved blow-up is true.
  bool physicsStepLocked();
  /// Simulated time: the physics' own, plus the idle ticks' (lockstep). Call with world_mutex_ held.
  double simTimeLocked() const { return world_->time() + idle_time_; }
  /// Lockstep mode: the coordinator's loop (world_mutex_ held while it works, released while it waits).
  void lockstepLoop();
  /// Drop the participants that owe a report for longer than the timeout, each with a sentence (@p now: wall s).
  void dropLateLocked(double now);
  /// Every participant is done with the ACT phase: apply the driving actor's command, advance the physics by one
  /// tick (an idle tick: the clock only), publish the frame and the sensors, and start the next tick's SENSE phase.
  void advanceTickLocked(double now);
  void publishTickLocked(std::uint8_t phase, const std::vector<std::string>& fresh);
  /// Debug aid (~trace_file): one line per event that changes the world, and every body's pose after each
  /// stepped tick, at full precision, so two takes of a campaign can be diffed to their first difference.
  void traceLocked(const std::string& event);
  void onLockstepDone(const LockstepDone::ConstPtr& done);
  /// After a checkpoint or restore: a new epoch (sensors start their schedules again), the world unhalted and shown.
  void restoredLocked(const std::string& what);

  // World and its settings; guarded by world_mutex_.
  std::mutex world_mutex_;
  std::unique_ptr<core::PhysicsWorld> world_;
  ClockMode mode_ = ClockMode::RealTime;
  double real_time_factor_ = 1.0;
  double tf_period_ = 0.001, sensor_period_ = 0.02;
  double next_frame_ = 0, next_sensors_ = 0;
  double min_frame_wall_interval_ = 0.001;  // fast mode only
  double last_frame_wall_ = 0;
  bool allow_fault_injection_ = false;
  std::string last_problem_;
  double last_problem_wall_ = -1e9;
  std::uint64_t blow_ups_ = 0;
  std::string halted_;  ///< why the physics halted (a blow-up that putting bodies at rest did not resolve), or ""
  // Lockstep mode; guarded by world_mutex_. lockstep_wake_ wakes the coordinator and the step operation.
  std::unique_ptr<core::LockstepCoordinator> lockstep_;
  std::uint64_t lockstep_clock_ = 0;  // the coordinator's id: later coordinators (a restart, a reconfigure) have larger ones
  std::unique_ptr<std::ofstream> trace_;
  double tick_period_ = 0.02;
  int steps_per_tick_ = 10;
  std::uint64_t ticks_done_ = 0, idle_ticks_ = 0;
  std::uint64_t epoch_ = 0;  // checkpoints and restores so far (LockstepTick.epoch)
  std::string lineage_;      // WorldState.lineage: new with every world built from the file
  void newLineageLocked();
  double idle_time_ = 0;          // simulated time spent in idle ticks (the world did not move)
  double idle_period_ = 0.02;     // wall s without demand before an idle tick
  double last_tick_wall_ = 0;
  double last_announce_wall_ = 0;  // wall time the clock last announced itself to nobody (a restarted simulator)
  bool last_tick_idle_ = false;
  // Wall time per part of a stepped tick (~status): when each phase began, and whether the SENSE phase owed a sensor.
  core::LockstepTiming timing_;
  std::chrono::steady_clock::time_point sense_began_, act_began_;
  bool sense_owed_ = false;
  std::condition_variable lockstep_wake_;

  std::atomic<bool> running_{false};
  std::atomic<bool> paused_{false};
  std::atomic<bool> restart_pacing_{true};
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  std::thread thread_;

  // Reports are heard on a thread of their own, never behind the manager's other callbacks (a participant in the
  // same manager reports without waiting for a worker); its queue outlives the subscriber.
  ros::CallbackQueue report_queue_;
  std::unique_ptr<ros::AsyncSpinner> report_spinner_;

  // ROS handles last (destroyed first).
  ros::Time last_tf_stamp_;  // frames between ticks get strictly later stamps (publishFrameLocked)
  ros::Publisher clock_pub_, tf_pub_, tf_static_pub_, scene_pub_, markers_pub_, ground_truth_pub_, odom_pub_,
      ir_pub_, joints_pub_, tick_pub_;
  ros::Subscriber cmd_vel_sub_, wheel_speeds_sub_, lockstep_done_sub_;
};

}  // namespace xpersif
