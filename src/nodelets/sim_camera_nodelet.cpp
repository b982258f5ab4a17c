// A simulated camera as a nodelet: in XPERSim's manager, its images reach other nodelets without copies.
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/camera/sim_camera.h"
#include "xpersif/component/shells.h"

namespace xpersif {
class SimCameraNodelet : public ComponentNodelet<SimCamera> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::SimCameraNodelet, nodelet::Nodelet)
