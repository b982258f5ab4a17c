#include "xpersif/core/sim/world_spec.h"

#include <Eigen/Eigenvalues>
#include <opencv2/aruco.hpp>
#include <urdf_parser/urdf_parser.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "xpersif/core/common/package_path.h"
#include "xpersif/core/common/validation.h"

namespace xpersif::core {

Eigen::Quaterniond quaternionFromRpy(double roll, double pitch, double yaw) {
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
}

double yawOf(const Eigen::Isometry3d& pose) {
  const Eigen::Matrix3d r = pose.rotation();
  return std::atan2(r(1, 0), r(0, 0));
}

std::vector<Visual> ArenaSpec::walls() const {
  const double t = wall_thickness, h = wall_height;
  const double hx = size_x / 2 + t / 2, hy = size_y / 2 + t / 2;
  const double boxes[4][4] = {{hx, 0, t, size_y + 2 * t}, {-hx, 0, t, size_y + 2 * t}, {0, hy, size_x, t}, {0, -hy, size_x, t}};
  std::vector<Visual> out;
  for (const auto& b : boxes) {
    Visual wall;
    wall.shape.box_size = Eigen::Vector3d(b[2], b[3], h);
    wall.offset.translation() = Eigen::Vector3d(b[0], b[1], h / 2);
    wall.color = wall_color;
    out.push_back(wall);
  }
  return out;
}

std::vector<std::string> WorldSpec::bodyNames() const {
  std::vector<std::string> names{robot.name};
  for (const auto& o : objects) names.push_back(o.name);
  return names;
}

namespace {

// ---- URDF ------------------------------------------------------------------------------------------

Eigen::Isometry3d toIsometry(const urdf::Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  t.linear() = Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z).normalized().toRotationMatrix();
  return t;
}

Shape toShape(const urdf::GeometrySharedPtr& geometry, const std::string& where) {
  Shape shape;
  if (!geometry) throw WorldError(where + " has no geometry");
  switch (geometry->type) {
    case urdf::Geometry::BOX: {
      auto box = std::static_pointer_cast<urdf::Box>(geometry);
      shape.type = Shape::Type::Box;
      shape.box_size = Eigen::Vector3d(box->dim.x, box->dim.y, box->dim.z);
      break;
    }
    case urdf::Geometry::CYLINDER: {
      auto cylinder = std::static_pointer_cast<urdf::Cylinder>(geometry);
      shape.type = Shape::Type::Cylinder;
      shape.radius = cylinder->radius;
      shape.length = cylinder->length;
      break;
    }
    case urdf::Geometry::SPHERE:
      shape.type = Shape::Type::Sphere;
      shape.radius = std::static_pointer_cast<urdf::Sphere>(geometry)->radius;
      break;
    default:
      throw WorldError(where + " uses a mesh; XPERSim simulates boxes, cylinders and spheres");
  }
  return shape;
}

/// A link's mass must be finite and not negative; a given inertia matrix (not all zero, which means "take it
/// from the collision shape") must be finite and positive definite, or ODE cannot integrate the body.
void checkInertial(const LinkSpec& link, const std::string& where) {
  if (!std::isfinite(link.mass) || link.mass < 0) {
    throw WorldError(where + " has mass " + std::to_string(link.mass) + "; it must be a finite number, zero or more");
  }
  if (!link.inertia.allFinite()) throw WorldError(where + " has an inertia matrix that is not finite");
  if (link.mass > 0 && !link.inertia.isZero(0)) {
    const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(link.inertia).eigenvalues().minCoeff();
    if (!(smallest > 0)) {
      throw WorldError(where + " has an inertia matrix that is not positive definite (smallest eigenvalue " +
                       std::to_string(smallest) + ")");
    }
  }
}

void addLink(const urdf::ModelInterface& model, const urdf::LinkConstSharedPtr& link, RobotSpec& robot,
             const std::string& source) {
  LinkSpec spec;
  spec.name = link->name;
  const std::string where = source + ": link '" + link->name + "'";
  if (auto joint = link->parent_joint) {
    spec.parent = joint->parent_link_name;
    spec.joint = joint->name;
    spec.parent_from_link = toIsometry(joint->parent_to_joint_origin_transform);
    switch (joint->type) {
      case urdf::Joint::FIXED: spec.joint_type = LinkSpec::JointType::Fixed; break;
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS: spec.joint_type = LinkSpec::JointType::Revolute; break;
      default:
        throw WorldError(source + ": joint '" + joint->name + "' is neither fixed, revolute nor continuous");
    }
    spec.axis = Eigen::Vector3d(joint->axis.x, joint->axis.y, joint->axis.z);
    if (spec.joint_type == LinkSpec::JointType::Revolute && spec.axis.norm() < 1e-9) {
      throw WorldError(source + ": joint '" + joint->name + "' has a zero axis");
    }
  }
  if (link->inertial) {
    spec.mass = link->inertial->mass;
    const auto& o = link->inertial->origin.position;
    spec.com = Eigen::Vector3d(o.x, o.y, o.z);
    const auto& i = *link->inertial;
    spec.inertia << i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz;
    checkInertial(spec, where);
  }
  if (spec.joint_type != LinkSpec::JointType::Fixed && !(spec.mass > 0)) {
    throw WorldError(where + " moves on its own but has no mass; give it an <inertial>");
  }
  for (const auto& c : link->collision_array) {
    Visual v;
    v.shape = toShape(c->geometry, where + " collision");
    v.offset = toIsometry(c->origin);
    spec.collisions.push_back(v);
  }
  for (const auto& vis : link->visual_array) {
    Visual v;
    v.shape = toShape(vis->geometry, where + " visual");
    v.offset = toIsometry(vis->origin);
    const urdf::MaterialSharedPtr material = vis->material ? vis->material : model.getMaterial(vis->material_name);
    if (material) v.color = {material->color.r, material->color.g, material->color.b, material->color.a};
    spec.visuals.push_back(v);
  }
  robot.links.push_back(spec);
  for (const auto& child : link->child_links) addLink(model, child, robot, source);
}

// ---- YAML: every value is read through these helpers, so that every refusal is one sentence
//      "<file>: <field> <what is wrong> (line L, column C)" ---------------------------------------------

/// " (line L, column C)" of a node in the world file, when yaml-cpp knows it.
std::string at(const YAML::Node& node) {
  if (!node.IsDefined()) return "";
  const YAML::Mark mark = node.Mark();
  if (mark.line < 0) return "";
  return " (line " + std::to_string(mark.line + 1) + ", column " + std::to_string(mark.column + 1) + ")";
}

/// How a value reads in a sentence: its text, or what kind of thing it is.
std::string shown(const YAML::Node& node) {
  if (!node.IsDefined()) return "missing";
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  if (node.IsMap()) return "a mapping";
  return "empty";
}

/// @p field is "<file>: <path>", e.g. "worlds/x.yaml: arena.size[1]".
[[noreturn]] void fail(const std::string& field, const YAML::Node& node, const std::string& reason) {
  throw WorldError(field + " " + reason + at(node));
}

std::string metres(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v;
  return s.str();
}

double asNumber(const YAML::Node& value, const std::string& field) {
  double v = 0;
  if (!value.IsScalar() || !YAML::convert<double>::decode(value, v)) {
    fail(field, value, "is " + shown(value) + "; it must be a number");
  }
  if (!std::isfinite(v)) fail(field, value, "is " + shown(value) + "; it must be a finite number");
  return v;
}

double asPositive(const YAML::Node& value, const std::string& field) {
  const double v = asNumber(value, field);
  if (!(v > 0)) fail(field, value, "is " + shown(value) + "; it must be greater than zero");
  return v;
}

double asInRange(const YAML::Node& value, const std::string& field, double lo, double hi) {
  const double v = asNumber(value, field);
  if (!(v >= lo && v <= hi)) {
    fail(field, value, "is " + shown(value) + "; it must lie in " + metres(lo) + ".." + metres(hi));
  }
  return v;
}

long long asWhole(const YAML::Node& value, const std::string& field, long long lo, long long hi) {
  long long v = 0;
  if (!value.IsScalar() || !YAML::convert<long long>::decode(value, v)) {
    fail(field, value, "is " + shown(value) + "; it must be a whole number");
  }
  if (v < lo || v > hi) {
    fail(field, value, "is " + shown(value) + "; it must lie in " + std::to_string(lo) + ".." + std::to_string(hi));
  }
  return v;
}

std::string asText(const YAML::Node& value, const std::string& field) {
  if (!value.IsScalar()) fail(field, value, "is " + shown(value) + "; it must be a text");
  return value.Scalar();
}

std::string asIdentifier(const YAML::Node& value, const std::string& field) {
  const std::string text = value ? asText(value, field) : "";
  const std::string problem = checkIdentifier(field, text);
  if (!problem.empty()) throw WorldError(problem + at(value));
  return text;
}

/// Optional keys of a mapping: the fallback when absent. @p where is "<file>: <path>".
double number(const YAML::Node& map, const std::string& key, double fallback, const std::string& where) {
  const YAML::Node v = map[key];
  return v ? asNumber(v, where + "." + key) : fallback;
}

double positive(const YAML::Node& map, const std::string& key, double fallback, const std::string& where) {
  const YAML::Node v = map[key];
  return v ? asPositive(v, where + "." + key) : fallback;
}

long long whole(const YAML::Node& map, const std::string& key, long long fallback, long long lo, long long hi,
                const std::string& where) {
  const YAML::Node v = map[key];
  return v ? asWhole(v, where + "." + key, lo, hi) : fallback;
}

std::string text(const YAML::Node& map, const std::string& key, const std::string& fallback, const std::string& where) {
  const YAML::Node v = map[key];
  return v ? asText(v, where + "." + key) : fallback;
}

std::vector<std::string> texts(const YAML::Node& map, const std::string& key, const std::string& where) {
  const YAML::Node v = map[key];
  std::vector<std::string> out;
  if (!v) return out;
  if (!v.IsSequence()) fail(where + "." + key, v, "is " + shown(v) + "; it must be a list of names");
  for (std::size_t i = 0; i < v.size(); ++i) out.push_back(asText(v[i], where + "." + key + "[" + std::to_string(i) + "]"));
  return out;
}

Rgba color(const YAML::Node& map, const std::string& key, const Rgba& fallback, const std::string& where) {
  const YAML::Node value = map[key];
  if (!value) return fallback;
  const std::string field = where + "." + key;
  if (!value.IsSequence() || (value.size() != 3 && value.size() != 4)) {
    fail(field, value, "is " + shown(value) + "; it must be [r, g, b] or [r, g, b, a] in 0..1");
  }
  float c[4] = {0, 0, 0, 1};
  for (std::size_t i = 0; i < value.size(); ++i) {
    c[i] = static_cast<float>(asInRange(value[i], field + "[" + std::to_string(i) + "]", 0, 1));
  }
  return {c[0], c[1], c[2], c[3]};
}

void rejectUnknownKeys(const YAML::Node& map, const std::set<std::string>& known, const std::string& where) {
  if (!map.IsMap()) fail(where, map, "is " + shown(map) + "; it must be a mapping");
  for (const auto& entry : map) {
    const std::string key = asText(entry.first, where + " key");
    if (!known.count(key)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      fail(where, entry.first, "has unknown key '" + key + "'; known keys: " + list);
    }
  }
}

Eigen::Isometry3d pose(const YAML::Node& map, const std::string& where) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  const YAML::Node p = map["pose"];
  if (!p) return t;
  const std::string here = where + ".pose";
  rejectUnknownKeys(p, {"x", "y", "z", "roll", "pitch", "yaw"}, here);
  t.translation() = Eigen::Vector3d(number(p, "x", 0, here), number(p, "y", 0, here), number(p, "z", 0, here));
  t.linear() = quaternionFromRpy(number(p, "roll", 0, here), number(p, "pitch", 0, here), number(p, "yaw", 0, here))
                   .toRotationMatrix();
  return t;
}

std::string readFile(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw WorldError("cannot read " + what + " '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

bool isLink(const RobotSpec& robot, const std::string& name) {
  for (const auto& l : robot.links) {
    if (l.name == name) return true;
  }
  return false;
}

// ---- The robot's wheels: what the embodiment needs to drive it as a differential drive ---------------

void deriveWheels(RobotSpec& robot, const std::string& world_field, const std::string& urdf) {
  if (robot.left_wheel_joint == robot.right_wheel_joint) {
    throw WorldError(world_field + ".left_wheel_joint and right_wheel_joint both name '" + robot.left_wheel_joint +
                     "'; a differential drive needs two different wheel joints");
  }
  auto wheel = [&](const std::string& joint, const std::string& key) -> const LinkSpec& {
    for (const auto& l : robot.links) {
      if (l.joint != joint) continue;
      if (l.joint_type != LinkSpec::JointType::Revolute) {
        throw WorldError(urdf + ": wheel joint '" + joint + "' must be revolute or continuous");
      }
      if (l.parent != robot.links[0].name) {
        throw WorldError(urdf + ": wheel link '" + l.name + "' must hang from the root link '" + robot.links[0].name + "'");
      }
      if (l.collisions.empty() || l.collisions[0].shape.type == Shape::Type::Box) {
        throw WorldError(urdf + ": wheel link '" + l.name + "' needs a sphere or cylinder collision shape (its tyre)");
      }
      return l;
    }
    throw WorldError(world_field + "." + key + " names '" + joint + "', which is not a joint of " + urdf);
  };
  const LinkSpec& left = wheel(robot.left_wheel_joint, "left_wheel_joint");
  const LinkSpec& right = wheel(robot.right_wheel_joint, "right_wheel_joint");
  const Eigen::Vector3d left_axis = (left.parent_from_link.rotation() * left.axis).normalized();
  const Eigen::Vector3d right_axis = (right.parent_from_link.rotation() * right.axis).normalized();
  if (left_axis.cross(right_axis).norm() > 0.01) {
    throw WorldError(urdf + ": wheel joints '" + left.joint + "' and '" + right.joint +
                     "' turn about axes that are not parallel, so the robot cannot drive straight");
  }
  robot.wheel_radius = left.collisions[0].shape.radius;
  robot.wheel_separation = (left.parent_from_link.translation() - right.parent_from_link.translation()).norm();
  if (std::abs(right.collisions[0].shape.radius - robot.wheel_radius) > 0.01 * robot.wheel_radius) {
    throw WorldError(urdf + ": wheel links '" + left.name + "' and '" + right.name + "' have different radii");
  }
  if (!(robot.wheel_radius > 0) || !(robot.wheel_separation > 0)) {
    throw WorldError(urdf + ": wheels need a positive radius and distinct positions");
  }
}

// ---- Horizontal footprints: where things stand on the floor, to keep them apart and inside -----------

/// A disc, or a rectangle turned by yaw, on the floor plane.
struct Footprint {
  bool disc = true;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius = 0;               ///< disc
  Eigen::Vector2d half{0, 0};      ///< rectangle: half extents along its own axes
  double yaw = 0;                  ///< rectangle: angle of its first axis
};

constexpr double kOverlapTolerance = 0.001;  ///< m; touching is fine, 1 mm of interpenetration too

/// The footprint of @p shape at @p pose: exact for upright or lying boxes and cylinders and for spheres, a
/// circumscribed disc for anything tilted.
Footprint footprintOf(const Shape& shape, const Eigen::Isometry3d& pose) {
  Footprint f;
  f.centre = pose.translation().head<2>();
  const Eigen::Matrix3d r = pose.rotation();
  const auto vertical = [&](int axis) { return std::abs(r(2, axis)) > 0.999; };
  const auto rectangle = [&](int axis_a, double half_a, double half_b) {
    f.disc = false;
    f.half = Eigen::Vector2d(half_a, half_b);
    f.yaw = std::atan2(r(1, axis_a), r(0, axis_a));
  };
  switch (shape.type) {
    case Shape::Type::Sphere: f.radius = shape.radius; break;
    case Shape::Type::Cylinder:
      if (vertical(2)) {
        f.radius = shape.radius;
      } else if (std::abs(r(2, 2)) < 0.001) {
        rectangle(2, shape.length / 2, shape.radius);
      } else {
        f.radius = std::hypot(shape.radius, shape.length / 2);
      }
      break;
    case Shape::Type::Box: {
      const Eigen::Vector3d h = shape.box_size / 2;
      f.radius = h.norm();
      for (int up = 0; up < 3; ++up) {
        if (vertical(up)) rectangle((up + 1) % 3, h((up + 1) % 3), h((up + 2) % 3));
      }
      break;
    }
  }
  return f;
}

Eigen::Vector2d axisOf(const Footprint& f, int i) {
  const double a = f.yaw + (i == 0 ? 0 : M_PI / 2);
  return Eigen::Vector2d(std::cos(a), std::sin(a));
}

/// Half the footprint's width along the unit direction @p n.
double reach(const Footprint& f, const Eigen::Vector2d& n) {
  if (f.disc) return f.radius;
  return f.half.x() * std::abs(axisOf(f, 0).dot(n)) + f.half.y() * std::abs(axisOf(f, 1).dot(n));
}

bool overlap(const Footprint& a, const Footprint& b) {
  const Eigen::Vector2d d = b.centre - a.centre;
  if (a.disc && b.disc) return d.norm() < a.radius + b.radius - kOverlapTolerance;
  if (a.disc != b.disc) {  // the disc's centre against the nearest point of the rectangle
    const Footprint& rect = a.disc ? b : a;
    const Footprint& disc = a.disc ? a : b;
    const Eigen::Vector2d p = disc.centre - rect.centre;
    const Eigen::Vector2d local(axisOf(rect, 0).dot(p), axisOf(rect, 1).dot(p));
    const Eigen::Vector2d nearest = local.cwiseMax(-rect.half).cwiseMin(rect.half);
    return (local - nearest).norm() < disc.radius - kOverlapTolerance;
  }
  for (const Footprint* f : {&a, &b}) {  // two rectangles: separating axis test
    for (int i = 0; i < 2; ++i) {
      const Eigen::Vector2d n = axisOf(*f, i);
      if (std::abs(d.dot(n)) >= reach(a, n) + reach(b, n) - kOverlapTolerance) return false;
    }
  }
  return true;
}

bool insideArena(const Footprint& f, const ArenaSpec& arena) {
  return std::abs(f.centre.x()) + reach(f, Eigen::Vector2d::UnitX()) <= arena.size_x / 2 + kOverlapTolerance &&
         std::abs(f.centre.y()) + reach(f, Eigen::Vector2d::UnitY()) <= arena.size_y / 2 + kOverlapTolerance;
}

/// The robot's collision shapes on the floor at its start pose.
std::vector<Footprint> robotFootprint(const RobotSpec& robot) {
  std::map<std::string, Eigen::Isometry3d> world_from_link;
  std::vector<Footprint> out;
  for (const auto& link : robot.links) {
    const Eigen::Isometry3d t = link.parent.empty() ? robot.pose : world_from_link.at(link.parent) * link.parent_from_link;
    world_from_link[link.name] = t;
    for (const auto& c : link.collisions) out.push_back(footprintOf(c.shape, t * c.offset));
  }
  return out;
}

/// Every object inside the arena, clear of the robot's start footprint and of every other object.
void checkPlacement(const WorldSpec& world, const YAML::Node& objects) {
  const std::string& source = world.source;
  const std::vector<Footprint> robot = robotFootprint(world.robot);
  for (const Footprint& part : robot) {
    if (!insideArena(part, world.arena)) {
      throw WorldError(source + ": robot.pose puts the robot (partly) outside the " + metres(world.arena.size_x) + " x " +
                       metres(world.arena.size_y) + " m arena");
    }
  }
  std::vector<Footprint> placed;
  for (std::size_t i = 0; i < world.objects.size(); ++i) {
    const ObjectSpec& o = world.objects[i];
    const std::string field = source + ": objects[" + std::to_string(i) + "] ('" + o.name + "')";
    const Footprint f = footprintOf(o.shape, o.pose);
    if (!insideArena(f, world.arena)) {
      fail(field, objects[i], "at (" + metres(f.centre.x()) + ", " + metres(f.centre.y()) + ") reaches outside the " +
                                  metres(world.arena.size_x) + " x " + metres(world.arena.size_y) + " m arena");
    }
    for (const Footprint& part : robot) {
      if (overlap(f, part)) fail(field, objects[i], "overlaps the robot at its start pose (robot.pose)");
    }
    for (std::size_t j = 0; j < placed.size(); ++j) {
      if (overlap(f, placed[j])) {
        fail(field, objects[i], "overlaps objects[" + std::to_string(j) + "] ('" + world.objects[j].name + "')");
      }
    }
    placed.push_back(f);
  }
}

// ---- The sections of a world file --------------------------------------------------------------------

void parsePhysics(const YAML::Node& p, const std::string& w, PhysicsSpec& physics) {
  rejectUnknownKeys(p, {"step", "gravity", "seed", "iterations", "max_speed", "contact_episode_gap", "friction_model"}, w);
  physics.step = positive(p, "step", physics.step, w);
  if (physics.step > 0.05) fail(w + ".step", p["step"], "is " + shown(p["step"]) + "; it must be at most 0.05 s for stable contacts");
  physics.gravity = number(p, "gravity", physics.gravity, w);
  physics.seed = static_cast<unsigned long>(whole(p, "seed", static_cast<long long>(physics.seed), 0, 4294967295LL, w));
  physics.iterations = static_cast<int>(whole(p, "iterations", physics.iterations, 1, 1000, w));
  physics.max_speed = positive(p, "max_speed", physics.max_speed, w);
  physics.contact_episode_gap = positive(p, "contact_episode_gap", physics.contact_episode_gap, w);
  const std::string model = text(p, "friction_model", "coulomb", w);
  if (model != "coulomb" && model != "pyramid") {
    fail(w + ".friction_model", p["friction_model"], "is '" + model + "'; it must be coulomb or pyramid");
  }
  physics.friction_model = model == "coulomb" ? PhysicsSpec::FrictionModel::Coulomb : PhysicsSpec::FrictionModel::Pyramid;
}

void parseArena(const YAML::Node& a, const std::string& w, ArenaSpec& arena) {
  rejectUnknownKeys(a, {"size", "wall_height", "wall_thickness", "wall_color", "floor_color"}, w);
  if (const YAML::Node size = a["size"]) {
    if (!size.IsSequence() || size.size() != 2) fail(w + ".size", size, "is " + shown(size) + "; it must be [x, y]");
    arena.size_x = asInRange(size[0], w + ".size[0]", 0.1, 1000);
    arena.size_y = asInRange(size[1], w + ".size[1]", 0.1, 1000);
  }
  arena.wall_height = positive(a, "wall_height", arena.wall_height, w);
  arena.wall_thickness = positive(a, "wall_thickness", arena.wall_thickness, w);
  arena.wall_color = color(a, "wall_color", arena.wall_color, w);
  arena.floor_color = color(a, "floor_color", arena.floor_color, w);
}

/// `fiducial: {dictionary: 4x4_50, id: 0, size: 0.04, pose: {x, y, yaw}}`: an ArUco marker on the robot's top.
void parseFiducial(const YAML::Node& f, const std::string& w, RobotSpec& robot) {
  if (!f.IsMap()) fail(w, f, "must be a map such as {dictionary: 4x4_50, id: 0, size: 0.04}");
  rejectUnknownKeys(f, {"dictionary", "id", "size", "pose"}, w);
  RobotSpec::Fiducial& fiducial = robot.fiducial;
  fiducial.dictionary = text(f, "dictionary", "4x4_50", w);
  const int code = arucoDictionaryCode(fiducial.dictionary);
  if (code < 0) {
    std::string names;
    for (const auto& n : arucoDictionaryNames()) names += (names.empty() ? "" : ", ") + n;
    fail(w + ".dictionary", f["dictionary"], "is not an ArUco dictionary; known: " + names);
  }
  const int markers = cv::aruco::getPredefinedDictionary(code)->bytesList.rows;
  fiducial.id = static_cast<int>(whole(f, "id", 0, 0, markers - 1, w));
  if (!f["size"]) fail(w, f, "needs 'size', the side of the marker's black square in metres");
  fiducial.size = asInRange(f["size"], w + ".size", 0.001, 1.0);
  fiducial.offset = pose(f, w);
  const double yaw = yawOf(fiducial.offset);
  fiducial.offset = Eigen::Translation3d(fiducial.offset.translation().x(), fiducial.offset.translation().y(), 0) *
                    Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
}

RobotSpec parseRobot(const YAML::Node& r, const std::string& w, const std::string& base_dir) {
  rejectUnknownKeys(r, {"urdf", "pose", "left_wheel_joint", "right_wheel_joint", "max_wheel_speed", "max_wheel_torque",
                        "wheel_friction", "body_friction", "ir_sensors", "ir_range", "heading_marker", "fiducial"}, w);
  const std::string urdf_file = text(r, "urdf", "", w);
  if (urdf_file.empty()) fail(w, r, "needs 'urdf', the robot's URDF file");
  std::string urdf_path;
  try {
    urdf_path = resolveNamedFile(urdf_file, base_dir);
  } catch (const std::invalid_argument& e) {
    fail(w + ".urdf", r["urdf"], e.what());
  }
  RobotSpec robot = parseRobotUrdf(readFile(urdf_path, "URDF"), urdf_path);
  robot.pose = pose(r, w);
  robot.left_wheel_joint = text(r, "left_wheel_joint", "left_wheel_joint", w);
  robot.right_wheel_joint = text(r, "right_wheel_joint", "right_wheel_joint", w);
  robot.max_wheel_speed = positive(r, "max_wheel_speed", robot.max_wheel_speed, w);
  robot.max_wheel_torque = positive(r, "max_wheel_torque", robot.max_wheel_torque, w);
  robot.wheel_friction = positive(r, "wheel_friction", robot.wheel_friction, w);
  robot.body_friction = positive(r, "body_friction", robot.body_friction, w);
  robot.ir_sensors = texts(r, "ir_sensors", w);
  robot.ir_range = positive(r, "ir_range", robot.ir_range, w);
  for (std::size_t i = 0; i < robot.ir_sensors.size(); ++i) {
    if (!isLink(robot, robot.ir_sensors[i])) {
      fail(w + ".ir_sensors[" + std::to_string(i) + "]", r["ir_sensors"][i],
           "names '" + robot.ir_sensors[i] + "', which is not a link of " + urdf_path);
    }
  }
  robot.heading_marker = text(r, "heading_marker", "", w);
  if (!robot.heading_marker.empty() && !isLink(robot, robot.heading_marker)) {
    fail(w + ".heading_marker", r["heading_marker"], "names '" + robot.heading_marker + "', which is not a link of " + urdf_path);
  }
  if (r["fiducial"]) parseFiducial(r["fiducial"], w + ".fiducial", robot);
  deriveWheels(robot, w, urdf_path);
  return robot;
}

/// A box's size: one edge length (a cube) or [x, y, z].
Eigen::Vector3d boxSize(const YAML::Node& o, const std::string& w) {
  const YAML::Node size = o["size"];
  if (!size) return Eigen::Vector3d::Constant(0.04);
  if (size.IsSequence()) {
    if (size.size() != 3) fail(w + ".size", size, "is a list of " + std::to_string(size.size()) + "; it must be an edge length or [x, y, z]");
    Eigen::Vector3d s;
    for (int i = 0; i < 3; ++i) s(i) = asPositive(size[i], w + ".size[" + std::to_string(i) + "]");
    return s;
  }
  return Eigen::Vector3d::Constant(asPositive(size, w + ".size"));
}

/// `friction`: one number, or [along x, along y] in the object's frame; `friction_redraw`: [min, max].
void parseFriction(const YAML::Node& o, const std::string& w, ObjectSpec& object) {
  const YAML::Node f = o["friction"];
  if (f && f.IsSequence()) {
    if (f.size() != 2) {
      fail(w + ".friction", f, "is a list of " + std::to_string(f.size()) +
                                   "; it must be one number or [along x, along y] in the object's frame");
    }
    object.friction = asPositive(f[0], w + ".friction[0]");
    object.friction_y = asPositive(f[1], w + ".friction[1]");
    if (object.shape.type == Shape::Type::Sphere && object.anisotropic()) {
      fail(w + ".friction", f, "differs along x and y on a sphere, which rolls and has no fixed axes on the floor; give one number");
    }
  } else {
    object.friction = object.friction_y = positive(o, "friction", object.friction, w);
  }
  const YAML::Node r = o["friction_redraw"];
  if (!r) return;
  const std::string field = w + ".friction_redraw";
  if (!r.IsSequence() || r.size() != 2) fail(field, r, "is " + shown(r) + "; it must be [min, max], the range the friction is drawn from");
  object.friction_redraw_min = asPositive(r[0], field + "[0]");
  object.friction_redraw_max = asPositive(r[1], field + "[1]");
  if (object.friction_redraw_min > object.friction_redraw_max) {
    fail(field, r, "is [" + metres(object.friction_redraw_min) + ", " + metres(object.friction_redraw_max) +
                       "]; its min must not exceed its max");
  }
  if (object.anisotropic()) {
    fail(field, r, "is given with a friction that differs along x and y; a redrawn friction is one number for "
                   "every direction, so give friction as one number");
  }
}

ObjectSpec parseObject(const YAML::Node& o, const std::string& w, std::set<std::string>& names) {
  ObjectSpec object;
  if (!o.IsMap()) fail(w, o, "is " + shown(o) + "; it must be a mapping");
  if (!o["name"]) fail(w, o, "has no name");
  object.name = asIdentifier(o["name"], w + ".name");
  if (!names.insert(object.name).second) {
    fail(w + ".name", o["name"], "'" + object.name + "' is already taken (by the robot, one of its links or another object)");
  }
  const std::set<std::string> common{"name", "shape", "mass", "friction", "friction_redraw", "color", "pose"};
  const std::string shape = text(o, "shape", "box", w);
  std::set<std::string> known = common;
  if (shape == "box") {
    known.insert("size");
    rejectUnknownKeys(o, known, w + " (a box)");
    object.shape.box_size = boxSize(o, w);
  } else if (shape == "cylinder" || shape == "sphere") {
    object.shape.type = shape == "cylinder" ? Shape::Type::Cylinder : Shape::Type::Sphere;
    known.insert("radius");
    if (shape == "cylinder") known.insert("length");
    rejectUnknownKeys(o, known, w + " (a " + shape + ")");
    object.shape.radius = positive(o, "radius", 0.02, w);
    object.shape.length = positive(o, "length", 0.04, w);
  } else {
    fail(w + ".shape", o["shape"], "is '" + shape + "'; it must be box, cylinder or sphere");
  }
  object.mass = positive(o, "mass", object.mass, w);
  parseFriction(o, w, object);
  object.color = color(o, "color", object.color, w);
  object.pose = pose(o, w);
  return object;
}

CameraSpec parseCamera(const YAML::Node& c, const std::string& w, const RobotSpec& robot, std::set<std::string>& names) {
  rejectUnknownKeys(c, {"name", "parent", "pose", "width", "height", "fx", "fy", "cx", "cy"}, w);
  if (!c["name"]) fail(w, c, "has no name");
  CameraSpec camera;
  camera.model.name = asIdentifier(c["name"], w + ".name");
  camera.model.frame = camera.model.name + "_optical";
  if (!names.insert(camera.model.frame).second) fail(w + ".name", c["name"], "'" + camera.model.name + "' is already taken");
  camera.parent = text(c, "parent", "world", w);
  if (camera.parent != "world" && !isLink(robot, camera.parent)) {
    fail(w + ".parent", c["parent"], "'" + camera.parent + "' is neither 'world' nor a robot link");
  }
  camera.parent_from_optical = pose(c, w);
  camera.model.width = static_cast<int>(whole(c, "width", 600, 8, 8192, w));
  camera.model.height = static_cast<int>(whole(c, "height", 416, 8, 8192, w));
  camera.model.fx = positive(c, "fx", 500, w);
  camera.model.fy = positive(c, "fy", camera.model.fx, w);
  camera.model.cx = number(c, "cx", camera.model.width / 2.0, w);
  camera.model.cy = number(c, "cy", camera.model.height / 2.0, w);
  return camera;
}

/// A list under @p key of the root, or an empty node.
YAML::Node list(const YAML::Node& root, const std::string& key, const std::string& source, std::size_t max) {
  const YAML::Node l = root[key];
  if (!l) return YAML::Node(YAML::NodeType::Sequence);
  if (!l.IsSequence()) fail(source + ": " + key, l, "is " + shown(l) + "; it must be a list");
  if (l.size() > max) fail(source + ": " + key, l, "has " + std::to_string(l.size()) + " entries; at most " + std::to_string(max) + " are supported");
  return l;
}

// Colour tracking finds a robot by a body and a heading marker of colours of their own. Chromaticity, (r, g, b) /
// (r + g + b), is what survives the renderer's shading; two colours closer than this on every channel, or a colour
// this close to grey, cannot be told apart whatever the light.
constexpr double kOwnColour = 0.03;

double chromaDistance(const Rgba& a, const Rgba& b) {
  const double sa = std::max(1e-9, static_cast<double>(a.r) + a.g + a.b);
  const double sb = std::max(1e-9, static_cast<double>(b.r) + b.g + b.b);
  return std::max({std::fabs(a.r / sa - b.r / sb), std::fabs(a.g / sa - b.g / sb), std::fabs(a.b / sa - b.b / sb)});
}

std::string describe(const Rgba& c) {
  std::ostringstream out;
  out << "(" << c.r << ", " << c.g << ", " << c.b << ")";
  return out.str();
}

// Why the robot's own colours cannot give its pose from above ("" = they can): no body or heading marker visual,
// a grey one, or one whose colour something else in the world shares.
std::string colourTrackingProblem(const WorldSpec& world) {
  const RobotSpec& robot = world.robot;
  auto area = [](const Shape& s) {
    return s.type == Shape::Type::Box ? s.box_size.x() * s.box_size.y() : M_PI * s.radius * s.radius;
  };
  const Visual* body = nullptr;  // as perception takes it: the root's largest box or cylinder seen from above
  for (const Visual& v : robot.links.front().visuals) {
    if (v.shape.type != Shape::Type::Sphere && (!body || area(v.shape) > area(body->shape))) body = &v;
  }
  std::string marker_link = robot.heading_marker;
  for (std::size_t i = 1; marker_link.empty() && i < robot.links.size(); ++i) {
    const auto& visuals = robot.links[i].visuals;
    if (visuals.size() == 1 && visuals.front().shape.type == Shape::Type::Box) marker_link = robot.links[i].name;
  }
  const Visual* marker = nullptr;
  for (const LinkSpec& l : robot.links) {
    if (l.name == marker_link && !l.visuals.empty()) marker = &l.visuals.front();
  }
  if (!body) return "its root link has no box or cylinder visual to be found by";
  if (!marker) return "it has no heading marker (a link with one box visual) to give its heading";
  const Rgba grey{1, 1, 1, 1};
  std::vector<std::pair<std::string, Rgba>> others = {{"the floor", world.arena.floor_color},
                                                       {"the walls", world.arena.wall_color}};
  for (const ObjectSpec& o : world.objects) others.push_back({"object '" + o.name + "'", o.color});
  for (const LinkSpec& l : robot.links) {
    for (const Visual& v : l.visuals) {
      if (&v != body && &v != marker) others.push_back({"its link '" + l.name + "'", v.color});
    }
  }
  for (const auto& [what, visual] : {std::make_pair(std::string("body"), body), std::make_pair(std::string("heading marker"), marker)}) {
    if (chromaDistance(visual->color, grey) < kOwnColour) {
      return "its " + what + " " + describe(visual->color) + " is grey, black or white";
    }
    for (const auto& [name, colour] : others) {
      if (chromaDistance(visual->color, colour) < kOwnColour) {
        return "its " + what + " " + describe(visual->color) + " has the colour of " + name + " " + describe(colour);
      }
    }
  }
  if (chromaDistance(body->color, marker->color) < kOwnColour) {
    return "its body and heading marker share one colour " + describe(body->color);
  }
  return "";
}

// A robot the overhead camera could not find by its colours gets what a lab would tape on: an ArUco marker (4x4_50,
// id 0) as large as its top allows (a plate the width of its body, the marker three quarters of the plate).
RobotSpec::Fiducial fiducialIfColoursFail(const WorldSpec& world) {
  RobotSpec::Fiducial fiducial;
  if (world.robot.links.empty()) return fiducial;
  const std::string problem = colourTrackingProblem(world);
  if (problem.empty()) return fiducial;
  double width = 0;
  for (const Visual& v : world.robot.links.front().visuals) {
    const double w = v.shape.type == Shape::Type::Box ? std::min(v.shape.box_size.x(), v.shape.box_size.y())
                                                      : 2 * v.shape.radius;
    width = std::max(width, w);
  }
  if (!(width > 0)) return fiducial;
  fiducial.dictionary = "4x4_50";
  fiducial.id = 0;
  fiducial.size = 0.75 * width;
  fiducial.automatic_reason = problem;
  return fiducial;
}

WorldSpec parseWorldNode(const YAML::Node& root, const std::string& base_dir, const std::string& source) {
  if (!root.IsMap()) throw WorldError(source + ": a world file is a YAML mapping (name, physics, arena, robot, objects, cameras)");
  rejectUnknownKeys(root, {"name", "physics", "arena", "robot", "objects", "cameras"}, source + ": the world");
  WorldSpec world;
  world.source = source;
  world.name = root["name"] ? asText(root["name"], source + ": name") : "world";
  if (const YAML::Node p = root["physics"]) parsePhysics(p, source + ": physics", world.physics);
  if (const YAML::Node a = root["arena"]) parseArena(a, source + ": arena", world.arena);
  const YAML::Node r = root["robot"];
  if (!r) throw WorldError(source + ": the world has no robot");
  world.robot = parseRobot(r, source + ": robot", base_dir);

  std::set<std::string> names{world.robot.name, "world", "floor"};
  for (const auto& l : world.robot.links) names.insert(l.name);
  const YAML::Node objects = list(root, "objects", source, 10000);
  for (std::size_t i = 0; i < objects.size(); ++i) {
    world.objects.push_back(parseObject(objects[i], source + ": objects[" + std::to_string(i) + "]", names));
  }
  checkPlacement(world, objects);
  if (world.robot.fiducial.dictionary.empty()) world.robot.fiducial = fiducialIfColoursFail(world);
  const YAML::Node cameras = list(root, "cameras", source, 64);
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    world.cameras.push_back(parseCamera(cameras[i], source + ": cameras[" + std::to_string(i) + "]", world.robot, names));
  }
  return world;
}

}  // namespace

RobotSpec parseRobotUrdf(const std::string& urdf_xml, const std::string& source) {
  urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf_xml);
  if (!model) throw WorldError(source + " is not a valid URDF (see the parser's message above)");
  RobotSpec robot;
  robot.name = model->getName();
  robot.urdf = urdf_xml;
  addLink(*model, model->getRoot(), robot, source);
  return robot;
}

WorldSpec parseWorld(const std::string& yaml_text, const std::string& base_dir, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    const std::string where = e.mark.is_null() ? "" : " (line " + std::to_string(e.mark.line + 1) + ", column " +
                                                          std::to_string(e.mark.column + 1) + ")";
    throw WorldError(source + ": not valid YAML: " + e.msg + where);
  }
  try {
    return parseWorldNode(root, base_dir, source);
  } catch (const YAML::Exception& e) {  // a safety net; every value should have been checked above
    throw WorldError(source + ": " + e.msg + (e.mark.is_null() ? "" : " (line " + std::to_string(e.mark.line + 1) + ")"));
  }
}

WorldSpec loadWorldFile(const std::string& path) {
  const std::string text = readFile(path, "world file");
  const auto slash = path.find_last_of('/');
  return parseWorld(text, slash == std::string::npos ? "." : path.substr(0, slash), path);
}

}  // namespace xpersif::core
