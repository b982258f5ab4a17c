// Vision as a nodelet (see include/xpersif/perception/vision_component.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/perception/vision_component.h"

namespace xpersif {
class VisionNodelet : public ComponentNodelet<Vision> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::VisionNodelet, nodelet::Nodelet)
