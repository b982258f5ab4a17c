// MOTIVATION as a nodelet (see include/xpersif/cognition/motivation_component.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/cognition/motivation_component.h"
#include "xpersif/component/shells.h"

namespace xpersif {
class MotivationNodelet : public ComponentNodelet<MotivationComponent> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::MotivationNodelet, nodelet::Nodelet)
