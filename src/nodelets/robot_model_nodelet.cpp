// RobotModel as a nodelet (see include/xpersif/embodiment/robot_model.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/embodiment/robot_model.h"

namespace xpersif {
class RobotModelNodelet : public ComponentNodelet<RobotModel> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::RobotModelNodelet, nodelet::Nodelet)
