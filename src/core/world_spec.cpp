#include "xpersif/core/world_spec.h"

#include <urdf_parser/urdf_parser.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "xpersif/core/validation.h"

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
    if (!(spec.mass >= 0) || !std::isfinite(spec.mass)) throw WorldError(where + " has an invalid mass");
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

// ---- YAML ------------------------------------------------------------------------------------------

std::string at(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  return mark.line >= 0 ? " (line " + std::to_string(mark.line + 1) + ")" : "";
}

template <class T>
T get(const YAML::Node& map, const std::string& key, const T& fallback, const std::string& where) {
  const YAML::Node value = map[key];
  if (!value) return fallback;
  try {
    return value.as<T>();
  } catch (const YAML::Exception&) {
    throw WorldError(where + "." + key + at(value) + " has the wrong type");
  }
}

double number(const YAML::Node& map, const std::string& key, double fallback, const std::string& where) {
  const double v = get<double>(map, key, fallback, where);
  if (!std::isfinite(v)) throw WorldError(where + "." + key + at(map[key]) + " must be a finite number");
  return v;
}

double positive(const YAML::Node& map, const std::string& key, double fallback, const std::string& where) {
  const double v = number(map, key, fallback, where);
  if (!(v > 0)) throw WorldError(where + "." + key + at(map[key]) + " must be greater than zero");
  return v;
}

Rgba color(const YAML::Node& map, const std::string& key, const Rgba& fallback, const std::string& where) {
  const YAML::Node value = map[key];
  if (!value) return fallback;
  if (!value.IsSequence() || (value.size() != 3 && value.size() != 4)) {
    throw WorldError(where + "." + key + at(value) + " must be [r, g, b] or [r, g, b, a] in 0..1");
  }
  float c[4] = {0, 0, 0, 1};
  for (std::size_t i = 0; i < value.size(); ++i) {
    const double v = value[i].as<double>();
    if (!(v >= 0 && v <= 1)) throw WorldError(where + "." + key + at(value) + " components must lie in 0..1");
    c[i] = static_cast<float>(v);
  }
  return {c[0], c[1], c[2], c[3]};
}

void rejectUnknownKeys(const YAML::Node& map, const std::set<std::string>& known, const std::string& where) {
  if (!map.IsMap()) throw WorldError(where + at(map) + " must be a mapping");
  for (const auto& entry : map) {
    const std::string key = entry.first.as<std::string>();
    if (!known.count(key)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw WorldError(where + at(entry.first) + " has unknown key '" + key + "'; known: " + list);
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

void deriveWheels(RobotSpec& robot, const std::string& source) {
  auto wheel = [&](const std::string& joint) -> const LinkSpec& {
    for (const auto& l : robot.links) {
      if (l.joint == joint) {
        if (l.joint_type != LinkSpec::JointType::Revolute) {
          throw WorldError(source + ": wheel joint '" + joint + "' must be revolute or continuous");
        }
        if (l.collisions.empty()) throw WorldError(source + ": wheel link '" + l.name + "' has no collision shape");
        if (l.parent != robot.links[0].name) {
          throw WorldError(source + ": wheel link '" + l.name + "' must hang from the root link");
        }
        return l;
      }
    }
    throw WorldError(source + ": the robot has no joint '" + joint + "' to drive as a wheel");
  };
  const LinkSpec& left = wheel(robot.left_wheel_joint);
  const LinkSpec& right = wheel(robot.right_wheel_joint);
  robot.wheel_radius = left.collisions[0].shape.radius;
  robot.wheel_separation = (left.parent_from_link.translation() - right.parent_from_link.translation()).norm();
  if (!(robot.wheel_radius > 0) || !(robot.wheel_separation > 0)) {
    throw WorldError(source + ": wheels need a positive radius and distinct positions");
  }
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
    throw WorldError(source + ": not valid YAML: " + e.what());
  }
  if (!root.IsMap()) throw WorldError(source + ": a world file is a YAML mapping");
  rejectUnknownKeys(root, {"name", "physics", "arena", "robot", "objects", "cameras"}, source);
  WorldSpec world;
  world.source = source;
  world.name = get<std::string>(root, "name", "world", source);

  if (const YAML::Node p = root["physics"]) {
    const std::string w = source + ": physics";
    rejectUnknownKeys(p, {"step", "gravity", "seed", "iterations", "max_speed"}, w);
    world.physics.step = positive(p, "step", world.physics.step, w);
    if (world.physics.step > 0.05) throw WorldError(w + ".step must be at most 0.05 s for stable contacts");
    world.physics.gravity = number(p, "gravity", world.physics.gravity, w);
    world.physics.seed = get<unsigned long>(p, "seed", world.physics.seed, w);
    world.physics.iterations = get<int>(p, "iterations", world.physics.iterations, w);
    if (world.physics.iterations < 1 || world.physics.iterations > 1000) throw WorldError(w + ".iterations must lie in 1..1000");
    world.physics.max_speed = positive(p, "max_speed", world.physics.max_speed, w);
  }
  if (const YAML::Node a = root["arena"]) {
    const std::string w = source + ": arena";
    rejectUnknownKeys(a, {"size", "wall_height", "wall_thickness", "wall_color", "floor_color"}, w);
    if (const YAML::Node size = a["size"]) {
      if (!size.IsSequence() || size.size() != 2) throw WorldError(w + ".size" + at(size) + " must be [x, y]");
      world.arena.size_x = size[0].as<double>();
      world.arena.size_y = size[1].as<double>();
      if (!(world.arena.size_x > 0.1 && world.arena.size_y > 0.1 && world.arena.size_x < 1000 && world.arena.size_y < 1000)) {
        throw WorldError(w + ".size" + at(size) + " must lie between 0.1 and 1000 m");
      }
    }
    world.arena.wall_height = positive(a, "wall_height", world.arena.wall_height, w);
    world.arena.wall_thickness = positive(a, "wall_thickness", world.arena.wall_thickness, w);
    world.arena.wall_color = color(a, "wall_color", world.arena.wall_color, w);
    world.arena.floor_color = color(a, "floor_color", world.arena.floor_color, w);
  }

  const YAML::Node r = root["robot"];
  if (!r) throw WorldError(source + ": the world has no robot");
  {
    const std::string w = source + ": robot";
    rejectUnknownKeys(r, {"urdf", "pose", "left_wheel_joint", "right_wheel_joint", "max_wheel_speed",
                          "max_wheel_torque", "wheel_friction", "body_friction", "ir_sensors", "ir_range", "heading_marker"}, w);
    const std::string urdf_file = get<std::string>(r, "urdf", "", w);
    if (urdf_file.empty()) throw WorldError(w + " needs 'urdf', the robot's URDF file");
    const std::string urdf_path = urdf_file[0] == '/' ? urdf_file : base_dir + "/" + urdf_file;
    world.robot = parseRobotUrdf(readFile(urdf_path, "URDF"), urdf_path);
    world.robot.pose = pose(r, w);
    world.robot.left_wheel_joint = get<std::string>(r, "left_wheel_joint", "left_wheel_joint", w);
    world.robot.right_wheel_joint = get<std::string>(r, "right_wheel_joint", "right_wheel_joint", w);
    world.robot.max_wheel_speed = positive(r, "max_wheel_speed", world.robot.max_wheel_speed, w);
    world.robot.max_wheel_torque = positive(r, "max_wheel_torque", world.robot.max_wheel_torque, w);
    world.robot.wheel_friction = positive(r, "wheel_friction", world.robot.wheel_friction, w);
    world.robot.body_friction = number(r, "body_friction", world.robot.body_friction, w);
    world.robot.ir_sensors = get<std::vector<std::string>>(r, "ir_sensors", {}, w);
    world.robot.ir_range = positive(r, "ir_range", world.robot.ir_range, w);
    for (const auto& ir : world.robot.ir_sensors) {
      bool found = false;
      for (const auto& l : world.robot.links) found = found || l.name == ir;
      if (!found) throw WorldError(w + ".ir_sensors names '" + ir + "', which is not a link of " + urdf_path);
    }
    world.robot.heading_marker = get<std::string>(r, "heading_marker", "", w);
    if (!world.robot.heading_marker.empty()) {
      bool found = false;
      for (const auto& l : world.robot.links) found = found || l.name == world.robot.heading_marker;
      if (!found) {
        throw WorldError(w + ".heading_marker names '" + world.robot.heading_marker + "', which is not a link of " +
                         urdf_path);
      }
    }
    deriveWheels(world.robot, urdf_path);
  }

  std::set<std::string> names{world.robot.name, "world", "floor"};
  for (const auto& l : world.robot.links) names.insert(l.name);
  if (const YAML::Node objects = root["objects"]) {
    if (!objects.IsSequence()) throw WorldError(source + ": objects" + at(objects) + " must be a list");
    if (objects.size() > 10000) throw WorldError(source + ": at most 10000 objects are supported");
    for (std::size_t i = 0; i < objects.size(); ++i) {
      const YAML::Node o = objects[i];
      const std::string w = source + ": objects[" + std::to_string(i) + "]";
      rejectUnknownKeys(o, {"name", "shape", "size", "radius", "length", "mass", "friction", "color", "pose"}, w);
      ObjectSpec object;
      object.name = get<std::string>(o, "name", "", w);
      throwIfInvalid(checkIdentifier(w + ".name", object.name));
      if (!names.insert(object.name).second) throw WorldError(w + ".name '" + object.name + "' is already taken");
      const std::string shape = get<std::string>(o, "shape", "box", w);
      if (shape == "box") {
        const YAML::Node size = o["size"];
        if (size && size.IsSequence() && size.size() == 3) {
          object.shape.box_size = Eigen::Vector3d(size[0].as<double>(), size[1].as<double>(), size[2].as<double>());
        } else {
          const double edge = positive(o, "size", 0.04, w);
          object.shape.box_size = Eigen::Vector3d::Constant(edge);
        }
        if (!(object.shape.box_size.minCoeff() > 0)) throw WorldError(w + ".size must be positive");
      } else if (shape == "cylinder" || shape == "sphere") {
        object.shape.type = shape == "cylinder" ? Shape::Type::Cylinder : Shape::Type::Sphere;
        object.shape.radius = positive(o, "radius", 0.02, w);
        object.shape.length = positive(o, "length", 0.04, w);
      } else {
        throw WorldError(w + ".shape is '" + shape + "'; it must be box, cylinder or sphere");
      }
      object.mass = positive(o, "mass", object.mass, w);
      object.friction = number(o, "friction", object.friction, w);
      if (object.friction < 0) throw WorldError(w + ".friction must not be negative");
      object.color = color(o, "color", object.color, w);
      object.pose = pose(o, w);
      world.objects.push_back(object);
    }
  }

  if (const YAML::Node cameras = root["cameras"]) {
    if (!cameras.IsSequence()) throw WorldError(source + ": cameras" + at(cameras) + " must be a list");
    for (std::size_t i = 0; i < cameras.size(); ++i) {
      const YAML::Node c = cameras[i];
      const std::string w = source + ": cameras[" + std::to_string(i) + "]";
      rejectUnknownKeys(c, {"name", "parent", "pose", "width", "height", "fx", "fy", "cx", "cy"}, w);
      CameraSpec camera;
      camera.model.name = get<std::string>(c, "name", "", w);
      throwIfInvalid(checkIdentifier(w + ".name", camera.model.name));
      camera.model.frame = camera.model.name + "_optical";
      if (!names.insert(camera.model.frame).second) throw WorldError(w + ".name '" + camera.model.name + "' is already taken");
      camera.parent = get<std::string>(c, "parent", "world", w);
      bool parent_known = camera.parent == "world";
      for (const auto& l : world.robot.links) parent_known = parent_known || l.name == camera.parent;
      if (!parent_known) throw WorldError(w + ".parent '" + camera.parent + "' is neither 'world' nor a robot link");
      camera.parent_from_optical = pose(c, w);
      camera.model.width = get<int>(c, "width", 600, w);
      camera.model.height = get<int>(c, "height", 416, w);
      if (camera.model.width < 8 || camera.model.height < 8 || camera.model.width > 8192 || camera.model.height > 8192) {
        throw WorldError(w + " width and height must lie in 8..8192 pixels");
      }
      camera.model.fx = positive(c, "fx", 500, w);
      camera.model.fy = positive(c, "fy", camera.model.fx, w);
      camera.model.cx = number(c, "cx", camera.model.width / 2.0, w);
      camera.model.cy = number(c, "cy", camera.model.height / 2.0, w);
      world.cameras.push_back(camera);
    }
  }
  return world;
}

WorldSpec loadWorldFile(const std::string& path) {
  const std::string text = readFile(path, "world file");
  const auto slash = path.find_last_of('/');
  return parseWorld(text, slash == std::string::npos ? "." : path.substr(0, slash), path);
}

}  // namespace xpersif::core
