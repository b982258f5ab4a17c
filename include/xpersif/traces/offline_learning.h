/**
 * @file offline_learning.h
 * @brief MACHINELEARNING trained from recorded bags instead of a live run: the ExperimentRecords of the bags
 *        in the order they were recorded, turned into samples by core::trainFromRecords (the same rule as
 *        live training, see core/experiment_samples.h), so the model equals the live one.
 */
#pragma once

#include <string>
#include <vector>

#include "xpersif/core/evaluation/experiment_samples.h"
#include "xpersif/traces/bag_tools.h"

namespace xpersif::traces {

/// @p run_id 0: every record; else only that run's. @throws BagError for unreadable bags
core::OfflineTrainingReport trainFromBags(core::PushLearner& learner, const std::vector<std::string>& files,
                                          std::uint64_t run_id = 0, const std::string& topic = kExperimentsTopic);

}  // namespace xpersif::traces
