// Vision as a nodelet (see include/xpersif/perception/vision.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/perception/vision.h"

namespace xpersif {
class VisionNodelet : public ComponentNodelet<Vision> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::VisionNodelet, nodelet::Nodelet)
