/**
 * @file frame_schedule.h
 * @brief When a camera component (OBSERVATION, PERCEPTION) renders a frame: at `~rate` Hz of ROS time on a
 *        timer, or, when XPERSim runs in lockstep (doc/lockstep.md), as a sensor of its clock at the ticks where a
 *        frame is due, from the tick's own /tf frame, reporting each tick done.
 *
 * In lockstep a camera renders on request (`~lockstep_frames: on_request`, the default): at the ticks an actor
 * asked it for a frame (a controller's fix, LockstepDone.wants_frames), at every idle tick (the standing world,
 * for whoever waits for a new frame: LOOPMODEL, EXECUTION's observations), and at the first tick of a new epoch;
 * a moving world costs no frame nobody asked for. `periodic` renders besides at `~rate` Hz of the physics' own
 * time, so idle ticks never shift when the moving world is seen. The clock waits for a camera only at its frames
 * (the same rule, core::LockstepCoordinator::startTick). A restored world state (a new epoch) starts the schedule
 * again, as a fresh sensor's.
 */
#pragma once

#include <ros/ros.h>

#include <cstdint>
#include <functional>
#include <memory>

#include "xpersif/component/lockstep_client.h"
#include "xpersif/core/common/parameters.h"
#include "xpersif/perception/camera_part.h"

namespace xpersif {

class FrameSchedule {
 public:
  /// Render, extract and publish one frame; true when it published. Its argument is the lockstep tick's stamp
  /// (zero on the timer).
  using Render = std::function<bool(const ros::Time& lockstep_stamp)>;

  /// ~lockstep_frames: on_request or periodic (declared by the camera components).
  static core::ParameterSpec modeParameter();

  /// @param camera the part whose camera must have the tick's /tf frame before a lockstep frame is rendered
  FrameSchedule(const CameraPart& camera, Render render) : camera_(camera), render_(std::move(render)) {}

  /// On activate: join XPERSim's lockstep clock as a sensor named after @p private_nh's namespace, or, when it
  /// does not run in lockstep, start a timer at @p rate Hz of ROS time that renders at most @p max_wall_rate
  /// frames per wall second (a fast clock would otherwise render more than a person can watch; in lockstep every
  /// due frame is rendered). @throws std::runtime_error when the simulator refuses the join
  /// With @p periodic (lockstep_frames periodic), lockstep frames are also due at @p rate Hz of physics time.
  void start(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh, double rate, double max_wall_rate,
             bool periodic);
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
  bool periodic_ = false;    // lockstep: frames at rate_ besides those asked for
  double next_due_ = 0;      // lockstep: physics time at which the next frame is due (infinity: on request only)
  std::uint64_t epoch_ = 0;  // lockstep: the world state's epoch the schedule belongs to
  ros::Timer timer_;
  std::unique_ptr<LockstepClient> lockstep_;
};

}  // namespace xpersif
