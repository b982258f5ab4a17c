#include "xpersif/decision/decision_common.h"

#include "xpersif/core/common/validation.h"

namespace xpersif {

core::Contract fromContractMsg(const Contract& message) {
  core::Contract c;
  c.name = message.name;
  if (message.kind == Contract::COMMAND) {
    c.kind = core::Contract::Kind::Command;
  } else if (message.kind == Contract::OPERATION) {
    c.kind = core::Contract::Kind::Operation;
  } else {
    throw core::ContractError("contract '" + message.name + "' has kind '" + message.kind +
                              "', neither command nor operation");
  }
  c.interface_type = message.interface_type;
  c.description = message.description;
  c.parameters = message.parameters;
  for (const auto& p : message.preconditions) c.preconditions.push_back({p.literal, p.description});
  c.effects = message.effects;
  return c;
}

std::string checkScene(const FeatureVector& scene) {
  std::string why = core::checkMaxSize("scene.objects", scene.objects.size(), core::kMaxObjectsPerFeatureVector);
  for (std::size_t i = 0; why.empty() && i < scene.objects.size(); ++i) {
    const auto& o = scene.objects[i];
    const std::string field = "scene.objects[" + std::to_string(i) + "]";
    why = core::checkAllFinite(field + " pose", {o.position.x, o.position.y, o.yaw});
    if (why.empty()) why = core::checkAllFinite(field + ".feature_values", o.feature_values);
  }
  return why;
}

std::string joinNames(const std::vector<std::string>& names) {
  std::string text;
  for (const auto& n : names) text += (text.empty() ? "" : ", ") + n;
  return "[" + text + "]";
}

}  // namespace xpersif
