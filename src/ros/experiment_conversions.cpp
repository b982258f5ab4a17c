#include "xpersif/ros/experiment_conversions.h"

namespace xpersif {

core::Experiment fromMsg(const Experiment& msg) {
  core::Experiment e;
  e.object = msg.object;
  e.side = msg.side;
  e.offset = msg.offset;
  e.distance = msg.distance;
  return e;
}

Experiment toMsg(const core::Experiment& experiment) {
  Experiment msg;
  msg.object = experiment.object;
  msg.side = experiment.side;
  msg.offset = experiment.offset;
  msg.distance = experiment.distance;
  return msg;
}

core::ObjectFeatures fromMsg(const ObjectFeatures& msg) {
  core::ObjectFeatures o;
  o.name = msg.name;
  o.x = msg.position.x;
  o.y = msg.position.y;
  o.yaw = msg.yaw;
  for (std::size_t i = 0; i < msg.feature_names.size() && i < msg.feature_values.size(); ++i) {
    o.extra[msg.feature_names[i]] = msg.feature_values[i];
  }
  return o;
}

core::FeatureVector fromMsg(const FeatureVector& msg) {
  core::FeatureVector v;
  v.stamp = msg.header.stamp.toSec();
  for (const auto& o : msg.objects) v.objects.push_back(fromMsg(o));
  return v;
}

const ObjectFeatures* findObject(const FeatureVector& features, const std::string& name) {
  for (const auto& o : features.objects) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

}  // namespace xpersif
