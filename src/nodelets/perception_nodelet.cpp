// Perception as a nodelet (see include/xpersif/perception/perception.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/perception/perception.h"

namespace xpersif {
class PerceptionNodelet : public ComponentNodelet<Perception> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::PerceptionNodelet, nodelet::Nodelet)
