/**
 * @file frame_schedule.h
 * @brief When a camera component (OBSERVATION, PERCEPTION) renders a frame: at `~rate` Hz of ROS time on a
 *        timer, or, when XPERSim runs in lockstep (doc/lockstep.md), as a sensor of its clock at the ticks where a
 *        frame is due, from the tick's own /tf frame, reporting each tick done.
 *
 * Lockstep frames are due on the physics' own time, so idle ticks never shift when the moving world is seen; an
 * idle tick shows the standing world again (to whoever waits for a new frame). The clock waits for a camera only
 * at its frames (the same rule, core::LockstepCoordinator::startTick). A restored world state (a new epoch)
 * starts the schedule again, as a fresh sensor's.
 */
#pragma once

#include <ros/ros.h>

#include <cstdint>
#include <functional>
#include <memory>

#include "xpersif/component/lockstep_client.h"
#include "xpersif/perception/camera_part.h"

namespace xpersif {

class FrameSchedule {
 public:
  /// Render, extract and publish one frame; true when it published. Its argument is the lockstep tick's stamp
  /// (zero on the timer).
  using Render = std::function<bool(const ros::Time& lockstep_stamp)>;

  /// @param camera the part whose camera must have the tick's /tf frame before a lockstep frame is rendered
  FrameSchedule(const CameraPart& camera, Render render) : camera_(camera), render_(std::move(render)) {}

  /// On activate: join XPERSim's lockstep clock as a sensor named after @p private_nh's namespace, or, when it
  /// does not run in lockstep, start a timer at @p rate Hz of ROS time that renders at most @p max_wall_rate
  /// frames per wall second (a fast clock would otherwise render more than a person can watch; in lockstep every
  /// due frame is rendered). @throws std::runtime_error when the simulator refuses the join
  void start(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh, double rate, double max_wall_rate);
  /// On deactivate: stop the timer and leave the clock.
  void stop();

 private:
  /// A timer's frame, unless the last one is less than 1/max_wall_rate wall seconds old.
  void onTimer();
  /// A SENSE tick (the client's tick thread): render if a frame is due, then report the tick.
  void onTick(LockstepClient& client, const LockstepClient::Tick& tick);

  const CameraPart& camera_;
  Render render_;
  double rate_ = 10.0;
  double max_wall_rate_ = 30.0;
  ros::WallTime last_wall_;  // timer: when the last frame was published
  double next_due_ = 0;      // lockstep: physics time at which the next frame is due
  std::uint64_t epoch_ = 0;  // lockstep: the world state's epoch the schedule belongs to
  ros::Timer timer_;
  std::unique_ptr<LockstepClient> lockstep_;
};

}  // namespace xpersif
