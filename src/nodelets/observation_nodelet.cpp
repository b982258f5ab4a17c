// Observation as a nodelet (see include/xpersif/perception/observation.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/perception/observation.h"

namespace xpersif {
class ObservationNodelet : public ComponentNodelet<Observation> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::ObservationNodelet, nodelet::Nodelet)
