// The example aggregate component as a nodelet.
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"
#include "xpersif/examples/example_statistics.h"

namespace xpersif {
class ExampleStatisticsNodelet : public ComponentNodelet<ExampleStatistics> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::ExampleStatisticsNodelet, nodelet::Nodelet)
