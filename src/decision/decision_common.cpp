#include "xpersif/decision/decision_common.h"

namespace xpersif {

core::ObjectFeatures toCoreObject(const ObjectFeatures& object) {
  core::ObjectFeatures o;
  o.name = object.name;
  o.x = object.position.x;
  o.y = object.position.y;
  o.yaw = object.yaw;
  const std::size_t n = std::min(object.feature_names.size(), object.feature_values.size());
  for (std::size_t i = 0; i < n; ++i) o.extra[object.feature_names[i]] = object.feature_values[i];
  return o;
}

core::FeatureVector toCoreFeatures(const FeatureVector& features) {
  core::FeatureVector v;
  v.stamp = features.header.stamp.toSec();
  for (const auto& o : features.objects) v.objects.push_back(toCoreObject(o));
  return v;
}

core::Experiment toCoreExperiment(const Experiment& experiment) {
  return core::Experiment{experiment.object, experiment.side, experiment.offset, experiment.distance};
}

Experiment toExperimentMsg(const core::Experiment& experiment) {
  Experiment m;
  m.object = experiment.object;
  m.side = experiment.side;
  m.offset = experiment.offset;
  m.distance = experiment.distance;
  return m;
}

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

const ObjectFeatures* findObject(const FeatureVector& features, const std::string& name) {
  for (const auto& o : features.objects) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

std::string joinNames(const std::vector<std::string>& names) {
  std::string text;
  for (const auto& n : names) text += (text.empty() ? "" : ", ") + n;
  return "[" + text + "]";
}

}  // namespace xpersif
