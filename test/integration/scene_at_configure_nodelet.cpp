// Test-only component that asks XPERSim for the scene from inside its configure, as RELOCATION does: loaded into
// XPERSim's own manager (one worker thread), it is configured only if XPERSim answers from a thread of its own.
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>

#include "xpersif/GetScene.h"
#include "xpersif/component/component.h"
#include "xpersif/component/shells.h"

namespace xpersif_test {

class SceneAtConfigure : public xpersif::Component {
 public:
  SceneAtConfigure(ros::NodeHandle nh, ros::NodeHandle private_nh)
      : Component(std::move(nh), std::move(private_nh), "xpersif_test/SceneAtConfigureNodelet") {}

 protected:
  void onConfigure() override {
    // XPERSim may still be starting: asked again until it answers with a scene (refusals come back at once).
    const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(60.0);
    xpersif::GetScene scene;
    while (!halting() && ros::WallTime::now() < until) {
      if (ros::service::call("xpersim/get_scene", scene) && scene.response.success) {
        privateNodeHandle().setParam("scene_nodes", static_cast<int>(scene.response.scene.nodes.size()));
        return;
      }
      ros::WallDuration(0.2).sleep();
    }
    throw std::runtime_error("xpersim/get_scene gave no scene within 60 s");
  }
};

class SceneAtConfigureNodelet : public xpersif::ComponentNodelet<SceneAtConfigure> {};

}  // namespace xpersif_test

PLUGINLIB_EXPORT_CLASS(xpersif_test::SceneAtConfigureNodelet, nodelet::Nodelet)
