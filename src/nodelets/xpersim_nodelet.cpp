// XPERSim as a nodelet: cameras loaded into the same manager get its messages without copies.
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/xpersim/xpersim.h"

namespace xpersif {
class XPerSimNodelet : public ComponentNodelet<XPerSim> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::XPerSimNodelet, nodelet::Nodelet)
