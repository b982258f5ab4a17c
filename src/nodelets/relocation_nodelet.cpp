// Relocation as a nodelet (see include/xpersif/embodiment/relocation.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/embodiment/relocation.h"

namespace xpersif {
class RelocationNodelet : public ComponentNodelet<Relocation> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::RelocationNodelet, nodelet::Nodelet)
