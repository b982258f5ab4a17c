// MACHINELEARNING as a nodelet (see include/xpersif/cognition/machine_learning.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/cognition/machine_learning.h"
#include "xpersif/component/shells.h"

namespace xpersif {
class MachineLearningNodelet : public ComponentNodelet<MachineLearning> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::MachineLearningNodelet, nodelet::Nodelet)
