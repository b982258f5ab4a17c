// The generic organizational component: supervises the components listed in ~components.
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/component/supervisor.h"

namespace xpersif {
class SupervisorNodelet : public ComponentNodelet<Supervisor> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::SupervisorNodelet, nodelet::Nodelet)
