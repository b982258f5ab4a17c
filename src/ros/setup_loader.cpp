#include "xpersif/ros/setup_loader.h"

#include <stdexcept>

#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/common/validation.h"
#include "xpersif/core/sim/world_spec.h"
#include "xpersif/ros/conversions.h"
#include "xpersif/ros/scene_tracker.h"

namespace xpersif {

core::SetupCatalogue restrictedToObjectsParameter(core::SetupCatalogue catalogue, const ros::NodeHandle& private_nh) {
  std::vector<std::string> objects;
  if (private_nh.getParam("objects", objects)) catalogue = catalogue.restrictedTo(objects, "~objects");
  return catalogue;
}

const core::ParameterTable& setupCatalogueParameters() {
  static const core::ParameterTable table(
      "set-up catalogue",
      {core::namesParameter("objects", {}, 256,
                            "the objects of the scene this component considers (default: every object of the "
                            "scene); a name the world lacks is a configure error"),
       core::textParameter("world", "",
                           "read the objects from this world file instead of XPERSim's scene (no simulator: a bag "
                           "being replayed)"),
       core::textParameter("scene_service", "xpersim/get_scene",
                           "XPERSim's get_scene (also found in a parent namespace)"),
       core::numberParameter("scene_timeout", 30.0, 0.001, 3600.0,
                             "s of wall time to wait for the scene (also found in a parent namespace)")});
  return table;
}

core::SetupCatalogue loadSetupCatalogue(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh) {
  return restrictedToObjectsParameter(loadSceneCatalogue(nh, private_nh), private_nh);
}

core::SetupCatalogue loadSceneCatalogue(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh) {
  const core::ParameterTable& declared = setupCatalogueParameters();
  std::string service = std::get<std::string>(declared.at("scene_service").default_value), key, world_file;
  // No simulator (a bag being replayed): the scene XPERSim would build from the same world file.
  if (private_nh.getParam("world", world_file)) {
    try {
      return core::SetupCatalogue::fromScene(core::PhysicsWorld(core::loadWorldFile(world_file)).scene());
    } catch (const core::WorldError& e) {
      throw std::runtime_error(std::string("~world: ") + e.what());
    }
  }
  double timeout = std::get<double>(declared.at("scene_timeout").default_value);
  if (private_nh.searchParam("scene_service", key)) private_nh.getParam(key, service);
  if (private_nh.searchParam("scene_timeout", key)) private_nh.getParam(key, timeout);
  core::throwIfInvalid(core::checkParameter(declared.at("scene_timeout"), timeout));
  service = nh.resolveName(service);
  const xpersif::Scene scene = fetchScene(service, timeout, "; the objects and the arena are read from it");
  return core::SetupCatalogue::fromScene(fromSceneMsg(scene));
}

}  // namespace xpersif
