/**
 * @file run_driver.h
 * @brief Drives one run of LOOPMODEL's `run` command to its end: what the console (`xpersif run`) and the
 *        experiment runner share.
 *
 * A run outlives its LOOPMODEL. When the command's server goes away (its manager was killed) and comes back
 * (roslaunch respawned the manager, and the loader put LOOPMODEL back), the goal is sent again with `resume`,
 * and the run goes on from the knowledge base where the dead LOOPMODEL left it. The driver gives up, with a
 * sentence, once the server has been gone for `patience` seconds or the ROS master for 10. All waiting is on wall
 * time: simulated time stands still while the simulator is gone.
 */
#pragma once

#include <actionlib/client/simple_action_client.h>
#include <ros/ros.h>

#include <functional>
#include <string>

#include "xpersif/RunLoopAction.h"

namespace xpersif {

class RunDriver {
 public:
  using Client = actionlib::SimpleActionClient<RunLoopAction>;
  using Feedback = std::function<void(const RunLoopFeedbackConstPtr&)>;

  struct Outcome {
    bool ended = false;  ///< the run reported an end (state and result below); false: `problem` says why not
    actionlib::SimpleClientGoalState state{actionlib::SimpleClientGoalState::LOST};
    RunLoopResultConstPtr result;
    std::string problem;
    unsigned resumes = 0;  ///< how often the run was sent again after LOOPMODEL came back
  };

  /// @param say   told, in a sentence, when LOOPMODEL went away and when the run was sent again.
  RunDriver(Client& client, std::string server, std::function<void(const std::string&)> say, double patience = 60.0)
      : client_(client), server_(std::move(server)), say_(std::move(say)), patience_(patience) {}

  /// Runs @p goal to its end. @p cancel_requested is asked often; once it says yes the run is cancelled (once),
  /// and its end is still waited for. @p give_up ends the wait at once (the caller is shutting down).
  Outcome run(RunLoopGoal goal, const Feedback& feedback, const std::function<bool()>& cancel_requested,
              const std::function<bool()>& give_up) {
    Outcome outcome;
    client_.sendGoal(goal, {}, {}, feedback);
    bool cancelled = false, gone = false;
    ros::WallTime last_heard = ros::WallTime::now(), last_master = last_heard, next_check = last_heard;
    while (true) {
      if (give_up && give_up()) {
        client_.cancelGoal();
        outcome.problem = "interrupted";
        return outcome;
      }
      if (!cancelled && cancel_requested && cancel_requested()) {
        client_.cancelGoal();
        cancelled = true;
      }
      const ros::WallTime now = ros::WallTime::now();
      bool connected = !gone;
      if (now >= next_check || gone) {
        next_check = now + ros::WallDuration(gone ? 0.2 : 1.0);
        const bool master = ros::master::check();
        connected = master && client_.isServerConnected();
        if (connected) {
          last_heard = now;
        } else if (!gone) {
          gone = true;
          say_(server_ + " went away during the run (its manager died?); waiting up to " +
               std::to_string(static_cast<int>(patience_)) + " s for it to come back");
        }
        if (master) last_master = now;
        // A master that died took the whole system with it: nothing will respawn it, so 10 s are enough.
        const double limit = master ? patience_ : 10.0;
        if ((now - (master ? last_heard : last_master)).toSec() > limit) {
          outcome.problem = (master ? server_ : "the ROS master " + ros::master::getURI()) + " has been gone for " +
                            std::to_string(static_cast<int>(limit)) +
                            " s, so the run's result will not come; what it did is in the knowledge base: start the "
                            "system again if it died, and go on with the same command and --resume";
          return outcome;
        }
      }
      const actionlib::SimpleClientGoalState state = client_.getState();
      // A restarted server does not know the goal (LOST); a resend may come before it is ACTIVE (REJECTED).
      const bool lost = state == actionlib::SimpleClientGoalState::LOST;
      const bool early_rejection = outcome.resumes > 0 && state == actionlib::SimpleClientGoalState::REJECTED &&
                                   (now - resent_at_).toSec() < patience_;
      if (lost && !gone) {
        gone = true;
        say_(server_ + " lost the run (it was restarted)");
      }
      if ((gone || early_rejection) && connected && !cancelled) {
        if (early_rejection) ros::WallDuration(0.5).sleep();
        goal.resume = true;
        say_(std::string(early_rejection ? "sent the run again (the restarted LOOPMODEL was not ready: " +
                                               state.getText() + ")"
                                         : server_ + " is back; sending the run again with resume"));
        if (!early_rejection) resent_at_ = ros::WallTime::now();
        client_.sendGoal(goal, {}, {}, feedback);
        ++outcome.resumes;
        gone = false;
        continue;
      }
      if (state.isDone() && (!lost || cancelled) && !early_rejection) break;
      ros::WallDuration(0.05).sleep();
    }
    outcome.ended = true;
    outcome.state = client_.getState();
    outcome.result = client_.getResult();
    return outcome;
  }

 private:
  Client& client_;
  std::string server_;
  std::function<void(const std::string&)> say_;
  double patience_;
  ros::WallTime resent_at_;
};

}  // namespace xpersif
