// Manipulation as a nodelet (see include/xpersif/embodiment/manipulation.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/embodiment/manipulation.h"

namespace xpersif {
class ManipulationNodelet : public ComponentNodelet<Manipulation> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::ManipulationNodelet, nodelet::Nodelet)
