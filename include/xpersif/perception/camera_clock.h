/**
 * @file camera_clock.h
 * @brief When a camera component (OBSERVATION, PERCEPTION) renders: a timer at its rate on ROS time, or, when
 *        XPERSim runs in lockstep, the clock's ticks as a sensor (README "Lockstep"): frames are due on the
 *        physics' own time, so idle ticks never shift when the moving world is seen, and an idle tick shows the
 *        standing world again to whoever waits for a new frame.
 */
#pragma once

#include <ros/ros.h>

#include <functional>
#include <memory>

#include "xpersif/component/lockstep_client.h"
#include "xpersif/perception/camera_part.h"

namespace xpersif {

class CameraClock {
 public:
  /// Render with @p render (true when it published a frame; its argument is the lockstep tick's stamp, zero
  /// on a timer) at @p rate frames per second of simulated time. @throws std::runtime_error if the lockstep
  /// clock refuses the camera
  void start(const ros::NodeHandle& nh, ros::NodeHandle& private_nh, double rate, const CameraPart& camera,
             std::function<bool(const ros::Time&)> render);
  /// Stop rendering and leave the clock.
  void stop();

 private:
  ros::Timer timer_;
  std::unique_ptr<LockstepClient> lockstep_;
  double next_due_ = 0;  // lockstep: physics time at which the next frame is due
};

}  // namespace xpersif
