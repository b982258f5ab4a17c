/**
 * @file setup.h
 * @brief The experimenter's catalogue of the set-up, read from XPERSim's scene description: the arena, the
 *        robot's footprint and the objects (names, shapes, sizes, colours). Masses, frictions and poses are not
 *        in it: the loop must learn them. Every limit of the experiment space comes from here, derived from
 *        each object's geometry, the robot's footprint and the arena, so that any world file works. ROS-free.
 */
#pragma once

#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "xpersif/core/common/experiment.h"
#include "xpersif/core/common/footprint.h"
#include "xpersif/core/common/scene.h"

namespace xpersif::core {

/// One object of the catalogue.
struct CatalogueObject {
  std::string name;
  Shape shape;  ///< as the scene describes it (a cylinder stands upright)
  Rgba color;
  Footprint footprint;
  double height = 0;  ///< m
};

struct SetupCatalogue {
  std::string world_file;  ///< where the catalogue came from, for sentences
  double arena_size_x = 0, arena_size_y = 0;  ///< inner extents, centred on the world origin
  double robot_radius = 0;  ///< the robot's footprint as a disc around its root, m
  std::vector<CatalogueObject> objects;  ///< in world-file order

  /**
   * @brief From a scene description: its `objects` with their single visual, the robot's footprint from the
   *        visuals of its root link. @throws ValidationError when the scene names no object, an object that is
   *        not a node with one visual, or has no robot.
   */
  static SetupCatalogue fromScene(const SceneDescription& scene);

  /// Only the objects named in @p names (in that order). @throws ValidationError naming @p field, the unknown
  /// object and the world file, when a name is not in the catalogue or appears twice, or @p names is empty.
  SetupCatalogue restrictedTo(const std::vector<std::string>& names, const std::string& field) const;

  std::vector<std::string> names() const;
  /// The object called @p name, or nullptr.
  const CatalogueObject* find(const std::string& name) const;

  /// The longest push after contact: a quarter of the arena's smaller extent, so a push stays well inside it.
  double maxPushDistance() const;
  /// The shortest push worth making: a tenth of the longest.
  double minPushDistance() const;
  /// Gap between the robot's front and an object's face at the approach spot: the robot's radius (room to
  /// turn in place before closing in), m.
  double approachStandoff() const;
  /// Distance from the walls at which every face of every object stays pushable: the largest object's
  /// circumradius, plus the approach stand-off and the robot's diameter, plus a margin of half the robot's radius.
  double wallMargin() const;
  /// Centre-to-centre distance between objects at which the robot fits between them to reach every face.
  double objectSpacing() const;

  /// "" when @p experiment pushes a catalogue object on a known side, with |offset| <= maxPushOffset and the
  /// distance in [minPushDistance, maxPushDistance]; else a sentence naming @p field and the bound.
  std::string checkExperiment(const std::string& field, const Experiment& experiment) const;
};

/// Where LOOPMODEL's tidy may put objects back, as an experimenter would: a spot within ±hx, ±hy of the arena's
/// centre, farther than `spacing` from everything that stands in the arena. An object not yet moved still stands
/// where it is, even when it is to be moved next (two misplaced objects once were each put beside the other's old
/// spot, and pushing either was refused from then on). ROS-free bookkeeping; the caller moves the bodies.
class ArenaTidy {
 public:
  ArenaTidy(double hx, double hy, double spacing) : hx_(hx), hy_(hy), spacing_(spacing) {}
  /// @p name (an object, or the robot) stands at (@p x, @p y); again for the same name: it was moved there.
  void stands(const std::string& name, double x, double y);
  /// A free spot for @p name (its own place does not count) among @p draws uniform draws from @p rng, or nothing
  /// when none is free: an arena too small for the spacing and the objects in it.
  std::optional<std::pair<double, double>> spotFor(const std::string& name, std::mt19937_64& rng, int draws = 200) const;

 private:
  double hx_, hy_, spacing_;
  std::vector<std::pair<std::string, std::pair<double, double>>> standing_;  // in the order first heard
};

}  // namespace xpersif::core
