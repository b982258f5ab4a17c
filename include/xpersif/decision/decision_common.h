/**
 * @file decision_common.h
 * @brief Small conversions shared by the loop's decision components (DESIGNOFEXPERIMENTS, PLANNER, EXECUTION,
 *        GOALDESIGN): between the loop's messages and the ROS-free core types.
 */
#pragma once

#include <string>
#include <vector>

#include "xpersif/Contract.h"
#include "xpersif/Experiment.h"
#include "xpersif/FeatureVector.h"
#include "xpersif/ObjectFeatures.h"
#include "xpersif/core/contract.h"
#include "xpersif/core/experiment.h"

namespace xpersif {

/// The object's pose and VISION's further features (feature_names/values) as the learner's input.
core::ObjectFeatures toCoreObject(const ObjectFeatures& object);
/// The whole vector; stamp in seconds of ROS time.
core::FeatureVector toCoreFeatures(const FeatureVector& features);
core::Experiment toCoreExperiment(const Experiment& experiment);
Experiment toExperimentMsg(const core::Experiment& experiment);

/// A contract as get_contracts sends it. Throws core::ContractError for an unknown kind.
core::Contract fromContractMsg(const Contract& message);

/// The object named @p name in @p features, or nullptr.
const ObjectFeatures* findObject(const FeatureVector& features, const std::string& name);

/// "[a, b, c]" (contract bindings and messages).
std::string joinNames(const std::vector<std::string>& names);

}  // namespace xpersif
