// Test-only component whose configure never answers (it waits until its process shuts down): a supervisor that
// brings it up must give up after ~startup_timeout and say so, not wait for good (seen in a live system: RELOCATION's
// configure blocked on a service whose queue was pinned to the same thread). With ~configure_seconds it is only slow.
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>

#include <algorithm>

#include "xpersif/component/component.h"
#include "xpersif/component/shells.h"

namespace xpersif_test {

class StuckConfigure : public xpersif::Component {
 public:
  StuckConfigure(ros::NodeHandle nh, ros::NodeHandle private_nh)
      : Component(std::move(nh), std::move(private_nh), "xpersif_test/StuckConfigureNodelet") {}

 protected:
  void onConfigure() override {
    // ~configure_seconds: a configure that is only slow (a camera waiting for its first tf); none: it never answers.
    double seconds = -1.0;
    privateNodeHandle().param("configure_seconds", seconds, seconds);
    const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(std::max(seconds, 0.0));
    while (ros::ok() && !halting() && (seconds < 0 || ros::WallTime::now() < until)) ros::WallDuration(0.1).sleep();
  }
};

class StuckConfigureNodelet : public xpersif::ComponentNodelet<StuckConfigure> {};

}  // namespace xpersif_test

PLUGINLIB_EXPORT_CLASS(xpersif_test::StuckConfigureNodelet, nodelet::Nodelet)
