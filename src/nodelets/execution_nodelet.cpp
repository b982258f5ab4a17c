// Execution as a nodelet (see include/xpersif/decision/execution.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/decision/execution.h"

namespace xpersif {
class ExecutionNodelet : public ComponentNodelet<Execution> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::ExecutionNodelet, nodelet::Nodelet)
