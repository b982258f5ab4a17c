// Accuracy of FEATUREEXTRACTION (core::FeatureExtractor) on random arrangements of the default world drawn
// by the project's Renderer, against the poses they were drawn at.
//  - overhead camera: position and yaw (modulo pi/2) error per cube colour, detection rate, false detections
//    (a cube reported while it was outside the image, or more than 2 cm from where it was), robot position
//    and heading error;
//  - robot camera (the robot turned towards a random cube): position error of the cubes wholly in its view
//    and not hidden behind another cube, by distance from the camera; detection rate; false detections (a
//    cube reported while wholly outside the view).
//  - the shapes world (a cube and a long bar of one red, a cylinder, a sphere, a cylinder and a sphere of one
//    orange): the same two parts per object, plus how often an object was reported at its same-coloured
//    partner's place (swapped).
// Usage: perception_accuracy [scenes=500] [seed=1] [out_dir=(none)] [noise_sigma=0] [morphology_kernel=default]
// Writes out_dir/perception_accuracy.md (the tables printed) and out_dir/perception_accuracy.csv (every sample);
// with noise_sigma > 0 (Gaussian image noise in grey levels, seeded), perception_accuracy_noise<sigma>.*.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "perception_scenes.h"
#include "xpersif/core/perception/feature_extractor.h"

using namespace perception_bench;

namespace {

struct Stats {
  std::vector<double> v;
  void add(double x) { v.push_back(x); }
  std::string row(double scale, int precision) const {
    if (v.empty()) return "– | – | –";
    std::vector<double> s = v;
    std::sort(s.begin(), s.end());
    double sum = 0;
    for (double x : s) sum += x;
    const double p95 = s[std::min(s.size() - 1, static_cast<std::size_t>(0.95 * (s.size() - 1) + 0.5))];
    char buf[128];
    std::snprintf(buf, sizeof buf, "%.*f | %.*f | %.*f", precision, scale * sum / s.size(), precision, scale * p95,
                  precision, scale * s.back());
    return buf;
  }
};

struct Tally {
  Stats pos, yaw;
  int expected = 0, detected = 0, false_detections = 0, gross = 0, absent = 0;  // absent: out of view
};

double angleError(double a, double b, double period) { return std::fabs(foldAngle(a - b, period)); }

/// Whether all 8 corners of a box of @p extents (a shape's bounding box) at @p pose project inside the image (1 px margin) in front of the camera,
/// and whether none does (wholly outside the view); also its projected bounding box and depth.
struct Visibility {
  bool whole = true, none = true;
  cv::Rect2d box;
  double depth = 0;
};

Visibility visibility(const CameraModel& c, const Eigen::Isometry3d& world_from_camera, const Eigen::Isometry3d& pose,
                      const Eigen::Vector3d& extents) {
  Visibility vis;
  const Eigen::Isometry3d camera_from_cube = world_from_camera.inverse() * pose;
  double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d corner((i & 1 ? 0.5 : -0.5) * extents.x(), (i & 2 ? 0.5 : -0.5) * extents.y(),
                                 (i & 4 ? 0.5 : -0.5) * extents.z());
    const Eigen::Vector3d p = camera_from_cube * corner;
    if (p.z() <= c.near_clip) {
      vis.whole = false;
      continue;
    }
    const double u = c.fx * p.x() / p.z() + c.cx, v = c.fy * p.y() / p.z() + c.cy;
    const bool inside = u >= 1 && v >= 1 && u <= c.width - 1 && v <= c.height - 1;
    vis.whole = vis.whole && inside;
    if (u >= 0 && v >= 0 && u <= c.width && v <= c.height) vis.none = false;
    u0 = std::min(u0, u);
    v0 = std::min(v0, v);
    u1 = std::max(u1, u);
    v1 = std::max(v1, v);
  }
  vis.box = cv::Rect2d(u0, v0, u1 - u0, v1 - v0);
  vis.depth = camera_from_cube.translation().z();
  return vis;
}

}  // namespace

int main(int argc, char** argv) {
  const int scenes = argc > 1 ? std::atoi(argv[1]) : 500;
  const unsigned seed = argc > 2 ? static_cast<unsigned>(std::atoi(argv[2])) : 1u;
  const std::string out_dir = argc > 3 ? argv[3] : "";
  const double noise = argc > 4 ? std::atof(argv[4]) : 0.0;
  cv::theRNG().state = seed;
  auto addNoise = [&](cv::Mat& image) {
    if (noise <= 0) return;
    cv::Mat n(image.size(), CV_16SC3), wide;
    cv::randn(n, 0, noise);
    image.convertTo(wide, CV_16SC3);
    wide += n;
    wide.convertTo(image, CV_8UC3);  // saturating
  };
  const DefaultWorld w(std::string(XPERSIF_SOURCE_DIR) + "/worlds/default.yaml");
  const Renderer renderer(w.scene);
  const CameraModel& overhead = *w.scene.findCamera("overhead");
  const CameraModel& robot_camera = *w.scene.findCamera("robot_camera");
  const PerceptionCatalogue catalogue = PerceptionCatalogue::fromScene(w.scene);
  PerceptionOptions options;
  if (argc > 5) options.morphology_kernel = std::atoi(argv[5]);
  const FeatureExtractor top(catalogue, overhead, options), front(catalogue, robot_camera, options);

  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::map<std::string, Tally> over;  // by cube, overhead
  Tally robot_tally;
  Stats robot_pos, robot_yaw;
  std::map<std::string, Tally> ahead;  // robot camera, by distance band
  const char* bands[] = {"< 0.20 m", "0.20-0.40 m", ">= 0.40 m"};
  std::ostringstream csv;
  csv << "scene,camera,object,truth_x,truth_y,truth_yaw,found,x,y,yaw,position_error_m,yaw_error_rad,distance_m\n";

  for (int s = 0; s < scenes; ++s) {
    // Overhead: one cube in ten is put out of view, to count false detections.
    const FrameTransforms current = randomScene(w, rng, 0.1);
    Frame f = render(renderer, w.scene, current, overhead);
    addNoise(f.image);
    const Detections d = top.extract(f.image, f.world_from_camera);
    for (const std::string& name : cubeNames()) {
      Tally& t = over[name];
      const Eigen::Isometry3d& truth = current.at(name);
      const bool in_view = truth.translation().x() < 1.0;
      const auto it = d.objects.find(name);
      csv << s << ",overhead," << name << "," << truth.translation().x() << "," << truth.translation().y() << ","
          << yawOf(truth) << "," << (it != d.objects.end());
      if (it != d.objects.end()) {
        const double pe = (it->second.position - truth.translation()).norm();
        const double ye = angleError(it->second.yaw, yawOf(truth), M_PI / 2);
        csv << "," << it->second.position.x() << "," << it->second.position.y() << "," << it->second.yaw << "," << pe
            << "," << ye;
        if (!in_view || pe > 0.02) ++t.false_detections;
        if (in_view) {
          t.pos.add(pe);
          t.yaw.add(ye);
        }
      } else {
        csv << ",,,,,";
      }
      csv << ",\n";
      if (!in_view) ++t.absent;
      if (in_view) {
        ++t.expected;
        if (it != d.objects.end()) ++t.detected;
      }
    }
    const Eigen::Isometry3d& rt = current.at(w.scene.robot_root);
    ++robot_tally.expected;
    if (d.robot.found) {
      ++robot_tally.detected;
      robot_pos.add(std::hypot(d.robot.x - rt.translation().x(), d.robot.y - rt.translation().y()));
      if (d.robot.yaw_known) robot_yaw.add(angleError(d.robot.yaw, yawOf(rt), 2 * M_PI));
    }

    // Robot camera: the robot turned towards one of the cubes (within +-0.35 rad), all cubes in the arena.
    FrameTransforms facing = randomScene(w, rng, 0.0);
    const std::string& target = cubeNames()[static_cast<std::size_t>(unit(rng) * 4) % 4];
    Eigen::Isometry3d& base = facing[w.scene.robot_root];
    const Eigen::Vector3d to = facing.at(target).translation() - base.translation();
    base = planar(base.translation().x(), base.translation().y(), base.translation().z(),
                  std::atan2(to.y(), to.x()) + 0.7 * (unit(rng) - 0.5));
    Frame g = render(renderer, w.scene, facing, robot_camera);
    addNoise(g.image);
    const Detections e = front.extract(g.image, g.world_from_camera);
    std::map<std::string, Visibility> vis;
    for (const std::string& name : cubeNames()) vis[name] = visibility(robot_camera, g.world_from_camera, facing.at(name), Eigen::Vector3d::Constant(0.04));
    for (const std::string& name : cubeNames()) {
      const Visibility& v = vis[name];
      bool hidden = false;  // behind a nearer cube's projected box
      for (const std::string& other : cubeNames()) {
        if (other != name && vis[other].depth > 0 && vis[other].depth < v.depth &&
            (vis[other].box & v.box).area() > 0) {
          hidden = true;
        }
      }
      const auto it = e.objects.find(name);
      const Eigen::Vector3d truth = facing.at(name).translation();
      const double distance = (truth - g.world_from_camera.translation()).head<2>().norm();
      const int band = distance < 0.2 ? 0 : (distance < 0.4 ? 1 : 2);
      Tally& t = ahead[bands[band]];
      if (v.none) ++t.absent;
      if (v.none && it != e.objects.end()) ++t.false_detections;
      if (!v.whole || hidden) continue;
      ++t.expected;
      csv << s << ",robot_camera," << name << "," << truth.x() << "," << truth.y() << "," << yawOf(facing.at(name))
          << "," << (it != e.objects.end());
      if (it != e.objects.end()) {
        ++t.detected;
        const double pe = (it->second.position.head<2>() - truth.head<2>()).norm();
        t.pos.add(pe);
        if (pe > 0.05) ++t.gross;
        csv << "," << it->second.position.x() << "," << it->second.position.y() << ",," << pe << ",";
      } else {
        csv << ",,,,,";
      }
      csv << "," << distance << "\n";
    }
  }


  // ---- the shapes world: boxes, cylinders and spheres, two colours shared by two objects each ----------
  const DefaultWorld sw = shapesWorld(std::string(XPERSIF_SOURCE_DIR) + "/worlds/default.yaml");
  const Renderer shapes_renderer(sw.scene);
  const PerceptionCatalogue shapes_catalogue = PerceptionCatalogue::fromScene(sw.scene);
  const FeatureExtractor shapes_top(shapes_catalogue, *sw.scene.findCamera("overhead"), options),
      shapes_front(shapes_catalogue, *sw.scene.findCamera("robot_camera"), options);
  struct ShapeTally {
    Tally over, ahead;
    int swapped_over = 0, swapped_ahead = 0;
  };
  std::map<std::string, ShapeTally> shapes;
  auto extentsOf = [&](const ObjectAppearance& o) {
    if (o.shape.type == Shape::Type::Box) return o.shape.box_size;
    return Eigen::Vector3d(2 * o.shape.radius, 2 * o.shape.radius, o.height());
  };
  // The other object of the same colour, or "".
  auto partnerOf = [&](const ObjectAppearance& o) {
    for (const ObjectAppearance& p : shapes_catalogue.objects) {
      if (p.name != o.name && p.color.r == o.color.r && p.color.g == o.color.g && p.color.b == o.color.b) return p.name;
    }
    return std::string();
  };
  for (int s = 0; s < scenes; ++s) {
    const FrameTransforms current = randomShapesScene(sw, rng, 0.1);
    Frame f = render(shapes_renderer, sw.scene, current, *sw.scene.findCamera("overhead"));
    addNoise(f.image);
    const Detections d = shapes_top.extract(f.image, f.world_from_camera);
    for (const ObjectAppearance& o : shapes_catalogue.objects) {
      ShapeTally& st = shapes[o.name];
      Tally& t = st.over;
      const Eigen::Isometry3d& truth = current.at(o.name);
      const bool in_view = truth.translation().x() < 1.0;
      const auto it = d.objects.find(o.name);
      if (!in_view) ++t.absent;
      if (in_view) ++t.expected;
      csv << s << ",shapes_overhead," << o.name << "," << truth.translation().x() << "," << truth.translation().y()
          << "," << yawOf(truth) << "," << (it != d.objects.end());
      if (it == d.objects.end()) {
        csv << ",,,,,,\n";
        continue;
      }
      const double pe = (it->second.position - truth.translation()).norm();
      const double period = it->second.yaw_period;
      const double ye = it->second.yaw_known ? angleError(it->second.yaw, yawOf(truth), period) : 0;
      csv << "," << it->second.position.x() << "," << it->second.position.y() << "," << it->second.yaw << "," << pe
          << "," << ye << ",\n";
      if (!in_view || pe > 0.02) ++t.false_detections;
      const std::string partner = partnerOf(o);
      if (!partner.empty() && (it->second.position - current.at(partner).translation()).norm() < pe) ++st.swapped_over;
      if (in_view) {
        ++t.detected;
        t.pos.add(pe);
        if (it->second.yaw_known) t.yaw.add(ye);
      }
    }

    // Robot camera: turned towards one object (within +-0.35 rad); objects wholly in view and not hidden.
    FrameTransforms facing = randomShapesScene(sw, rng, 0.0);
    const std::size_t n_objects = shapes_catalogue.objects.size();
    const std::string& target = shapes_catalogue.objects[static_cast<std::size_t>(unit(rng) * n_objects) % n_objects].name;
    Eigen::Isometry3d& base = facing[sw.scene.robot_root];
    const Eigen::Vector3d to = facing.at(target).translation() - base.translation();
    base = planar(base.translation().x(), base.translation().y(), base.translation().z(),
                  std::atan2(to.y(), to.x()) + 0.7 * (unit(rng) - 0.5));
    const CameraModel& shapes_robot_camera = *sw.scene.findCamera("robot_camera");
    Frame g = render(shapes_renderer, sw.scene, facing, shapes_robot_camera);
    addNoise(g.image);
    const Detections e = shapes_front.extract(g.image, g.world_from_camera);
    std::map<std::string, Visibility> vis;
    for (const ObjectAppearance& o : shapes_catalogue.objects) {
      vis[o.name] = visibility(shapes_robot_camera, g.world_from_camera, facing.at(o.name), extentsOf(o));
    }
    for (const ObjectAppearance& o : shapes_catalogue.objects) {
      ShapeTally& st = shapes[o.name];
      Tally& t = st.ahead;
      const Visibility& v = vis[o.name];
      bool hidden = false;
      for (const auto& [other, ov] : vis) {
        if (other != o.name && ov.depth > 0 && ov.depth < v.depth && (ov.box & v.box).area() > 0) hidden = true;
      }
      const auto it = e.objects.find(o.name);
      if (v.none) ++t.absent;
      if (v.none && it != e.objects.end()) ++t.false_detections;
      if (!v.whole || hidden) continue;
      ++t.expected;
      const Eigen::Vector3d truth = facing.at(o.name).translation();
      const double distance = (truth - g.world_from_camera.translation()).head<2>().norm();
      csv << s << ",shapes_robot_camera," << o.name << "," << truth.x() << "," << truth.y() << ","
          << yawOf(facing.at(o.name)) << "," << (it != e.objects.end());
      if (it == e.objects.end()) {
        csv << ",,,,," << distance << "\n";
        continue;
      }
      ++t.detected;
      const double pe = (it->second.position.head<2>() - truth.head<2>()).norm();
      t.pos.add(pe);
      if (pe > 0.05) ++t.gross;
      const std::string partner = partnerOf(o);
      if (!partner.empty() && (it->second.position.head<2>() - facing.at(partner).translation().head<2>()).norm() < pe) {
        ++st.swapped_ahead;
      }
      csv << "," << it->second.position.x() << "," << it->second.position.y() << ",," << pe << "," << distance << "\n";
    }
  }

  std::ostringstream md;
  md << "perception_accuracy: " << scenes << " random scenes of the default world, seed " << seed
     << ", image noise sigma " << noise << ", morphology kernel " << options.morphology_kernel << "\n\n";
  md << "Overhead camera (600 x 416, fx = 650, 1.2 m up); errors against the rendered poses; yaw modulo pi/2.\n\n";
  md << "False detections: reported while out of view (of how many out-of-view samples), or > 2 cm off.\n\n";
  md << "| cube | detected | false det. | position error mm: mean | p95 | max | yaw error deg: mean | p95 | max |\n";
  md << "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const std::string& name : cubeNames()) {
    const Tally& t = over[name];
    md << "| " << name << " | " << t.detected << "/" << t.expected << " | " << t.false_detections << " (of " << t.absent
       << ") | "
       << t.pos.row(1000, 2) << " | " << t.yaw.row(180 / M_PI, 2) << " |\n";
  }
  md << "| robot | " << robot_tally.detected << "/" << robot_tally.expected << " | – | " << robot_pos.row(1000, 2)
     << " | " << robot_yaw.row(180 / M_PI, 2) << " (heading, modulo 2 pi; " << robot_yaw.v.size()
     << " with the marker seen) |\n\n";
  md << "Robot camera (160 x 120, fx = 120), robot turned towards a random cube; cubes wholly in view and not\n"
        "behind another cube, by horizontal distance from the camera; position error in the floor plane.\n\n";
  md << "| distance | detected | false det. (wholly out of view) | >5 cm off | position error mm: mean | p95 | max |\n";
  md << "| --- | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const char* band : bands) {
    const Tally& t = ahead[band];
    md << "| " << band << " | " << t.detected << "/" << t.expected << " | " << t.false_detections << " (of " << t.absent
       << ") | " << t.gross
       << " | " << t.pos.row(1000, 1) << " |\n";
  }
  auto shapeWord = [](const ObjectAppearance& o) {
    switch (o.shape.type) {
      case Shape::Type::Box:
        return "box " + std::to_string(static_cast<int>(std::lround(o.shape.box_size.x() * 100))) + "x" +
               std::to_string(static_cast<int>(std::lround(o.shape.box_size.y() * 100))) + "x" +
               std::to_string(static_cast<int>(std::lround(o.shape.box_size.z() * 100))) + " cm";
      case Shape::Type::Cylinder:
        return "cylinder r " + std::to_string(static_cast<int>(std::lround(o.shape.radius * 1000))) + " mm, h " +
               std::to_string(static_cast<int>(std::lround(o.shape.length * 1000))) + " mm";
      case Shape::Type::Sphere:
        return "sphere r " + std::to_string(static_cast<int>(std::lround(o.shape.radius * 1000))) + " mm";
    }
    return std::string();
  };
  md << "\nShapes world, overhead camera: position error 3-D (centre); yaw error modulo the shape's symmetry (boxes\n"
        "only: cylinders and spheres report no yaw); swapped: reported nearer its same-coloured partner's place.\n\n";
  md << "| object | shape | detected | false det. | swapped | position error mm: mean | p95 | max | yaw error deg: mean | p95 | max |\n";
  md << "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const ObjectAppearance& o : shapes_catalogue.objects) {
    const ShapeTally& st = shapes[o.name];
    const Tally& t = st.over;
    md << "| " << o.name << " | " << shapeWord(o) << " | " << t.detected << "/" << t.expected << " | "
       << t.false_detections << " (of " << t.absent << ") | " << st.swapped_over << " | " << t.pos.row(1000, 2) << " | "
       << (o.rotationallySymmetric() ? std::string("– | – | –") : t.yaw.row(180 / M_PI, 2)) << " |\n";
  }
  md << "\nShapes world, robot camera (turned towards a random object): objects wholly in view and not behind\n"
        "another, all distances; position error in the floor plane.\n\n";
  md << "| object | shape | detected | false det. (wholly out of view) | swapped | >5 cm off | position error mm: mean | p95 | max |\n";
  md << "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const ObjectAppearance& o : shapes_catalogue.objects) {
    const ShapeTally& st = shapes[o.name];
    const Tally& t = st.ahead;
    md << "| " << o.name << " | " << shapeWord(o) << " | " << t.detected << "/" << t.expected << " | "
       << t.false_detections << " (of " << t.absent << ") | " << st.swapped_ahead << " | " << t.gross << " | "
       << t.pos.row(1000, 1) << " |\n";
  }
  std::fputs(md.str().c_str(), stdout);
  if (!out_dir.empty()) {
    const std::string base = out_dir + "/perception_accuracy" +
                             (noise > 0 ? "_noise" + std::to_string(static_cast<int>(noise)) : std::string());
    std::ofstream(base + ".md") << md.str();
    std::ofstream(base + ".csv") << csv.str();
  }
  return 0;
}
