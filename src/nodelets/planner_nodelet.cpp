// Planner as a nodelet (see include/xpersif/decision/planner_component.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/decision/planner_component.h"

namespace xpersif {
class PlannerNodelet : public ComponentNodelet<Planner> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::PlannerNodelet, nodelet::Nodelet)
