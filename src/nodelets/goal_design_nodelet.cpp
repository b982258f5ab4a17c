// GoalDesign as a nodelet (see include/xpersif/decision/goal_design.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/decision/goal_design.h"

namespace xpersif {
class GoalDesignNodelet : public ComponentNodelet<GoalDesign> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::GoalDesignNodelet, nodelet::Nodelet)
