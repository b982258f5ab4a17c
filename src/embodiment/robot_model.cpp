#include "xpersif/embodiment/robot_model.h"

#include "xpersif/component/parameter_reader.h"

namespace xpersif {

RobotModel::RobotModel(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Supervisor(std::move(nh), std::move(private_nh), "xpersif/RobotModelNodelet") {
  core::Contract get_state;
  get_state.name = "get_robot_state";
  get_state.kind = core::Contract::Kind::Operation;
  get_state.interface_type = "xpersif/GetRobotState";
  get_state.description = "the robot's pose, speeds, IR ring, contact, what it holds and its running commands";
  get_state.preconditions = {{"localized(robot)", "odometry must have arrived"}};
  get_state.effects = {"known(robot_state)"};
  ContractChecker<GetRobotState::Request> contract(get_state);
  contract.check("localized(robot)", [this](const GetRobotState::Request&) {
    std::lock_guard<std::mutex> lock(state_mutex_);
    return pose_source_ && pose_source_->hasOdometry() ? std::string() : "no odometry has arrived yet";
  });
  addOperation<GetRobotState>(contract, nullptr,
                              [this](const GetRobotState::Request&, GetRobotState::Response& response) {
                                fillState(response.state);
                              });
}

const core::ParameterTable& RobotModel::parameters() {
  static const core::ParameterTable table = [] {
    core::ParameterTable own(
        "robot_model",
        {core::numberParameter("contact_range", 0.003, 0.0, 0.05,
                               "m: an IR range this short counts as touching (the robot state's contact)"),
         core::flagParameter("has_gripper", false, "whether the robot state reports a gripper"),
         core::textParameter("observation_topic", "observation/features",
                             "the overhead camera's feature vectors (the robot's observed pose)")});
    own.include(Supervisor::parameters());
    return own;
  }();
  return table;
}

void RobotModel::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, RobotModel::parameters());
  const double contact_range = parameters.get<double>("contact_range");
  const bool has_gripper = parameters.get<bool>("has_gripper");
  const std::string observation_topic = parameters.get<std::string>("observation_topic");
  auto source = std::make_unique<RobotPoseSource>(nodeHandle(), "odom", observation_topic);
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    contact_range_ = contact_range;
    has_gripper_ = has_gripper;
    running_.clear();
    source.swap(pose_source_);
  }
  // Subscriptions are made and dropped outside the lock: dropping one waits for its running callback.
  source.reset();
  ir_sub_ = nodeHandle().subscribe<IrRanges>("ir", 5, [this](const IrRanges::ConstPtr& ir) {
    std::lock_guard<std::mutex> lock(state_mutex_);
    ir_ = ir;
  });
  Supervisor::onConfigure();
}

void RobotModel::onShutdown() {
  Supervisor::onShutdown();
  std::unique_ptr<RobotPoseSource> source;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    source.swap(pose_source_);
  }
  ir_sub_.shutdown();
}

void RobotModel::onComponentStatus(const std::string& name, const ComponentStatus& status) {
  std::lock_guard<std::mutex> lock(state_mutex_);
  running_[name] = status.running_commands;
}

void RobotModel::fillState(RobotState& state) const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  state.header.stamp = ros::Time::now();
  state.header.frame_id = "world";
  core::Pose2D pose;
  pose_source_->pose("odometry", &pose);
  state.odometry.x = pose.x;
  state.odometry.y = pose.y;
  state.odometry.theta = pose.yaw;
  state.observed = pose_source_->pose("observation", &pose).empty();
  state.pose.x = pose.x;
  state.pose.y = pose.y;
  state.pose.theta = pose.yaw;
  pose_source_->velocity(&state.linear_velocity, &state.angular_velocity);
  if (ir_) {
    state.ir_frames = ir_->frames;
    state.ir_ranges = ir_->ranges;
    state.ir_max_range = ir_->max_range;
    for (std::size_t i = 0; i < ir_->ranges.size() && i < ir_->frames.size(); ++i) {
      if (ir_->ranges[i] <= contact_range_) state.contact_sensors.push_back(ir_->frames[i]);
    }
  }
  state.in_contact = !state.contact_sensors.empty();
  state.has_gripper = has_gripper_;
  for (const auto& [component, commands] : running_) {
    for (const auto& command : commands) state.busy_commands.push_back(component + "/" + command);
  }
}

}  // namespace xpersif
