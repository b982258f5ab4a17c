/**
 * @file sim_camera.h
 * @brief A camera of the simulated scene (the paper's CAMERA subcomponent), rendered on the client side:
 *        it fetches the scene once, follows /tf, and renders what its camera sees at `~rate` Hz of
 *        simulated time. Images go out as shared pointers, so nodelets in the same manager receive them
 *        without a copy.
 *
 * Parameters: SimCamera::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md).
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
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

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
