/**
 * @file experiment_conversions.h
 * @brief Between the loop's messages (Experiment, FeatureVector, ObjectFeatures) and the ROS-free core
 *        structs of core/experiment.h.
 */
#pragma once

#include "xpersif/Experiment.h"
#include "xpersif/FeatureVector.h"
#include "xpersif/core/experiment.h"

namespace xpersif {

core::Experiment fromMsg(const Experiment& msg);
Experiment toMsg(const core::Experiment& experiment);
/// Pose and VISION's features (feature_names/values) of one object.
core::ObjectFeatures fromMsg(const ObjectFeatures& msg);
core::FeatureVector fromMsg(const FeatureVector& msg);
/// The object called @p name in @p features, or nullptr.
const ObjectFeatures* findObject(const FeatureVector& features, const std::string& name);

}  // namespace xpersif
