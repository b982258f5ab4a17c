// SnapshotRecorder as a nodelet (see include/xpersif/traces/snapshot_recorder.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/traces/snapshot_recorder.h"

namespace xpersif {
class SnapshotRecorderNodelet : public ComponentNodelet<SnapshotRecorder> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::SnapshotRecorderNodelet, nodelet::Nodelet)
