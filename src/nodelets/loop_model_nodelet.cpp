// LoopModel as a nodelet (see include/xpersif/loop/loop_model.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/loop/loop_model.h"

namespace xpersif {
class LoopModelNodelet : public ComponentNodelet<LoopModel> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::LoopModelNodelet, nodelet::Nodelet)
