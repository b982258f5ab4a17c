/**
 * @file sim_camera.h
 * @brief A camera of the simulated scene (the paper's CAMERA subcomponent), rendered on the client side:
 *        it fetches the scene once, follows /tf, and renders what its camera sees at `~rate` Hz of
 *        simulated time. Images go out as shared pointers, so nodelets in the same manager receive them
 *        without a copy.
 *
 * Parameters (configure): `~camera` (a camera of the scene, e.g. overhead or robot_camera; required),
 * `~rate` (Hz, default 30), `~scene_topic` (latched scene, default xpersim/scene, resolved in the component's namespace),
 * `~report_buffer_address` (default false; publishes `~buffer_address` for the zero-copy test).
 * Publishes `~image_raw` (sensor_msgs/Image, bgr8) and `~camera_info`.
 */
#pragma once

#include <ros/ros.h>

#include <memory>
#include <mutex>

#include "xpersif/component/component.h"
#include "xpersif/camera/rendered_camera.h"

namespace xpersif {

class SimCamera : public Component {
 public:
  SimCamera(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;

 private:
  void renderAndPublish();

  std::mutex mutex_;
  std::unique_ptr<RenderedCamera> camera_;
  double rate_ = 30.0;
  bool report_address_ = false;
  std::uint32_t seq_ = 0;

  ros::Publisher image_pub_, info_pub_, address_pub_;
  ros::Timer timer_;
};

}  // namespace xpersif
