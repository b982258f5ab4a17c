/**
 * @file experiment_conversions.h
 * @brief Between the cognitive loop's messages (Experiment, ObjectFeatures, FeatureVector, ExperimentRecord,
 *        Notion) and the ROS-free core types of experiment.h and knowledge_base.h, with the checks a message
 *        needs before it may be converted.
 *
 * What survives the trip: of an ObjectFeatures message the core keeps name, position x and y, yaw and the
 * named features (feature_names/feature_values); of a FeatureVector the header stamp and the objects. The rest
 * (pixels, contours, the robot) is what a camera saw, not what an experiment needs, and is not stored.
 */
#pragma once

#include <string>
#include <vector>

#include <geometry_msgs/Pose2D.h>

#include "xpersif/Experiment.h"
#include "xpersif/ExperimentRecord.h"
#include "xpersif/FeatureVector.h"
#include "xpersif/Notion.h"
#include "xpersif/ObjectFeatures.h"
#include "xpersif/core/common/experiment.h"
#include "xpersif/core/kb/knowledge_base.h"

namespace xpersif {

core::Experiment fromMsg(const Experiment& msg);
Experiment toMsg(const core::Experiment& experiment);

/// "" when the message can be converted (finite pose, parallel feature names and values within the caps).
std::string checkObjectFeatures(const std::string& field, const ObjectFeatures& msg);
core::ObjectFeatures fromMsg(const ObjectFeatures& msg);
ObjectFeatures toMsg(const core::ObjectFeatures& object);

/// "" when the message can be converted and the result passes core::checkFeatureVector.
std::string checkFeatureVector(const std::string& field, const FeatureVector& msg);
core::FeatureVector fromMsg(const FeatureVector& msg);
FeatureVector toMsg(const core::FeatureVector& features);

/**
 * The core record of a message: status "done" or "failed" only; predicted_mean and predicted_std both empty
 * (no prediction) or both of 3 finite numbers (std >= 0); every number finite; reason and design within
 * the caps. Throws core::ValidationError naming the field otherwise. The outcome (dx, dy, dyaw) is kept for
 * both statuses; the surprise is stored when a prediction is given. `design` is not part of the core record
 * (see knowledge_base.h) and is not returned by this function.
 */
core::ExperimentRecord fromMsg(const ExperimentRecord& msg);
ExperimentRecord toMsg(const core::ExperimentRecord& record);

Notion toMsg(const core::Notion& notion);
core::Notion fromMsg(const Notion& msg);

/// The object called @p name in @p features, or nullptr.
const ObjectFeatures* findObject(const FeatureVector& features, const std::string& name);

/// Appends the name and the pose (x, y, yaw) of each object of @p features to the parallel @p names and @p poses:
/// the scene as DesignExperiment's scene_objects and scene_poses carry it.
void appendScenePoses(const FeatureVector& features, std::vector<std::string>* names,
                      std::vector<geometry_msgs::Pose2D>* poses);

}  // namespace xpersif
