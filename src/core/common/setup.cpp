#include "xpersif/core/common/setup.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

double heightOf(const Shape& shape) {
  switch (shape.type) {
    case Shape::Type::Box: return shape.box_size.z();
    case Shape::Type::Cylinder: return shape.length;
    case Shape::Type::Sphere: return 2 * shape.radius;
  }
  return 0;
}

// How far a visual reaches horizontally from its node's origin.
double horizontalReach(const Visual& v) {
  const double centre = v.offset.translation().head<2>().norm();
  if (v.shape.type == Shape::Type::Box) return centre + 0.5 * std::hypot(v.shape.box_size.x(), v.shape.box_size.y());
  return centre + v.shape.radius;
}

}  // namespace

SetupCatalogue SetupCatalogue::fromScene(const SceneDescription& scene) {
  SetupCatalogue cat;
  cat.world_file = scene.world_file.empty() ? std::string("the world file") : scene.world_file;
  cat.arena_size_x = scene.arena_size_x;
  cat.arena_size_y = scene.arena_size_y;
  if (!(cat.arena_size_x > 0) || !(cat.arena_size_y > 0)) {
    throw ValidationError("the scene of " + cat.world_file + " gives no arena size; XPERSim describes it");
  }
  if (scene.objects.empty()) {
    throw ValidationError("the scene of " + cat.world_file + " has no objects: there is nothing to experiment with");
  }
  for (const auto& name : scene.objects) {
    const SceneNode* node = scene.findNode(name);
    if (!node || node->visuals.size() != 1) {
      throw ValidationError("the scene of " + cat.world_file + " lists object '" + name +
                            "' but has no node of that name with one visual");
    }
    const Visual& v = node->visuals.front();
    CatalogueObject object{name, v.shape, v.color, Footprint::ofShape(v.shape), heightOf(v.shape)};
    throwIfInvalid(object.footprint.check("object '" + name + "'"));
    cat.objects.push_back(object);
  }
  const SceneNode* root = scene.findNode(scene.robot_root);
  if (scene.robot_root.empty() || !root) {
    throw ValidationError("the scene of " + cat.world_file + " has no robot (robot_root '" + scene.robot_root + "')");
  }
  for (const Visual& v : root->visuals) cat.robot_radius = std::max(cat.robot_radius, horizontalReach(v));
  if (!(cat.robot_radius > 0)) {
    throw ValidationError("the robot's root link '" + scene.robot_root + "' in " + cat.world_file +
                          " has no visual to take its footprint from");
  }
  return cat;
}

SetupCatalogue SetupCatalogue::restrictedTo(const std::vector<std::string>& names, const std::string& field) const {
  if (names.empty()) throw ValidationError(field + " is empty; name at least one object of " + world_file);
  SetupCatalogue out = *this;
  out.objects.clear();
  std::set<std::string> seen;
  for (const auto& name : names) {
    const CatalogueObject* object = find(name);
    if (!object) {
      throw ValidationError(field + " names '" + name + "', which is not an object of " + world_file + " (its objects: " +
                            joined(this->names()) + ")");
    }
    if (!seen.insert(name).second) throw ValidationError(field + " names '" + name + "' twice");
    out.objects.push_back(*object);
  }
  return out;
}

std::vector<std::string> SetupCatalogue::names() const {
  std::vector<std::string> out;
  for (const auto& o : objects) out.push_back(o.name);
  return out;
}

const CatalogueObject* SetupCatalogue::find(const std::string& name) const {
  for (const auto& o : objects) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

double SetupCatalogue::maxPushDistance() const { return 0.25 * std::min(arena_size_x, arena_size_y); }
double SetupCatalogue::minPushDistance() const { return 0.1 * maxPushDistance(); }
double SetupCatalogue::approachStandoff() const { return robot_radius; }

double SetupCatalogue::wallMargin() const {
  double largest = 0;
  for (const auto& o : objects) largest = std::max(largest, o.footprint.circumradius());
  return largest + approachStandoff() + 2 * robot_radius + 0.25 * robot_radius;
}

double SetupCatalogue::objectSpacing() const {
  double largest = 0;
  for (const auto& o : objects) largest = std::max(largest, o.footprint.circumradius());
  return 2 * largest + 2 * robot_radius + 0.25 * robot_radius;
}

void ArenaTidy::stands(const std::string& name, double x, double y) {
  for (auto& [who, where] : standing_) {
    if (who == name) {
      where = {x, y};
      return;
    }
  }
  standing_.push_back({name, {x, y}});
}

std::optional<std::pair<double, double>> ArenaTidy::spotFor(const std::string& name, std::mt19937_64& rng,
                                                            int draws) const {
  std::uniform_real_distribution<double> ux(-hx_, hx_), uy(-hy_, hy_);
  for (int attempt = 0; attempt < draws; ++attempt) {
    const double x = ux(rng), y = uy(rng);
    bool free = true;
    for (const auto& [who, where] : standing_) {
      free = free && (who == name || std::hypot(x - where.first, y - where.second) > spacing_);
    }
    if (free) return std::make_pair(x, y);
  }
  return std::nullopt;
}

std::string SetupCatalogue::checkExperiment(const std::string& field, const Experiment& e) const {
  const CatalogueObject* object = find(e.object);
  if (!object) {
    return field + ".object is '" + e.object + "', which is not an object of " + world_file + " (its objects: " +
           joined(names()) + ")";
  }
  if (std::string p = checkOneOf(field + ".side", e.side, pushSides()); !p.empty()) return p;
  const double max_offset = maxPushOffset(object->footprint, e.side);
  if (std::string p = checkInRange(field + ".offset", e.offset, -max_offset, max_offset); !p.empty()) {
    return p + " (" + e.object + " is " + object->footprint.describe() + ")";
  }
  return checkInRange(field + ".distance", e.distance, minPushDistance(), maxPushDistance());
}

}  // namespace xpersif::core
