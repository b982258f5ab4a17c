/**
 * @file feature_selection.h
 * @brief FEATURESELECTION: says which further features VISION computes for every object (colour, size,
 *        orientation, distance to the robot, ...). Operation `select_features` (unknown names are refused,
 *        listing the known ones; the selection stays as it was); the choice is published latched on
 *        `~selection`. Parameters: `~features` (the initial selection; default core::FeatureSelection's).
 *        `~available` is set on configure to the features one can choose, "name [unit]: description".
 */
#pragma once

#include <mutex>

#include "xpersif/FeatureNames.h"
#include "xpersif/SelectFeatures.h"
#include "xpersif/component/component.h"
#include "xpersif/core/vision.h"

namespace xpersif {

class FeatureSelection : public Component {
 public:
  /// Its parameters, declared once (README, Parameter reference).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  FeatureSelection(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;

 private:
  void publish();

  std::mutex mutex_;
  core::FeatureSelection selection_;
  ros::Publisher selection_pub_;
};

}  // namespace xpersif
