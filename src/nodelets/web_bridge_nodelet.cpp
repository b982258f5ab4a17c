// WebBridge as a nodelet (see include/xpersif/web/web_bridge.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/web/web_bridge.h"

namespace xpersif {
class WebBridgeNodelet : public ComponentNodelet<WebBridge> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::WebBridgeNodelet, nodelet::Nodelet)
