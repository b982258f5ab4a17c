/**
 * @file action_wait.h
 * @brief Waiting for an action's result on wall time.
 *
 * actionlib's `waitForResult(timeout)` counts simulated time. That time stands still while the simulator is
 * gone, and runs backwards when a restarted simulator starts from zero. A waiting client then waits until the
 * new clock has caught up with the old one, however long that takes (issue 19: 54 s of a multi-host run).
 */
#pragma once

#include <actionlib/client/simple_action_client.h>
#include <ros/ros.h>

#include <functional>

namespace xpersif {

/// Waits until the client's goal is done, `timeout` of wall time passes (false), or `give_up()` says so (false).
template <class Action>
bool waitForResultOnWallTime(actionlib::SimpleActionClient<Action>& client, const ros::WallDuration& timeout,
                             const std::function<bool()>& give_up = {}) {
  const ros::WallTime until = ros::WallTime::now() + timeout;
  while (!client.getState().isDone()) {
    if (ros::WallTime::now() > until || (give_up && give_up()) || !ros::ok()) return false;
    ros::WallDuration(0.002).sleep();
  }
  return true;
}

}  // namespace xpersif
