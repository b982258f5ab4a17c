/**
 * @file control_ticker.h
 * @brief The clock of RELOCATION's and MANIPULATION's control loops: a fixed period on simulated time, or, when
 *        XPERSim runs in lockstep, its ticks (doc/lockstep.md): the loop decides on the odometry (and, when it
 *        steers by the overhead camera, the observation) stamped with the tick, and its command goes to the
 *        simulator with its report, so the same inputs give the same trajectory whatever the machine's load.
 */
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "xpersif/component/lockstep_client.h"
#include "xpersif/core/motion/motion.h"
#include "xpersif/embodiment/robot_pose_source.h"

namespace xpersif {

class ControlTicker {
 public:
  /**
   * @param lockstep the component's lockstep client (an actor), or nullptr
   * @param observation_participant the lockstep name of the camera component whose output this loop uses
   * @param fix_period lockstep, with @p uses_observation: seconds of simulated time between the frames this loop
   *        asks the camera for (its fixes; 0: it asks for none and takes the frames the camera's schedule has)
   * @param publish sends a velocity on the robot's cmd_vel (not in lockstep: the command goes with the report)
   */
  ControlTicker(LockstepClient* lockstep, const RobotPoseSource& source, double period, bool uses_observation,
                std::string observation_participant, std::function<void(const core::Velocity2D&)> publish,
                double fix_period = 0);
  ~ControlTicker();

  /// Begin: join the lockstep clock if there is one. "" or why not.
  std::string start();
  /// Wait for the current instant's sensor data (lockstep). "" or why they did not come.
  std::string sense();
  /// Lockstep: the camera published a frame at this tick (free-running clocks: always false).
  bool freshObservation() const;
  /// Lockstep: ask the camera for a frame at the first instant at or after @p stamp (the next one when it has
  /// passed), whatever the fix period.
  void requestObservation(const ros::Time& stamp = ros::Time()) { observation_at_ = stamp.toSec(); }
  bool lockstep() const { return lockstep_ != nullptr; }
  /// Seconds of simulated time since the previous instant (the period at the first).
  double dt() const { return dt_; }
  ros::Time now() const;
  /// Command @p velocity until the next instant and wait for it; false when @p stop says so or the clock
  /// stopped. Then call sense() again.
  bool next(const core::Velocity2D& velocity, const std::function<bool()>& stop);
  /// Stop the robot and leave the clock (also done by the destructor).
  void finish();

 private:
  LockstepClient* lockstep_;
  const RobotPoseSource& source_;
  double period_, dt_;
  bool uses_observation_;
  std::string observation_participant_;
  std::function<void(const core::Velocity2D&)> publish_;
  double fix_period_;
  double next_fix_ = 0;               // simulated s at which the next fix is asked for
  double observation_at_ = -1;        // simulated s of a frame asked for by the command (-1: none)
  std::optional<LockstepClient::Tick> tick_;
  ros::Time last_;
  bool finished_ = false;
};

}  // namespace xpersif
