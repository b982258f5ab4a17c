// Random arrangements of the default world for the perception benchmarks (shared by perception_accuracy and
// perception_speed): cubes at random non-overlapping places and yaws, the robot at a random pose.
#pragma once

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "xpersif/core/physics_world.h"
#include "xpersif/core/renderer.h"
#include "xpersif/core/world_spec.h"

namespace perception_bench {

using namespace xpersif::core;

inline const std::vector<std::string>& cubeNames() {
  static const std::vector<std::string> names = {"red_cube", "green_cube", "blue_cube", "yellow_cube"};
  return names;
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
    robot_z = initial.at("base_link").translation().z();
  }
};

inline Eigen::Isometry3d planar(double x, double y, double z, double yaw) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Eigen::Vector3d(x, y, z);
  p.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return p;
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
  current["base_link"] = planar(robot.x(), robot.y(), w.robot_z, yaw(rng));
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
