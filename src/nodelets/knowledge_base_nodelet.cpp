// KNOWLEDGEBASE as a nodelet (see include/xpersif/cognition/knowledge_base_component.h).
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/cognition/knowledge_base_component.h"
#include "xpersif/component/shells.h"

namespace xpersif {
class KnowledgeBaseNodelet : public ComponentNodelet<KnowledgeBaseComponent> {};
}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::KnowledgeBaseNodelet, nodelet::Nodelet)
