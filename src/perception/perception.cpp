#include "xpersif/perception/perception.h"

#include "xpersif/component/parameter_reader.h"


namespace xpersif {

Perception::Perception(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : AggregateComponent(nh, private_nh, "xpersif/PerceptionNodelet"),
      ir_ring_(addPart<LatestMessagePart<IrRanges>>("ir_ring", nh, "ir")),
      odometry_(addPart<LatestMessagePart<nav_msgs::Odometry>>("odometry", nh, "odom")),
      camera_(addPart<CameraPart>("camera", nh, core::kCameraOnRobot, [this](const RenderedCamera& c) { onScene(c); })),
      extraction_(addPart<FeatureExtractionPart>("feature_extraction")),
      schedule_(camera_, [this](const ros::Time& lockstep_stamp) { return tick(lockstep_stamp); }) {
  core::Contract read_ir;
  read_ir.name = "read_ir";
  read_ir.kind = core::Contract::Kind::Operation;
  read_ir.interface_type = "xpersif/ReadIr";
  read_ir.description = "the latest reading of the IR proximity ring";
  read_ir.preconditions = {{"sensing(ir_ring)", "an IR reading must have arrived"}};
  read_ir.effects = {"known(ir_ranges)"};
  ContractChecker<ReadIr::Request> ir_contract(read_ir);
  ir_contract.check("sensing(ir_ring)", [this](const ReadIr::Request&) {
    return ir_ring_.latest() ? std::string() : "no IR reading has arrived yet";
  });
  addOperation<ReadIr>(
      ir_contract, [](const ReadIr::Request& r) { core::requireInRange("max_age", r.max_age, 0.0, 1e6); },
      [this](const ReadIr::Request& request, ReadIr::Response& response) {
        const IrRanges::ConstPtr reading = ir_ring_.latest();
        const double age = (ros::Time::now() - reading->header.stamp).toSec();
        if (request.max_age > 0 && age > request.max_age) {
          throw std::runtime_error("the latest IR reading is " + core::describeNumber(age) + " s old, more than max_age " +
                                   core::describeNumber(request.max_age) + " s");
        }
        response.reading = *reading;
      });

  addOperation<GetFeatures>(
      features_.contract("the robot camera", "the robot camera has produced no feature vector yet"),
      LatestFeatures::validate,
      [this](const GetFeatures::Request& request, GetFeatures::Response& response) { features_.answer(request, response); },
      true, nullptr, LatestFeatures::binder());
}

const core::ParameterTable& Perception::parameters() {
  using core::ParameterSpec;
  static const core::ParameterTable table = [] {
    core::ParameterTable own(
        "perception",
        {core::numberParameter("rate", 10.0, 0.1, 1000.0, "Hz of simulated time at which the robot camera is rendered (realtime and fast; lockstep with lockstep_frames periodic)"),
         core::numberParameter("max_wall_rate", 30.0, 0.1, 1000.0, "realtime and fast modes: at most this many frames per wall second"),
         FrameSchedule::modeParameter(),
         core::textParameter("ir_ring/topic", "ir", "part ir_ring: the IR ranges' topic"),
         core::numberParameter("ir_ring/timeout", 2.0, 1e-6, 3600.0, "part ir_ring: s of ROS time without ranges before it is a problem"),
         core::textParameter("odometry/topic", "odom", "part odometry: the odometry's topic"),
         core::numberParameter("odometry/timeout", 2.0, 1e-6, 3600.0, "part odometry: s of ROS time without odometry before it is a problem"),
         core::textParameter("camera/name", core::kCameraOnRobot, "part camera: the scene's camera to render: its name, or on_robot (the one camera the robot carries)"),
         core::textParameter("camera/scene_topic", "xpersim/scene", "part camera: XPERSim's scene")});
    own.include(FeatureExtractionPart::parameters(), "feature_extraction/").include(LockstepClient::parameters());
    return own;
  }();
  return table;
}

void Perception::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, Perception::parameters());
  const double rate = parameters.get<double>("rate");
  const double max_wall_rate = parameters.get<double>("max_wall_rate");
  const bool periodic_frames = parameters.get<std::string>("lockstep_frames") == "periodic";
  {
    std::lock_guard<std::mutex> lock(mutex_);
    rate_ = rate;
    max_wall_rate_ = max_wall_rate;
    periodic_frames_ = periodic_frames;
    features_.reset();
    have_mount_ = false;
    frames_.advertise(pnh);
  }
  AggregateComponent::onConfigure();
}

void Perception::onScene(const RenderedCamera& camera) {
  // The camera's mount on the robot: chain the fixed nodes from the camera's frame up to the robot's root.
  const core::SceneDescription scene = camera.scene();
  const std::string root = scene.robot_root;  // from the world file's roles
  Eigen::Isometry3d root_from_camera = Eigen::Isometry3d::Identity();
  std::string frame = camera.model().frame;
  const core::SceneNode* node = scene.findNode(frame);
  while (node && node->name != root) {
    root_from_camera = node->parent_from_node * root_from_camera;
    node = scene.findNode(node->parent);
  }
  if (!node) {
    reportError("camera '" + camera.name() + "' does not hang from the robot's " + root + "; PERCEPTION needs the robot's own camera");
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    base_from_camera_ = root_from_camera;
    base_height_ = node->parent_from_node.translation().z();
    have_mount_ = true;
  }
  extraction_.setCamera(scene, camera.model());
}

void Perception::onActivate() {
  AggregateComponent::onActivate();
  schedule_.start(nodeHandle(), privateNodeHandle(), rate_, max_wall_rate_, periodic_frames_);
}

void Perception::onDeactivate() {
  schedule_.stop();
  AggregateComponent::onDeactivate();
}

bool Perception::tick(const ros::Time& lockstep_stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto camera = camera_.camera();
  const nav_msgs::Odometry::ConstPtr odom = odometry_.latest();
  if (!camera || !have_mount_ || !odom || !extraction_.ready()) return false;
  try {
    sensor_msgs::ImagePtr image = camera->render(seq_ + 1);
    if (!image) return false;
    ++seq_;
    const auto& p = odom->pose.pose;
    const double yaw = std::atan2(2.0 * (p.orientation.w * p.orientation.z + p.orientation.x * p.orientation.y),
                                  1.0 - 2.0 * (p.orientation.y * p.orientation.y + p.orientation.z * p.orientation.z));
    // What the robot believes: its odometry on the floor, at its body's height, and the camera's mount.
    Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();
    world_from_base.translation() = Eigen::Vector3d(p.position.x, p.position.y, base_height_);
    world_from_base.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    auto features = boost::make_shared<FeatureVector>(
        extraction_.extract(*image, world_from_base * base_from_camera_, privateNodeHandle().getNamespace()));
    frames_.publish(image, camera->info(image->header), features, features_);
    return true;
  } catch (const std::exception& e) {
    reportError(std::string("perception failed: ") + e.what());
  }
  return false;
}

}  // namespace xpersif
