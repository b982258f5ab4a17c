// Times Renderer::render() on a typical XPERSim arena: a ground plane, 4 walls, 4 cubes and a robot-like
// cylinder that drives in a circle, seen by a 600 x 416 overhead camera.
// Usage: render_bench [frames=1000] [png=/tmp/render_example.png]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#ifdef XPERSIF_BENCH_HAVE_IMGCODECS
#include <opencv2/imgcodecs.hpp>
#endif

#include "xpersif/core/render/renderer.h"

using namespace xpersif::core;

namespace {

SceneNode node(const std::string& name, const Eigen::Vector3d& at, Shape shape, const Rgba& color) {
  SceneNode n;
  n.name = name;
  n.parent = "world";
  n.parent_from_node.translation() = at;
  Visual visual;
  visual.shape = shape;
  visual.color = color;
  n.visuals.push_back(visual);
  return n;
}

Shape box(double x, double y, double z) {
  Shape s;
  s.type = Shape::Type::Box;
  s.box_size = Eigen::Vector3d(x, y, z);
  return s;
}

SceneDescription arena() {
  SceneDescription scene;
  const double lx = 3.0, ly = 2.0, wall_h = 0.3, wall_t = 0.05;
  scene.nodes.push_back(node("ground", {0, 0, -0.01}, box(lx, ly, 0.02), {0.55, 0.55, 0.5, 1}));
  const Rgba wall_color{0.75, 0.7, 0.6, 1};
  scene.nodes.push_back(node("wall_n", {0, ly / 2, wall_h / 2}, box(lx, wall_t, wall_h), wall_color));
  scene.nodes.push_back(node("wall_s", {0, -ly / 2, wall_h / 2}, box(lx, wall_t, wall_h), wall_color));
  scene.nodes.push_back(node("wall_e", {lx / 2, 0, wall_h / 2}, box(wall_t, ly, wall_h), wall_color));
  scene.nodes.push_back(node("wall_w", {-lx / 2, 0, wall_h / 2}, box(wall_t, ly, wall_h), wall_color));
  const Rgba cube_colors[4] = {{1, 0, 0, 1}, {0, 0.8, 0, 1}, {0, 0.3, 1, 1}, {1, 0.85, 0, 1}};
  const Eigen::Vector3d cube_at[4] = {{0.6, 0.4, 0.025}, {-0.7, 0.5, 0.025}, {0.9, -0.6, 0.025}, {-0.4, -0.3, 0.025}};
  for (int i = 0; i < 4; ++i) {
    SceneNode cube = node("cube_" + std::to_string(i), cube_at[i], box(0.05, 0.05, 0.05), cube_colors[i]);
    cube.dynamic = true;
    scene.nodes.push_back(cube);
  }
  Shape body;
  body.type = Shape::Type::Cylinder;
  body.radius = 0.17;
  body.length = 0.3;
  SceneNode robot = node("robot", {0, 0, 0.15}, body, {0.2, 0.2, 0.25, 1});
  robot.dynamic = true;
  Visual nose;  // a marker showing the robot's heading
  nose.shape = box(0.08, 0.06, 0.02);
  nose.color = {1, 1, 1, 1};
  nose.offset.translation() = Eigen::Vector3d(0.11, 0, 0.16);
  robot.visuals.push_back(nose);
  scene.nodes.push_back(robot);

  SceneNode optical;
  optical.name = "overhead_optical";
  optical.parent = "world";
  optical.parent_from_node.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();  // looking straight down
  optical.parent_from_node.translation() = Eigen::Vector3d(0, 0, 2.6);
  scene.nodes.push_back(optical);
  CameraModel camera;  // 600 x 416, f = 500
  camera.name = "overhead";
  camera.frame = "overhead_optical";
  scene.cameras.push_back(camera);
  return scene;
}

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::max(1, std::atoi(argv[1])) : 1000;
  const std::string png = argc > 2 ? argv[2] : "/tmp/render_example.png";

  const SceneDescription scene = arena();
  const CameraModel& camera = scene.cameras.front();
  const Renderer renderer(scene);
  cv::Mat image;
  std::vector<double> ms;
  ms.reserve(frames);
  const int warmup = 10;
  for (int k = -warmup; k < frames; ++k) {
    FrameTransforms current;
    const double a = 0.01 * k;
    Eigen::Isometry3d robot = Eigen::Isometry3d::Identity();
    robot.translation() = Eigen::Vector3d(0.5 * std::cos(a), 0.5 * std::sin(a), 0.15);
    robot.rotate(Eigen::AngleAxisd(a + M_PI / 2, Eigen::Vector3d::UnitZ()));
    current["robot"] = robot;
    const FrameTransforms world = worldTransforms(scene, current);
    const Eigen::Isometry3d world_from_camera = cameraWorldPose(scene, world, camera);

    const auto t0 = std::chrono::steady_clock::now();
    renderer.render(camera, world_from_camera, world, image);
    const auto t1 = std::chrono::steady_clock::now();
    if (k >= 0) ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  double mean = 0;
  for (double m : ms) mean += m;
  mean /= ms.size();
  auto pct = [&](double p) { return sorted[std::min(sorted.size() - 1, static_cast<size_t>(p * sorted.size()))]; };
  std::printf("render %dx%d, %zu triangles, %d frames: mean %.3f ms, p50 %.3f ms, p99 %.3f ms, max %.3f ms\n",
              camera.width, camera.height, renderer.triangleCount(), frames, mean, pct(0.5), pct(0.99),
              sorted.back());
#ifdef XPERSIF_BENCH_HAVE_IMGCODECS
  if (!png.empty() && cv::imwrite(png, image)) std::printf("last frame written to %s\n", png.c_str());
#endif
  return 0;
}
