/**
 * @file goal_choice.h
 * @brief Reaching a goal with a learned push model (GOALDESIGN's choices, ROS-free): where a push leaves the
 *        object, which push to make, and how closely the model predicts an object's pushes.
 */
#pragma once

#include <string>
#include <vector>

#include "xpersif/core/common/experiment.h"
#include "xpersif/core/common/pose2d.h"
#include "xpersif/core/learning/push_model.h"

namespace xpersif::core {

/// Where the object's centre ends, in the world, when it moves by @p outcome (push frame) after a push on
/// @p side while its perceived pose is @p object (the push direction is its yaw plus pushAngleInObject(side)).
Pose2D predictedEnd(const ObjectFeatures& object, const std::string& side, const Outcome& outcome);

/// A chosen push and what the model expects of it.
struct PushChoice {
  Experiment experiment;
  double expected_error = 0;  ///< m from the target to the predicted end
  double spread = 0;          ///< m, sqrt(std_dx^2 + std_dy^2) of the end
};

/**
 * @brief The candidate with the least expected squared distance to the target (tx, ty): the predicted end's
 *        distance squared plus @p uncertainty_weight times the variance of the end (std_dx^2 + std_dy^2, the
 *        trace of the outcome's covariance, the same in the push frame as in the world). Ties: the first.
 * Throws ValidationError for no candidates or a negative or non-finite weight; the model's predict() throws for
 * inputs it cannot use.
 */
PushChoice bestPush(const PushModel& model, const ObjectFeatures& object, double tx, double ty,
                    const std::vector<Experiment>& candidates, double uncertainty_weight);

/// How closely @p model predicts where @p object ends: the median over @p pushes of the end's spread (m);
/// +infinity for no pushes.
double predictedSpread(const PushModel& model, const ObjectFeatures& object, const std::vector<Experiment>& pushes);

}  // namespace xpersif::core
