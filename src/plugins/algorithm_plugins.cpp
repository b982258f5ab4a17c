/**
 * @file algorithm_plugins.cpp
 * @brief This package's algorithms exported to pluginlib (push_model_plugins.xml, experiment_design_plugins.xml,
 *        plan_search_plugins.xml). The classes live in the ROS-free core and are tested there; this library only
 *        registers them, and is loaded by pluginlib, never linked.
 */
#include <pluginlib/class_list_macros.hpp>

#include "xpersif/core/planning/experiment_design.h"
#include "xpersif/core/learning/gaussian_process_push_model.h"
#include "xpersif/core/planning/learning_progress.h"
#include "xpersif/core/learning/per_object_push_model.h"
#include "xpersif/core/planning/plan_search.h"
#include "xpersif/core/planning/strategic_student.h"
#include "xpersif/core/learning/push_learner.h"

PLUGINLIB_EXPORT_CLASS(xpersif::core::PushLearner, xpersif::core::PushModel)
PLUGINLIB_EXPORT_CLASS(xpersif::core::GaussianProcessPushModel, xpersif::core::PushModel)
PLUGINLIB_EXPORT_CLASS(xpersif::core::PerObjectPushModel, xpersif::core::PushModel)

PLUGINLIB_EXPORT_CLASS(xpersif::core::CuriosityDesign, xpersif::core::ExperimentDesign)
PLUGINLIB_EXPORT_CLASS(xpersif::core::RandomDesign, xpersif::core::ExperimentDesign)
PLUGINLIB_EXPORT_CLASS(xpersif::core::GridDesign, xpersif::core::ExperimentDesign)
PLUGINLIB_EXPORT_CLASS(xpersif::core::LearningProgressDesign, xpersif::core::ExperimentDesign)
PLUGINLIB_EXPORT_CLASS(xpersif::core::ErrorMaxDesign, xpersif::core::ExperimentDesign)
PLUGINLIB_EXPORT_CLASS(xpersif::core::StrategicStudentDesign, xpersif::core::ExperimentDesign)
PLUGINLIB_EXPORT_CLASS(xpersif::core::RoundRobinDesign, xpersif::core::ExperimentDesign)
PLUGINLIB_EXPORT_CLASS(xpersif::core::ReplicateScreeningDesign, xpersif::core::ExperimentDesign)

PLUGINLIB_EXPORT_CLASS(xpersif::core::BreadthFirstSearch, xpersif::core::PlanSearch)
PLUGINLIB_EXPORT_CLASS(xpersif::core::GreedyGoalCountSearch, xpersif::core::PlanSearch)
