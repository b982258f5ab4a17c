#include "xpersif/core/sim/world_generator.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>

namespace xpersif::core {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kWallThickness = 0.02;
constexpr double kRobotClearance = 0.12;  // m between footprints' circumcircles: the 7 cm robot reaches every face
constexpr double kWallClearance = 0.10;   // m from a footprint's circumcircle to the walls' inner faces

struct DrawnObject {
  std::string role, shape, name;
  std::vector<double> size;  // box: x, y, z; cylinder: radius, length
  double mass = 0, friction_x = 0, friction_y = 0, radius = 0;  // radius: of the footprint's circumcircle
  double x = 0, y = 0, yaw = 0;
  double r = 0, g = 0, b = 0;
  std::string colour;
};

std::string number(double value) {
  std::ostringstream out;
  out << std::setprecision(4) << value;
  return out.str();
}

/// HSV (h in degrees) to RGB in [0, 1].
void hsvToRgb(double h, double s, double v, double& r, double& g, double& b) {
  const double c = v * s, hp = std::fmod(h, 360.0) / 60.0, x = c * (1 - std::fabs(std::fmod(hp, 2.0) - 1)), m = v - c;
  const int sector = static_cast<int>(hp) % 6;
  const double table[6][3] = {{c, x, 0}, {x, c, 0}, {0, c, x}, {0, x, c}, {x, 0, c}, {c, 0, x}};
  r = table[sector][0] + m;
  g = table[sector][1] + m;
  b = table[sector][2] + m;
}

std::string colourName(double hue) {
  static const std::vector<std::pair<double, std::string>> names = {
      {15, "red"}, {45, "orange"}, {70, "yellow"}, {160, "green"}, {200, "cyan"}, {260, "blue"}, {290, "purple"},
      {340, "magenta"}, {360, "red"}};
  for (const auto& [upto, name] : names) {
    if (hue < upto) return name;
  }
  return "red";
}

/// One object of @p role: shape, size, mass and friction from the role's ranges.
DrawnObject drawBody(const std::string& role, std::mt19937& rng) {
  auto uniform = [&rng](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  DrawnObject o;
  o.role = role;
  if (role == "light") {
    if (uniform(0, 1) < 0.5) {
      const double side = uniform(0.035, 0.05);
      o.shape = "box";
      o.size = {side, side, side};
      o.radius = side / std::sqrt(2.0);
    } else {
      o.shape = "cylinder";
      o.size = {uniform(0.02, 0.03), 0.03};
      o.radius = o.size[0];
    }
    o.mass = uniform(0.015, 0.04);
    o.friction_x = o.friction_y = uniform(0.3, 0.6);
  } else if (role == "elongated") {
    o.shape = "box";
    o.size = {uniform(0.08, 0.12), uniform(0.025, 0.035), 0.03};
    o.radius = std::hypot(o.size[0], o.size[1]) / 2;
    o.mass = uniform(0.02, 0.04);
    o.friction_x = uniform(0.1, 0.2);
    o.friction_y = uniform(0.5, 0.7);
  } else if (role == "immovable") {
    const double side = uniform(0.045, 0.06);
    o.shape = "box";
    o.size = {side, side, side};
    o.radius = side / std::sqrt(2.0);
    o.mass = uniform(1.5, 3.0);
    o.friction_x = o.friction_y = uniform(0.8, 1.0);
  } else {  // redrawn
    const double side = uniform(0.035, 0.045);
    o.shape = "box";
    o.size = {side, side, side};
    o.radius = side / std::sqrt(2.0);
    o.mass = uniform(0.03, 0.06);
    o.friction_x = o.friction_y = 0.5;
  }
  return o;
}

/// Hues spread evenly around the circle from a random start, each jittered by less than a third of the spacing.
void paint(std::vector<DrawnObject>& objects, std::mt19937& rng) {
  auto uniform = [&rng](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  const double spacing = 360.0 / objects.size(), start = uniform(0, 360);
  std::vector<double> hues;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    hues.push_back(std::fmod(start + i * spacing + uniform(-spacing / 3, spacing / 3) + 720.0, 360.0));
  }
  std::shuffle(hues.begin(), hues.end(), rng);
  std::map<std::string, int> used;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    auto& o = objects[i];
    hsvToRgb(hues[i], uniform(0.7, 0.9), uniform(0.7, 0.9), o.r, o.g, o.b);
    const std::string noun = o.role == "elongated" ? "bar" : o.role == "immovable" ? "block"
                             : o.shape == "cylinder" ? "puck" : "cube";
    o.name = colourName(hues[i]) + "_" + noun;
    if (used[o.name]++) o.name += "_" + std::to_string(used[o.name]);
  }
}

/// Poses by rejection: inside the walls with room for the robot to reach every face, apart from each other and from
/// the robot's start. False when an object found no room (the caller draws them all again).
bool place(std::vector<DrawnObject>& objects, double arena_x, double arena_y, double robot_x, double robot_radius,
           std::mt19937& rng) {
  auto uniform = [&rng](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  for (std::size_t i = 0; i < objects.size(); ++i) {
    auto& o = objects[i];
    const double mx = arena_x / 2 - kWallClearance - o.radius, my = arena_y / 2 - kWallClearance - o.radius;
    bool placed = false;
    for (int attempt = 0; attempt < 2000 && !placed; ++attempt) {
      o.x = uniform(-mx, mx);
      o.y = uniform(-my, my);
      placed = std::hypot(o.x - robot_x, o.y) >= robot_radius + o.radius + kRobotClearance;
      for (std::size_t j = 0; j < i && placed; ++j) {
        placed = std::hypot(o.x - objects[j].x, o.y - objects[j].y) >= o.radius + objects[j].radius + kRobotClearance;
      }
    }
    if (!placed) return false;
    o.yaw = uniform(-kPi, kPi);
  }
  return true;
}

std::string objectLine(const DrawnObject& o) {
  std::ostringstream line;
  line << "  - {name: " << o.name << ", shape: " << o.shape;
  if (o.shape == "cylinder") {
    line << ", radius: " << number(o.size[0]) << ", length: " << number(o.size[1]);
  } else {
    line << ", size: [" << number(o.size[0]) << ", " << number(o.size[1]) << ", " << number(o.size[2]) << "]";
  }
  line << ", mass: " << number(o.mass) << ", friction: ";
  if (o.friction_x == o.friction_y) line << number(o.friction_x);
  else line << "[" << number(o.friction_x) << ", " << number(o.friction_y) << "]";
  if (o.role == "redrawn") line << ", friction_redraw: [0.1, 2.5]";
  line << ", color: [" << number(o.r) << ", " << number(o.g) << ", " << number(o.b) << ", 1.0], pose: {x: "
       << number(o.x) << ", y: " << number(o.y) << ", yaw: " << number(o.yaw) << "}}  # " << o.role << "\n";
  return line.str();
}

}  // namespace

const std::vector<std::string>& worldGeneratorRoles() {
  static const std::vector<std::string> roles = {"light", "elongated", "immovable", "redrawn"};
  return roles;
}

std::string generateWorld(const WorldGeneratorOptions& options) {
  if (options.objects < 1 || options.objects > 8) {
    throw std::invalid_argument("--objects is " + std::to_string(options.objects) + "; it must be in 1..8");
  }
  std::vector<std::string> roles = options.roles.empty() ? worldGeneratorRoles() : options.roles;
  for (const auto& role : roles) {
    const auto& known = worldGeneratorRoles();
    if (std::find(known.begin(), known.end(), role) == known.end()) {
      throw std::invalid_argument("--roles: '" + role + "' is not a role; the roles are light, elongated, immovable, "
                                  "redrawn");
    }
  }
  std::mt19937 rng(options.seed);
  auto uniform = [&rng](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  // Every role once (in a random order) while there are objects for it, then roles drawn at random.
  std::shuffle(roles.begin(), roles.end(), rng);
  std::vector<DrawnObject> objects;
  for (int i = 0; i < options.objects; ++i) {
    const std::string& role = i < static_cast<int>(roles.size())
                                  ? roles[i]
                                  : roles[std::uniform_int_distribution<std::size_t>(0, roles.size() - 1)(rng)];
    objects.push_back(drawBody(role, rng));
  }
  paint(objects, rng);
  const int extra = std::max(0, options.objects - 5);
  double arena_x = 0.8 + uniform(0, 0.25) + 0.06 * extra, arena_y = 0.55 + uniform(0, 0.15) + 0.04 * extra;
  const double robot_radius = 0.035;
  double robot_x = 0;
  // A layout that leaves no room for the last objects is drawn again; after 30 such, the arena grows by 5 %.
  for (int attempt = 0;; ++attempt) {
    if (attempt > 0 && attempt % 30 == 0) {
      if (attempt >= 300) {
        throw std::runtime_error("generate-world: no room for " + std::to_string(objects.size()) + " objects in a " +
                                 number(arena_x) + " x " + number(arena_y) + " m arena");
      }
      arena_x *= 1.05;
      arena_y *= 1.05;
    }
    robot_x = -arena_x / 2 + kWallClearance + robot_radius + 0.01;
    if (place(objects, arena_x, arena_y, robot_x, robot_radius, rng)) break;
  }
  // The overhead camera (600 x 416 px, fx 650) sees z * 0.92 by z * 0.64 m: the arena, its walls and a margin.
  const double z = std::max((arena_x + 2 * kWallThickness + 0.1) * 650.0 / 600.0,
                            (arena_y + 2 * kWallThickness + 0.1) * 650.0 / 416.0);

  std::ostringstream yaml;
  yaml << "# Generated by `xpersif generate-world --seed " << options.seed << " --objects " << options.objects
       << "` (doc/worlds.md): " << objects.size() << " objects; each line ends with its role.\n"
       << "name: generated_" << options.seed << "\n\n"
       << "physics:\n  step: 0.002\n  gravity: -9.81\n  seed: 1\n  iterations: 20\n  max_speed: 5.0\n"
       << "  friction_model: coulomb\n  contact_episode_gap: 0.5\n\n"
       << "arena:\n  size: [" << number(arena_x) << ", " << number(arena_y) << "]\n  wall_height: 0.05\n"
       << "  wall_thickness: " << kWallThickness << "\n  wall_color: [0.55, 0.55, 0.6, 1.0]\n"
       << "  floor_color: [0.93, 0.93, 0.9, 1.0]\n\n"
       << "robot:\n  urdf: " << options.robot_urdf << "\n  pose: {x: " << number(robot_x) << ", y: 0.0, yaw: 0.0}\n"
       << "  left_wheel_joint: left_wheel_joint\n  right_wheel_joint: right_wheel_joint\n  max_wheel_speed: 0.5\n"
       << "  max_wheel_torque: 0.005\n  wheel_friction: 1.0\n  body_friction: 0.3\n"
       << "  ir_sensors: [ir_0, ir_1, ir_2, ir_3, ir_4, ir_5, ir_6, ir_7]\n  ir_range: 0.06\n"
       << "  heading_marker: camera_link\n\nobjects:\n";
  for (const auto& o : objects) yaml << objectLine(o);
  yaml << "\ncameras:\n  - {name: overhead, parent: world, pose: {x: 0.0, y: 0.0, z: " << number(z)
       << ", roll: 3.14159265358979}, width: 600, height: 416, fx: 650.0, fy: 650.0}\n"
       << "  - {name: robot_camera, parent: camera_link, pose: {roll: -1.5707963267949, yaw: -1.5707963267949}, "
          "width: 160, height: 120, fx: 120.0, fy: 120.0}\n";
  return yaml.str();
}

}  // namespace xpersif::core
