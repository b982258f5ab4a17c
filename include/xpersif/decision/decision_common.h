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
#include "xpersif/core/common/contract.h"
#include "xpersif/core/common/experiment.h"
#include "xpersif/ros/experiment_conversions.h"

namespace xpersif {

// Messages <-> core structs (Experiment, ObjectFeatures, FeatureVector) and findObject: ros/experiment_conversions.h.

/// A contract as get_contracts sends it. Throws core::ContractError for an unknown kind.
core::Contract fromContractMsg(const Contract& message);

/// Why @p scene cannot be used (more objects than a feature vector may hold, a non-finite pose or feature),
/// or "" (requests that carry a scene: DesignGoal, ChoosePush).
std::string checkScene(const FeatureVector& scene);

/// "[a, b, c]" (contract bindings and messages).
std::string joinNames(const std::vector<std::string>& names);

}  // namespace xpersif
