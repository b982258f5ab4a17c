/**
 * @file setup_loader.h
 * @brief How a component learns the set-up: it asks XPERSim for its scene (the get_scene operation) and reads
 *        the experimenter's catalogue from it (core::SetupCatalogue), so that every component knows the same
 *        objects, shapes and sizes as the world file, and nothing is configured twice.
 */
#pragma once

#include "xpersif/core/common/parameters.h"

#include <ros/ros.h>

#include "xpersif/core/common/setup.h"

namespace xpersif {

/**
 * @brief The catalogue from XPERSim's scene. The operation is the `scene_service` parameter (searched upwards
 *        from @p private_nh; default "xpersim/get_scene" in @p nh's namespace), waited for up to
 *        `scene_timeout` s (30). The private parameter `~objects`, when set, restricts the catalogue to those
 *        objects (a name the scene lacks is an error naming it and the world file). With no simulator to ask
 *        (a recorded run being replayed), a private `~world` parameter names the world file instead, and the
 *        catalogue is that of the scene XPERSim builds from it.
 * @throws std::runtime_error (or core::ValidationError) with a sentence when the scene cannot be had or used
 */
core::SetupCatalogue loadSetupCatalogue(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);
/// As loadSetupCatalogue, every object of the scene (`~objects` not applied): what a component that considers
/// some objects must still steer clear of.
core::SetupCatalogue loadSceneCatalogue(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);
/// @p catalogue restricted to the private parameter `~objects`, when it is set.
core::SetupCatalogue restrictedToObjectsParameter(core::SetupCatalogue catalogue, const ros::NodeHandle& private_nh);
/// The private parameters loadSetupCatalogue reads (~objects, ~world, ~scene_service, ~scene_timeout).
const core::ParameterTable& setupCatalogueParameters();

}  // namespace xpersif
