/**
 * @file robot_model.h
 * @brief ROBOTMODEL (organizational): starts, parametrizes, watches and restarts the embodiment's
 *        components (RELOCATION, MANIPULATION, PERCEPTION, OBSERVATION, FEATURESELECTION, VISION: the
 *        `~components` list, as for any Supervisor), and is the one place to ask for the robot's state:
 *        operation `get_robot_state` (pose, speeds, IR ring, contact, what it holds, which embodiment
 *        commands run).
 *
 * Parameters: RobotModel::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md).
 */
#pragma once

#include <map>
#include <mutex>

#include "xpersif/GetRobotState.h"
#include "xpersif/IrRanges.h"
#include "xpersif/component/supervisor.h"
#include "xpersif/embodiment/robot_pose_source.h"

namespace xpersif {

class RobotModel : public Supervisor {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  RobotModel(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;
  void onShutdown() override;
  void onComponentStatus(const std::string& name, const ComponentStatus& status) override;

 private:
  void fillState(RobotState& state) const;

  mutable std::mutex state_mutex_;
  double contact_range_ = 0.003;
  bool has_gripper_ = false;
  IrRanges::ConstPtr ir_;
  std::map<std::string, std::vector<std::string>> running_;  // component -> its running commands
  std::unique_ptr<RobotPoseSource> pose_source_;
  ros::Subscriber ir_sub_;
};

}  // namespace xpersif
