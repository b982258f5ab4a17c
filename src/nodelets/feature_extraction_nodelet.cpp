// FeatureExtraction as a nodelet (see include/xpersif/perception/feature_extraction.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/perception/feature_extraction.h"

namespace xpersif {
class FeatureExtractionNodelet : public ComponentNodelet<FeatureExtraction> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::FeatureExtractionNodelet, nodelet::Nodelet)
