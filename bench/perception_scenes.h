// Random arrangements of the default world for the perception benchmarks (shared by perception_accuracy and
// perception_speed): cubes at random non-overlapping places and yaws, the robot at a random pose. Also the
// shapes world: the default world with boxes, cylinders and spheres, two pairs of them sharing a colour.
#pragma once

#include <cmath>
#include <fstream>
#include <sstream>
#include <random>
#include <string>
#include <vector>

#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/render/renderer.h"
#include "xpersif/core/sim/world_spec.h"

namespace perception_bench {

using namespace xpersif::core;

inline const std::vector<std::string>& cubeNames() {
  static const std::vector<std::string> names = {"red_cube", "green_cube", "blue_cube", "yellow_cube"};
  return names;
}

inline Eigen::Isometry3d planar(double x, double y, double z, double yaw) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Eigen::Vector3d(x, y, z);
  p.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

struct DefaultWorld {
  WorldSpec spec;
  SceneDescription scene;
  FrameTransforms initial;
  double robot_z = 0;
  explicit DefaultWorld(const std::string& world_file) {
    spec = loadWorldFile(world_file);
    PhysicsWorld world(spec);
    scene = world.scene();
    initial = world.dynamicTransforms();
    robot_z = initial.at(scene.robot_root).translation().z();
  }
  DefaultWorld() = default;
};

/// The shapes world's objects block: a 4 cm cube and an 8 x 3 x 3 cm bar of one red, a cylinder, a sphere, and
/// a cylinder and a sphere of one orange (the same radius: told apart by shape only).
inline const char* shapesObjects() {
  return R"(
objects:
  - {name: red_cube, size: 0.04, color: [0.85, 0.1, 0.1, 1.0], pose: {x: 0.05, y: 0.15}}
  - {name: red_bar, size: [0.08, 0.03, 0.03], color: [0.85, 0.1, 0.1, 1.0], pose: {x: 0.2, y: 0.15, yaw: 0.5}}
  - {name: blue_can, shape: cylinder, radius: 0.02, length: 0.05, color: [0.1, 0.2, 0.85, 1.0], pose: {x: 0.25, y: -0.1}}
  - {name: green_ball, shape: sphere, radius: 0.025, color: [0.1, 0.7, 0.15, 1.0], pose: {x: 0.0, y: -0.15}}
  - {name: orange_can, shape: cylinder, radius: 0.02, length: 0.04, color: [0.95, 0.5, 0.05, 1.0], pose: {x: -0.15, y: 0.2}}
  - {name: orange_ball, shape: sphere, radius: 0.02, color: [0.95, 0.5, 0.05, 1.0], pose: {x: -0.1, y: -0.2}}
)";
}

/// The default world file with its objects block replaced by shapesObjects().
inline DefaultWorld shapesWorld(const std::string& default_world_file) {
  std::ifstream in(default_world_file);
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  const std::size_t from = yaml.find("\nobjects:"), to = yaml.find("\ncameras:");
  yaml.replace(from, to - from, shapesObjects());
  DefaultWorld w;
  w.spec = parseWorld(yaml, default_world_file.substr(0, default_world_file.rfind('/')), "shapes");
  PhysicsWorld world(w.spec);
  w.scene = world.scene();
  w.initial = world.dynamicTransforms();
  w.robot_z = w.initial.at(w.scene.robot_root).translation().z();
  return w;
}

/**
 * The shapes world's objects anywhere with |x| <= 0.38, |y| <= 0.23, centres >= 11 cm apart (the bar's corners
 * reach 4.3 cm) and >= 9 cm from the robot's, random yaws; the robot as in randomScene(). With
 * @p out_of_view_probability an object is moved far outside the image instead.
 */
inline FrameTransforms randomShapesScene(const DefaultWorld& w, std::mt19937& rng, double out_of_view_probability = 0) {
  std::uniform_real_distribution<double> unit(0.0, 1.0), yaw(-M_PI, M_PI);
  FrameTransforms current = w.initial;
  const Eigen::Vector2d robot(-0.38 + 0.76 * unit(rng), -0.23 + 0.46 * unit(rng));
  current[w.scene.robot_root] = planar(robot.x(), robot.y(), w.robot_z, yaw(rng));
  std::vector<Eigen::Vector2d> taken;
  int far = 0;
  for (const std::string& name : w.scene.objects) {
    const double z = w.initial.at(name).translation().z();
    if (unit(rng) < out_of_view_probability) {
      current[name] = planar(5.0 + far++, 5.0, z, yaw(rng));
      continue;
    }
    for (;;) {
      const Eigen::Vector2d p(-0.38 + 0.76 * unit(rng), -0.23 + 0.46 * unit(rng));
      bool free = (p - robot).norm() >= 0.09;
      for (const auto& q : taken) free = free && (p - q).norm() >= 0.11;
      if (!free) continue;
      taken.push_back(p);
      current[name] = planar(p.x(), p.y(), z, yaw(rng));
      break;
    }
  }
  return current;
}

/**
 * Cubes (4 cm) anywhere with |x| <= 0.41, |y| <= 0.26 (clear of the walls at any yaw), centres >= 6 cm apart
 * (a 4 cm cube's corners reach 2.83 cm from its centre) and >= 7 cm from the robot's (r = 3.5 cm); the robot
 * at |x| <= 0.38, |y| <= 0.23 with any heading. With @p out_of_view_probability, a cube is moved far outside
 * the arena and the image instead (to count false detections).
 */
inline FrameTransforms randomScene(const DefaultWorld& w, std::mt19937& rng, double out_of_view_probability = 0) {
  std::uniform_real_distribution<double> unit(0.0, 1.0), yaw(-M_PI, M_PI);
  FrameTransforms current = w.initial;
  const Eigen::Vector2d robot(-0.38 + 0.76 * unit(rng), -0.23 + 0.46 * unit(rng));
  current[w.scene.robot_root] = planar(robot.x(), robot.y(), w.robot_z, yaw(rng));
  std::vector<Eigen::Vector2d> cubes;
  int far = 0;
  for (const std::string& name : cubeNames()) {
    if (unit(rng) < out_of_view_probability) {
      current[name] = planar(5.0 + far++, 5.0, 0.02, yaw(rng));
      continue;
    }
    for (;;) {
      const Eigen::Vector2d p(-0.41 + 0.82 * unit(rng), -0.26 + 0.52 * unit(rng));
      bool free = (p - robot).norm() >= 0.07;
      for (const auto& q : cubes) free = free && (p - q).norm() >= 0.06;
      if (!free) continue;
      cubes.push_back(p);
      current[name] = planar(p.x(), p.y(), 0.02, yaw(rng));
      break;
    }
  }
  return current;
}

struct Frame {
  cv::Mat image;
  Eigen::Isometry3d world_from_camera;
};

inline Frame render(const Renderer& renderer, const SceneDescription& scene, const FrameTransforms& current,
                    const CameraModel& camera) {
  const FrameTransforms world = worldTransforms(scene, current);
  Frame f;
  f.world_from_camera = cameraWorldPose(scene, world, camera);
  renderer.render(camera, f.world_from_camera, world, f.image);
  return f;
}

}  // namespace perception_bench
