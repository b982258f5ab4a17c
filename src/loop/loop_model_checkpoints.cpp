/**
 * @file loop_model_checkpoints.cpp
 * @brief LOOPMODEL's checkpoints: XPERSim's world state at the start of every step, stored in the knowledge base
 *        and put back when a step is done again (a component was lost during it) or a run resumes; and how the
 *        loop notices a lost component and waits for it to come back.
 */
#include "xpersif/loop/loop_model.h"

#include "xpersif/GetWorldState.h"
#include "xpersif/RecordWorldState.h"
#include "xpersif/WorldState.h"
#include "service_call.h"

namespace xpersif {

using loop::callPatiently;
using loop::callWhenReady;

void LoopModel::onComponentLost(const SupervisedComponent& component, const std::string& reason) {
  (void)component;
  (void)reason;
  ++losses_;
}

std::string LoopModel::checkpointWorld(std::string* why) {
  Spending spending(wall_spent_, "checkpoint");
  WorldState checkpoint;
  *why = callPatiently(nodeHandle(), "xpersim/checkpoint", checkpoint);
  if (why->empty()) world_lineage_ = checkpoint.response.lineage;
  return checkpoint.response.state;
}

std::string LoopModel::storeWorldState(std::uint64_t run_id, std::uint32_t step, const std::string& state) {
  Spending spending(wall_spent_, "checkpoint");
  RecordWorldState record;
  record.request.run_id = run_id;
  record.request.step = step;
  record.request.state = state;
  return callPatiently(nodeHandle(), "knowledge_base/record_world_state", record);
}

std::string LoopModel::takeCheckpoint(std::uint64_t run_id, std::uint32_t step, std::string* refused) {
  std::string why;
  const std::string state = checkpointWorld(&why);
  if (why.empty()) {
    why = storeWorldState(run_id, step, state);
    // A knowledge base that cannot store (its disk full or read-only) will not store the step's results either:
    // the caller ends the run before the step, so that it can be resumed from here once the disk is fixed.
    if (!why.empty()) {
      *refused = why;
      return state;
    }
  }
  if (!why.empty()) {
    ROS_WARN("%s: no world state at step %u (a resume from there will start from the world as it is then): %s",
             name().c_str(), step, why.c_str());
  }
  return state;
}

std::string LoopModel::restoreCheckpoint(std::uint64_t run_id, std::uint32_t step, const std::string& state) {
  Spending spending(wall_spent_, "checkpoint");
  WorldState restore;
  restore.request.state = state;
  // Time goes on after the latest the loop saw, plus a margin for what others saw after it.
  restore.request.min_clock = latest_clock_ + 1.0;
  if (state.empty()) {
    GetWorldState stored;
    stored.request.run_id = run_id;
    stored.request.step = step;
    std::string why = callPatiently(nodeHandle(), "knowledge_base/get_world_state", stored);
    if (!why.empty()) return why;
    if (!stored.response.found) return "no world state is stored for step " + std::to_string(step);
    restore.request.state = stored.response.state;
  }
  // Patient with restore's unmet precondition too: standing(sim) fails only while a lockstep participant still
  // wants time (a command of the lost step winding down, a paused XPERSim), and the world stands once it has it.
  const std::string why = callWhenReady(nodeHandle(), "xpersim/restore", restore, {});
  if (!why.empty()) return why;
  world_lineage_ = restore.response.lineage;
  awaitClock(restore.response.clock);
  return "";
}

void LoopModel::awaitClock(double restored_clock) {
  // Frames stamped after restored_clock show the restored world. Until this process's clock has reached it, a
  // scene "newer than now" may still be a frame of the world before (a restarted simulator shows its world file).
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(10.0);
  while (ros::ok() && ros::Time::now().toSec() < restored_clock && ros::WallTime::now() < until) {
    ros::WallDuration(0.005).sleep();
  }
  if (ros::Time::now().toSec() < restored_clock) {
    ROS_WARN("%s: the clock did not reach the restored world's %.3f s within 10 s (it shows %.3f s)", name().c_str(),
             restored_clock, ros::Time::now().toSec());
  }
}

bool LoopModel::lostDuring(std::uint64_t losses_before, const ExperimentRecord& record) {
  // A failure may be the first sign of a lost component: give the supervisor its heartbeat timeout to tell.
  if (record.status != "done" && losses_ == losses_before) ros::WallDuration(heartbeatTimeout() + 0.5).sleep();
  return losses_ != losses_before;
}

void LoopModel::nameFailedComponent(ExperimentRecord& record) const {
  if (record.status == "done") return;
  const std::string failed = failedComponent();
  if (!failed.empty()) record.reason = failed + "; downstream of it: " + record.reason;
}

std::string LoopModel::returnTo(Run::Context& context, std::uint64_t run_id, const std::string& state) {
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(180.0);
  std::vector<std::string> lost = lostComponents();
  while (!lost.empty()) {
    if (context.stopRequested()) return "stopped while components were lost";
    if (ros::WallTime::now() > until) {
      std::string names;
      for (const auto& n : lost) names += (names.empty() ? "" : ", ") + n;
      return names + " did not come back within 180 s";
    }
    ros::WallDuration(0.1).sleep();
    lost = lostComponents();
  }
  return restoreCheckpoint(run_id, 0, state);
}

}  // namespace xpersif
