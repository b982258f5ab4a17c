// XPERSim as a nodelet: cameras loaded into the same manager get its messages without copies. Its callbacks run on a
// thread of its own, so that components in its manager may call its operations from their callbacks.
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/xpersim/xpersim.h"

namespace xpersif {
class XPerSimNodelet : public ComponentNodelet<XPerSim, true> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::XPerSimNodelet, nodelet::Nodelet)
