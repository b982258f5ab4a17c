#include "xpersif/core/perception/perception_check.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "xpersif/core/common/validation.h"
#include "xpersif/core/perception/background.h"
#include "xpersif/core/perception/robot_tracker.h"
#include "xpersif/core/render/renderer.h"

namespace xpersif::core {

namespace {

std::string mm(double metres) { return describeNumber(std::round(metres * 10000) / 10) + " mm"; }
std::string px(double pixels) { return describeNumber(std::round(pixels * 10) / 10) + " px"; }
double yawOf(const Eigen::Isometry3d& t) { return std::atan2(t.linear()(1, 0), t.linear()(0, 0)); }

// The arena's far corner as seen by a camera: the largest depth of the four corners at height @p z, and whether
// all of them project into the image.
struct Corners {
  double depth = 0;
  std::string outside;  // "" or the first corner out of view, e.g. "(0.75, -0.5)"
};
Corners arenaCorners(const CameraModel& camera, const Eigen::Isometry3d& world_from_camera, double sx, double sy,
                     double z) {
  Corners c;
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d w((i & 1 ? 0.5 : -0.5) * sx, (i & 2 ? 0.5 : -0.5) * sy, z);
    const Eigen::Vector3d p = camera_from_world * w;
    c.depth = std::max(c.depth, p.z());
    const double u = camera.fx * p.x() / p.z() + camera.cx, v = camera.fy * p.y() / p.z() + camera.cy;
    if (c.outside.empty() && (!(p.z() > 0) || u < 0 || v < 0 || u > camera.width || v > camera.height)) {
      c.outside = "(" + describeNumber(w.x()) + ", " + describeNumber(w.y()) + ")";
    }
  }
  return c;
}

std::string tooCoarse(const CameraModel& camera, const std::string& what, double size, double seen, double needed,
                      double depth, const std::string& unit) {
  const double focal = std::min(camera.fx, camera.fy);
  const double scale = needed / seen;
  return "camera '" + camera.name + "' (" + std::to_string(camera.width) + " x " + std::to_string(camera.height) +
         " px, focal length " + describeNumber(focal) + " px) is too coarse for this arena: at its far corner, " +
         describeNumber(std::round(depth * 100) / 100) + " m away, " + what + " (" + mm(size) + ") covers " +
         px(seen) + unit + " and FEATUREEXTRACTION needs " + px(needed) + "; give the camera a focal length of at "
         "least " + describeNumber(std::ceil(focal * scale)) + " px (an image of " +
         std::to_string(static_cast<int>(std::ceil(camera.width * scale))) + " x " +
         std::to_string(static_cast<int>(std::ceil(camera.height * scale))) + " px for the same view), hang it " +
         "lower, or make it at least " + mm(size * scale);
}

}  // namespace

std::string checkCoverage(const PerceptionCatalogue& catalogue, const CameraModel& camera,
                          const Eigen::Isometry3d& world_from_camera, double arena_size_x, double arena_size_y) {
  const double focal = std::min(camera.fx, camera.fy);
  const Corners floor = arenaCorners(camera, world_from_camera, arena_size_x, arena_size_y, 0);
  if (!floor.outside.empty()) {
    return "camera '" + camera.name + "' does not see the whole arena: its corner " + floor.outside +
           " falls outside the " + std::to_string(camera.width) + " x " + std::to_string(camera.height) +
           " px image; hang the camera higher or give it a shorter focal length";
  }
  for (const ObjectAppearance& o : catalogue.objects) {
    const double side = o.footprint().minCoeff();
    const double depth = arenaCorners(camera, world_from_camera, arena_size_x, arena_size_y, o.height()).depth;
    const double seen = focal * side / depth;
    if (seen < kMinObjectPixelsAcross) {
      return tooCoarse(camera, "object '" + o.name + "'", side, seen, kMinObjectPixelsAcross, depth, " across");
    }
  }
  const RobotAppearance& r = catalogue.robot;
  if (!r.present) return "";
  if (r.fiducial.dictionary >= 0) {
    const double top = r.root_height + r.fiducial.root_from_marker.translation().z();
    const double depth = arenaCorners(camera, world_from_camera, arena_size_x, arena_size_y, top).depth;
    const double cell_size = fiducialCellSize(r);
    const double cell = focal * cell_size / depth;
    if (cell < kMinFiducialCellPixels) {
      return tooCoarse(camera, "a cell of the robot's fiducial", cell_size, cell,
                       kMinFiducialCellPixels, depth, "");
    }
  } else if (r.marker_size.minCoeff() > 0) {
    // A coloured marker is found by its area; the sizes scale with the square root of the pixels.
    const double area = r.marker_size.x() * r.marker_size.y();
    const double depth = arenaCorners(camera, world_from_camera, arena_size_x, arena_size_y, r.marker_top).depth;
    const double seen = camera.fx * camera.fy * area / (depth * depth);
    if (seen < kMinMarkerPixels) {
      return tooCoarse(camera, "the robot's heading marker", std::sqrt(area), std::sqrt(seen),
                       std::sqrt(kMinMarkerPixels), depth,
                       " across (" + px(seen) + " in all; a fiducial on the robot would do better)");
    }
  }
  return "";
}

namespace {

// Renders the scene, and the scene without one node, from one camera.
struct SceneImages {
  const SceneDescription& scene;
  const FrameTransforms& world;
  const CameraModel& camera;
  Eigen::Isometry3d pose;

  cv::Mat render(const SceneDescription& s) const {
    cv::Mat image;
    Renderer(s).render(camera, pose, world, image);
    return image;
  }
  // The pixels where @p node (and the nodes below it) shows: the image changes when they are painted another
  // colour (magenta, or green for a magenta thing). Removing them would miss a face the colour of the floor.
  cv::Mat visiblePixels(const cv::Mat& full, const std::string& node) const {
    SceneDescription painted = scene;
    std::set<std::string> below = {node};
    for (SceneNode& n : painted.nodes) {
      if (!below.count(n.name) && !below.count(n.parent)) continue;
      below.insert(n.name);
      for (Visual& v : n.visuals) v.color = v.color.g < 0.5f && v.color.r > 0.5f ? Rgba{0, 1, 0, 1} : Rgba{1, 0, 1, 1};
    }
    cv::Mat diff, mask;
    cv::absdiff(full, render(painted), diff);
    cv::cvtColor(diff, mask, cv::COLOR_BGR2GRAY);
    return mask > 0;
  }
};

// Why an object or the robot was not found: out of view, indistinguishable from the empty arena, or seen but not
// measured.
std::string whyNotFound(const SceneImages& images, const cv::Mat& full, const cv::Mat& background,
                        const std::string& node, const PerceptionOptions& options) {
  const cv::Mat visible = images.visiblePixels(full, node);
  const int pixels = cv::countNonZero(visible);
  if (pixels == 0) return "not in view, or hidden behind something";
  cv::Mat diff;
  cv::absdiff(full, background, diff);
  std::vector<cv::Mat> channels;
  cv::split(diff, channels);
  cv::Mat total;
  cv::add(channels[0], channels[1], total, cv::noArray(), CV_16U);
  cv::add(total, channels[2], total, cv::noArray(), CV_16U);
  double most = 0;
  cv::minMaxLoc(total, nullptr, &most, nullptr, nullptr, visible);
  const int standing_out = cv::countNonZero((total >= options.background_difference) & visible);
  if (standing_out < std::max(options.min_blob_pixels, 0.5 * pixels)) {
    // Its shaded sides may stand out while its top, which is measured, does not.
    return std::to_string(pixels - standing_out) + " of its " + std::to_string(pixels) +
           " px differ from the empty arena behind them by less than FEATUREEXTRACTION needs (" +
           describeNumber(options.background_difference) + " of 765 in colour; at most " + describeNumber(most) +
           "): it looks like the floor or the walls; give it a colour or brightness of its own";
  }
  return "seen (" + std::to_string(pixels) + " px, " + std::to_string(standing_out) +
         " standing out from the empty arena) but not measured: its top face is hidden, cut by the image border, "
         "too small, or its colour is taken for another object's";
}

void checkObjects(const SceneImages& images, const FeatureExtractor& extractor, const Detections& seen,
                  const cv::Mat& full, const cv::Mat& background, CameraPerception& out) {
  for (const ObjectAppearance& o : extractor.catalogue().objects) {
    PerceivedThing t;
    t.name = o.name;
    const auto it = seen.objects.find(o.name);
    t.found = it != seen.objects.end();
    if (!t.found) {
      t.reason = whyNotFound(images, full, background, o.name, extractor.options());
    } else {
      const Eigen::Isometry3d truth = images.world.at(o.name);
      t.position_error = (it->second.position.head<2>() - truth.translation().head<2>()).norm();
      if (it->second.yaw_known) {
        t.yaw_checked = true;
        t.yaw_error = std::fabs(foldAngle(it->second.yaw - yawOf(truth), it->second.yaw_period));
      }
      const double allowed = 0.25 * o.footprint().minCoeff();
      if (out.downward && t.position_error > allowed) {
        t.reason = "measured " + mm(t.position_error) + " from where it is, more than a quarter of its size (" +
                   mm(allowed) + ")";
      }
    }
    out.objects.push_back(t);
  }
}

void checkRobot(const SceneImages& images, const FeatureExtractor& extractor, const Detections& seen,
                const cv::Mat& full, const cv::Mat& background, CameraPerception& out) {
  const RobotAppearance& r = extractor.catalogue().robot;
  out.robot_looked_for = r.present && out.downward;
  if (!out.robot_looked_for) return;
  PerceivedThing& t = out.robot;
  t.name = r.name;
  t.found = seen.robot.found && seen.robot.yaw_known;
  if (!t.found) {
    const std::string how = r.fiducial.dictionary >= 0 ? "its fiducial was not detected"
                            : seen.robot.found        ? "its heading marker was not found"
                                                      : "its body was not found";
    const std::string why = whyNotFound(images, full, background, r.name, extractor.options());
    t.reason = how + (why.rfind("seen", 0) == 0 ? "" : ": " + why);
    return;
  }
  const Eigen::Isometry3d truth = images.world.at(r.name);
  t.position_error = (Eigen::Vector2d(seen.robot.x, seen.robot.y) - truth.translation().head<2>()).norm();
  t.yaw_checked = true;
  t.yaw_error = std::fabs(foldAngle(seen.robot.yaw - yawOf(truth), 2 * M_PI));
  constexpr double kAllowed = 0.01, kAllowedYaw = 0.1;
  if (t.position_error > kAllowed || t.yaw_error > kAllowedYaw) {
    t.reason = "measured " + mm(t.position_error) + " and " + describeNumber(std::round(t.yaw_error * 573) / 10) +
               " degrees from its pose (at most " + mm(kAllowed) + " and " +
               describeNumber(std::round(kAllowedYaw * 573) / 10) + " degrees do)";
  }
}

}  // namespace

PerceptionCheck checkPerception(const SceneDescription& scene, const FrameTransforms& current,
                                const PerceptionOptions& options) {
  PerceptionCheck check;
  const FrameTransforms world = worldTransforms(scene, current);
  auto background = std::make_shared<RenderedBackground>(scene);
  const PerceptionCatalogue catalogue = PerceptionCatalogue::fromScene(scene);
  for (const CameraModel& camera : scene.cameras) {
    CameraPerception out;
    out.camera = camera.name;
    const SceneImages images{scene, world, camera, cameraWorldPose(scene, world, camera)};
    out.downward = isDownwardCamera(images.pose, options.max_downward_tilt);
    try {
      const FeatureExtractor extractor(catalogue, camera, options, background);
      if (out.downward) {
        out.refusal = checkCoverage(catalogue, camera, images.pose, scene.arena_size_x, scene.arena_size_y);
      }
      if (out.refusal.empty()) {
        const cv::Mat full = images.render(scene);
        const cv::Mat empty = background->imageFor(camera, images.pose);
        const Detections seen = extractor.extract(full, images.pose);
        checkObjects(images, extractor, seen, full, empty, out);
        checkRobot(images, extractor, seen, full, empty, out);
      }
    } catch (const std::exception& e) {
      out.refusal = "camera '" + camera.name + "' cannot be used: " + e.what();
    }
    check.cameras.push_back(out);
  }
  return check;
}

std::string PerceptionCheck::problem() const {
  for (const CameraPerception& c : cameras) {
    if (!c.refusal.empty()) return c.refusal;
    if (!c.downward) continue;
    for (const PerceivedThing& t : c.objects) {
      if (!t.reason.empty()) {
        return "camera '" + c.camera + "' " + (t.found ? "misplaces" : "cannot find") + " object '" + t.name +
               "' at the start: " + t.reason;
      }
    }
    if (c.robot_looked_for && !c.robot.reason.empty()) {
      return "camera '" + c.camera + "' " + (c.robot.found ? "misplaces" : "cannot find") + " the robot '" +
             c.robot.name + "' at the start: " + c.robot.reason;
    }
  }
  return "";
}

std::string PerceptionCheck::describe() const {
  std::ostringstream out;
  auto line = [&](const PerceivedThing& t, bool robot) {
    out << "    " << (robot ? "robot '" + t.name + "'" : t.name) << ": ";
    if (!t.found) {
      out << "not found: " << t.reason << "\n";
      return;
    }
    out << "found, " << mm(t.position_error) << " off";
    if (t.yaw_checked) out << ", yaw " << describeNumber(std::round(t.yaw_error * 573) / 10) << " degrees off";
    if (!t.reason.empty()) out << ": " << t.reason;
    out << "\n";
  };
  for (const CameraPerception& c : cameras) {
    out << "  camera '" << c.camera << "' (" << (c.downward ? "from above" : "from the side") << ")";
    if (!c.refusal.empty()) {
      out << ": " << c.refusal << "\n";
      continue;
    }
    out << ":\n";
    for (const PerceivedThing& t : c.objects) line(t, false);
    if (c.robot_looked_for) line(c.robot, true);
  }
  return out.str();
}

}  // namespace xpersif::core
