// Overhead and robot-camera accuracy on every shipped world, per object (its shape and case), over random
// placements: with the empty arena subtracted (what the loop runs) and, where the world's colours allow it,
// colours alone (the extractor before issue 36), on the same images. See perception.md.
//   perception_worlds [placements] [seed]
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "xpersif/core/perception/background.h"
#include "xpersif/core/perception/feature_extractor.h"
#include "xpersif/core/render/renderer.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/sim/world_spec.h"

using namespace xpersif::core;

namespace {

double headingOf(const Eigen::Isometry3d& t) { return std::atan2(t.linear()(1, 0), t.linear()(0, 0)); }

struct Tally {
  int seen = 0, found = 0;
  std::vector<double> errors, yaw_errors;
  void add(const FrameTransforms& world, const std::string& name, const Detections& d) {
    ++seen;
    const auto it = d.objects.find(name);
    if (it == d.objects.end()) return;
    ++found;
    errors.push_back((it->second.position.head<2>() - world.at(name).translation().head<2>()).norm());
    if (it->second.yaw_known) {
      yaw_errors.push_back(std::fabs(foldAngle(it->second.yaw - headingOf(world.at(name)), it->second.yaw_period)));
    }
  }
  static double quantile(std::vector<double> v, double q) {
    if (v.empty()) return NAN;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<std::size_t>(q * v.size()))];
  }
  std::string row() const {
    if (seen == 0) return "| – | – | – |";
    char text[160];
    std::snprintf(text, sizeof text, "| %d/%d | %.2f / %.2f | %s |", found, seen, 1000 * quantile(errors, 0.5),
                  1000 * quantile(errors, 0.95),
                  yaw_errors.empty() ? "–" : (std::to_string(std::lround(10 * quantile(yaw_errors, 0.95) * 180 / M_PI) / 10.0).substr(0, 4)).c_str());
    return text;
  }
};

std::string describe(const Shape& s) {
  char text[80];
  if (s.type == Shape::Type::Box) {
    std::snprintf(text, sizeof text, "box %.0f×%.0f×%.0f mm", 1000 * s.box_size.x(), 1000 * s.box_size.y(), 1000 * s.box_size.z());
  } else if (s.type == Shape::Type::Cylinder) {
    std::snprintf(text, sizeof text, "cylinder r %.0f h %.0f mm", 1000 * s.radius, 1000 * s.length);
  } else {
    std::snprintf(text, sizeof text, "sphere r %.0f mm", 1000 * s.radius);
  }
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  const int placements = argc > 1 ? std::stoi(argv[1]) : 100;
  const unsigned seed = argc > 2 ? static_cast<unsigned>(std::stoul(argv[2])) : 1;
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(std::string(XPERSIF_SOURCE_DIR) + "/worlds")) {
    if (e.path().extension() == ".yaml") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  std::cout << "| world | object (shape) | overhead found | overhead error median / p95, mm | yaw p95, ° | "
               "colours alone: found | error, mm | yaw | robot camera found | error, mm | yaw | colours alone: found | "
               "error, mm | yaw |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  std::vector<std::string> speeds;
  for (const auto& file : files) {
    const PhysicsWorld world(loadWorldFile(file));
    const SceneDescription& scene = world.scene();
    const PerceptionCatalogue catalogue = PerceptionCatalogue::fromScene(scene);
    auto background = std::make_shared<RenderedBackground>(scene);
    const Renderer renderer(scene);
    std::map<std::string, Tally> over, alone, forward, forward_alone;
    Tally robot_over;
    std::vector<double> ms_with, ms_alone;  // overhead extract() wall time
    std::vector<double> robot_errors, robot_yaw;
    std::mt19937 rng(seed);
    const double hx = 0.5 * scene.arena_size_x - 0.07, hy = 0.5 * scene.arena_size_y - 0.07;
    std::uniform_real_distribution<double> ux(-hx, hx), uy(-hy, hy), uyaw(-M_PI, M_PI);
    const FrameTransforms start = world.dynamicTransforms();
    for (int k = 0; k < placements; ++k) {
      FrameTransforms current = start;
      std::vector<Eigen::Vector2d> taken;
      std::vector<std::string> things = scene.objects;
      things.insert(things.begin(), scene.robot_root);
      for (const auto& name : things) {
        for (int tries = 0; tries < 500; ++tries) {
          const Eigen::Vector2d p(ux(rng), uy(rng));
          bool free = true;
          for (const auto& q : taken) free = free && (p - q).norm() > 0.13;
          if (!free) continue;
          taken.push_back(p);
          Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
          pose.translation() = Eigen::Vector3d(p.x(), p.y(), start.at(name).translation().z());
          pose.linear() = Eigen::AngleAxisd(uyaw(rng), Eigen::Vector3d::UnitZ()).toRotationMatrix();
          current[name] = pose;
          break;
        }
      }
      const FrameTransforms w = worldTransforms(scene, current);
      for (const CameraModel& camera : scene.cameras) {
        const Eigen::Isometry3d pose = cameraWorldPose(scene, w, camera);
        cv::Mat image;
        renderer.render(camera, pose, w, image);
        const FeatureExtractor with(catalogue, camera, PerceptionOptions(), background);
        auto t0 = std::chrono::steady_clock::now();
        const Detections d = with.extract(image, pose);
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        const bool down = with.isDownward(pose);
        for (const auto& name : scene.objects) (down ? over : forward)[name].add(w, name, d);
        try {
          const FeatureExtractor colours(catalogue, camera);
          t0 = std::chrono::steady_clock::now();
          const Detections c = colours.extract(image, pose);
          if (with.isDownward(pose)) {
            ms_alone.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
          }
          for (const auto& name : scene.objects) (down ? alone : forward_alone)[name].add(w, name, c);
        } catch (const std::exception&) {  // colours alone cannot tell this world's colours apart
        }
        if (down) {
          ms_with.push_back(ms);
          ++robot_over.seen;
          if (d.robot.found && d.robot.yaw_known) {
            ++robot_over.found;
            const Eigen::Isometry3d& r = w.at(scene.robot_root);
            robot_errors.push_back(std::hypot(d.robot.x - r.translation().x(), d.robot.y - r.translation().y()));
            robot_yaw.push_back(std::fabs(foldAngle(d.robot.yaw - headingOf(r), 2 * M_PI)));
          }
        }
      }
    }
    const std::string world_name = std::filesystem::path(file).stem().string();
    for (const auto& o : catalogue.objects) {
      std::cout << "| " << world_name << " | " << o.name << " (" << describe(o.shape) << ") " << over[o.name].row()
                << " " << alone[o.name].row().substr(1) << " " << forward[o.name].row().substr(1) << " "
                << forward_alone[o.name].row().substr(1) << "\n";
    }
    robot_over.errors = robot_errors;
    robot_over.yaw_errors = robot_yaw;
    std::cout << "| " << world_name << " | robot " << scene.robot_root
              << (scene.robot_fiducial.node.empty() ? " (colour marker)" : " (fiducial)") << " " << robot_over.row()
              << " | | | | | | | | |\n";
    speeds.push_back("| " + world_name + " | " + std::to_string(Tally::quantile(ms_with, 0.5)).substr(0, 5) + " | " +
                     (ms_alone.empty() ? std::string("–") : std::to_string(Tally::quantile(ms_alone, 0.5)).substr(0, 5)) +
                     " |");
  }
  std::cout << "\n| world | overhead extract() median, ms: empty arena subtracted | colours alone |\n| --- | --- | --- |\n";
  for (const auto& line : speeds) std::cout << line << "\n";
  return 0;
}
