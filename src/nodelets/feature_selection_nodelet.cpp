// FeatureSelection as a nodelet (see include/xpersif/perception/feature_selection.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/perception/feature_selection.h"

namespace xpersif {
class FeatureSelectionNodelet : public ComponentNodelet<FeatureSelection> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::FeatureSelectionNodelet, nodelet::Nodelet)
