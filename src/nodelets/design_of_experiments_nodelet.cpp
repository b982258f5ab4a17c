// DesignOfExperiments as a nodelet (see include/xpersif/decision/design_of_experiments.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/decision/design_of_experiments.h"

namespace xpersif {
class DesignOfExperimentsNodelet : public ComponentNodelet<DesignOfExperiments> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::DesignOfExperimentsNodelet, nodelet::Nodelet)
