/**
 * @file record_conversions.h
 * @brief Between the loop's messages (ExperimentRecord, FeatureVector) and the ROS-free core structs
 *        (core::ExperimentRecord, core::FeatureVector), for the trace tools and for MACHINELEARNING.
 *
 * ObjectFeatures -> core::ObjectFeatures: name, x = position.x, y = position.y, yaw, and extra = the pairs
 * (feature_names[i], feature_values[i]) computed by VISION. A record's outcome is set when its status is
 * "done"; its prediction when predicted_mean and predicted_std both have 3 values; surprise when finite and
 * >= 0 and a prediction exists.
 */
#pragma once

#include "xpersif/ExperimentRecord.h"
#include "xpersif/FeatureVector.h"
#include "xpersif/core/knowledge_base.h"

namespace xpersif::traces {

/// @throws core::ValidationError when feature_names and feature_values differ in length.
core::FeatureVector fromMsg(const xpersif::FeatureVector& msg);
core::ExperimentRecord fromMsg(const xpersif::ExperimentRecord& msg);

xpersif::FeatureVector toMsg(const core::FeatureVector& features);
xpersif::ExperimentRecord toMsg(const core::ExperimentRecord& record);

}  // namespace xpersif::traces
