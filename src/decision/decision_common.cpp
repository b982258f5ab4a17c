#include "xpersif/decision/decision_common.h"

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

std::string joinNames(const std::vector<std::string>& names) {
  std::string text;
  for (const auto& n : names) text += (text.empty() ? "" : ", ") + n;
  return "[" + text + "]";
}

}  // namespace xpersif
