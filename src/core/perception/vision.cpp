#include "xpersif/core/perception/vision.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::vector<std::string> featureNames() {
  std::vector<std::string> names;
  for (const auto& f : availableFeatures()) names.push_back(f.name);
  return names;
}

/// Mean colour (r, g, b in 0..1) of the object's top face, or of the brightest shade of its blob when the top
/// face is unknown (forward camera): the face lit most squarely, i.e. its colour as near its base colour as
/// the image shows it.
cv::Vec3d meanColor(const cv::Mat& bgr, const ObjectDetection& det) {
  const std::vector<cv::Point>& outline = det.top_contour.empty() ? det.contour : det.top_contour;
  if (outline.empty()) return {kNaN, kNaN, kNaN};
  const cv::Rect roi = cv::boundingRect(outline) & cv::Rect(0, 0, bgr.cols, bgr.rows);
  if (roi.empty()) return {kNaN, kNaN, kNaN};
  cv::Mat mask = cv::Mat::zeros(roi.size(), CV_8U);
  cv::drawContours(mask, std::vector<std::vector<cv::Point>>{outline}, 0, cv::Scalar(255), cv::FILLED, cv::LINE_8,
                   cv::noArray(), 0, -roi.tl());
  const cv::Mat patch = bgr(roi);
  if (det.top_contour.empty()) {
    cv::Mat brightness, patch_f;
    patch.convertTo(patch_f, CV_32FC3);
    cv::transform(patch_f, brightness, cv::Matx13f(1, 1, 1));
    double max_value = 0;
    cv::minMaxLoc(brightness, nullptr, &max_value, nullptr, nullptr, mask);
    cv::Mat bright;
    cv::compare(brightness, 0.9 * max_value, bright, cv::CMP_GE);
    cv::bitwise_and(mask, bright, mask);
  }
  if (cv::countNonZero(mask) == 0) return {kNaN, kNaN, kNaN};
  const cv::Scalar m = cv::mean(patch, mask);
  return {m[2] / 255.0, m[1] / 255.0, m[0] / 255.0};
}

/// HSV hue (deg, 0..360) and saturation (0..1) of an RGB colour.
void hueSaturation(const cv::Vec3d& rgb, double& hue, double& saturation) {
  const double r = rgb[0], g = rgb[1], b = rgb[2];
  const double mx = std::max({r, g, b}), mn = std::min({r, g, b}), c = mx - mn;
  saturation = mx > 0 ? c / mx : 0;
  if (!(c > 0)) {
    hue = std::isnan(c) ? kNaN : 0;
    return;
  }
  double h;
  if (mx == r) {
    h = std::fmod((g - b) / c, 6.0);
  } else if (mx == g) {
    h = (b - r) / c + 2;
  } else {
    h = (r - g) / c + 4;
  }
  hue = h * 60;
  if (hue < 0) hue += 360;
}

}  // namespace

const std::vector<FeatureInfo>& availableFeatures() {
  static const std::vector<FeatureInfo> features = {
      {"x", "m", "x of the object's centre in the world frame"},
      {"y", "m", "y of the object's centre in the world frame"},
      {"hue", "deg", "hue (HSV, 0..360) of the mean colour of the object's top face"},
      {"saturation", "1", "saturation (HSV, 0..1) of the mean colour of the object's top face"},
      {"color_r", "1", "mean red of the object's top-face pixels, 0..1"},
      {"color_g", "1", "mean green of the object's top-face pixels, 0..1"},
      {"color_b", "1", "mean blue of the object's top-face pixels, 0..1"},
      {"size", "m", "edge length: mean of the back-projected top face's sides (forward camera: visible height)"},
      {"area", "m^2", "area of the back-projected top face"},
      {"orientation", "rad", "yaw modulo the object's symmetry (pi/2 for a cube), in (-period/2, period/2]; 0 for round objects"},
      {"elongation", "1", "long side over short side of the top face (1 for a square)"},
      {"distance_to_robot", "m", "horizontal distance from the robot's centre to the object's centre"},
      {"bearing_from_robot", "rad", "direction of the object in the robot's frame (0 ahead, + to the left)"},
      {"distance_to_wall", "m", "horizontal distance from the object's centre to the nearest inner wall face"},
      {"confidence", "1", "the detection's confidence, 0..1"},
  };
  return features;
}

const std::vector<std::string>& objectFeatureNames() {
  static const std::vector<std::string> names = {"hue",  "saturation", "color_r", "color_g",
                                                 "color_b", "size",    "area",    "elongation"};
  return names;
}

FeatureSelection::FeatureSelection() : names_(defaultNames()) {}

FeatureSelection::FeatureSelection(const std::vector<std::string>& names) { set(names); }

std::vector<std::string> FeatureSelection::defaultNames() {
  return {"x", "y", "hue", "size", "orientation", "distance_to_robot", "bearing_from_robot", "distance_to_wall"};
}

void FeatureSelection::set(const std::vector<std::string>& names) {
  if (names.empty()) {
    throw ValidationError("the feature selection is empty; choose at least one feature (e.g. hue, size)");
  }
  const std::vector<std::string> known = featureNames();
  std::vector<std::string> unique;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (std::find(known.begin(), known.end(), names[i]) == known.end()) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw ValidationError("feature '" + names[i] + "' (features[" + std::to_string(i) +
                            "]) is unknown; the features are: " + list);
    }
    if (std::find(unique.begin(), unique.end(), names[i]) == unique.end()) unique.push_back(names[i]);
  }
  names_ = std::move(unique);
}

void FeatureSelection::reset() { names_ = defaultNames(); }

bool FeatureSelection::contains(const std::string& name) const {
  return std::find(names_.begin(), names_.end(), name) != names_.end();
}

std::map<std::string, std::map<std::string, double>> Vision::compute(const cv::Mat& bgr, const Detections& detections,
                                                                     const FeatureSelection& selection,
                                                                     const ArenaExtents& arena,
                                                                     const std::optional<Pose2D>& robot) const {
  if (bgr.empty()) throw ValidationError("the image is empty; VISION needs the image the detections came from");
  if (bgr.type() != CV_8UC3) {
    throw ValidationError("the image has " + std::to_string(bgr.channels()) + " channel(s) of depth code " +
                          std::to_string(bgr.depth()) + "; expected 8-bit BGR (CV_8UC3)");
  }
  requirePositive("arena.size_x", arena.size_x);
  requirePositive("arena.size_y", arena.size_y);
  if (robot) {
    requireFinite("robot.x", robot->x);
    requireFinite("robot.y", robot->y);
    requireFinite("robot.yaw", robot->yaw);
  }
  // The robot pose for the relational features: given, else detected (its heading only if seen).
  bool have_robot = false, have_heading = false;
  Pose2D r;
  if (robot) {
    r = *robot;
    have_robot = have_heading = true;
  } else if (detections.robot.found) {
    r = {detections.robot.x, detections.robot.y, detections.robot.yaw};
    have_robot = true;
    have_heading = detections.robot.yaw_known;
  }

  const bool need_color = selection.contains("hue") || selection.contains("saturation") ||
                          selection.contains("color_r") || selection.contains("color_g") ||
                          selection.contains("color_b");
  std::map<std::string, std::map<std::string, double>> out;
  for (const auto& [name, det] : detections.objects) {
    cv::Vec3d rgb(kNaN, kNaN, kNaN);
    double hue = kNaN, saturation = kNaN;
    if (need_color) {
      rgb = meanColor(bgr, det);
      hueSaturation(rgb, hue, saturation);
    }
    const bool top_known = det.top_corners.size() == 4;
    // A round object (upright cylinder, sphere) looks the same at every yaw: its frame is the world's.
    const bool round = det.yaw_period >= 2 * M_PI - 1e-9;
    const double dx = det.position.x() - r.x, dy = det.position.y() - r.y;
    std::map<std::string, double>& f = out[name];
    for (const std::string& feature : selection.names()) {
      double v = kNaN;
      if (feature == "x") {
        v = det.position.x();
      } else if (feature == "y") {
        v = det.position.y();
      } else if (feature == "hue") {
        v = hue;
      } else if (feature == "saturation") {
        v = saturation;
      } else if (feature == "color_r") {
        v = rgb[0];
      } else if (feature == "color_g") {
        v = rgb[1];
      } else if (feature == "color_b") {
        v = rgb[2];
      } else if (feature == "size") {
        v = top_known ? 0.5 * (det.measured_length + det.measured_width) : det.measured_width;
        if (!(v > 0)) v = kNaN;
      } else if (feature == "area") {
        if (top_known) v = det.measured_length * det.measured_width;
        if (round && det.measured_width > 0) v = M_PI * 0.25 * det.measured_width * det.measured_width;
      } else if (feature == "orientation") {
        if (det.yaw_known) v = det.yaw;
        if (round) v = 0.0;
      } else if (feature == "elongation") {
        if (top_known && det.measured_width > 0) v = det.measured_length / det.measured_width;
        if (round) v = 1.0;
      } else if (feature == "distance_to_robot") {
        if (have_robot) v = std::hypot(dx, dy);
      } else if (feature == "bearing_from_robot") {
        if (have_robot && have_heading) v = foldAngle(std::atan2(dy, dx) - r.yaw, 2 * M_PI);
      } else if (feature == "distance_to_wall") {
        v = std::min(0.5 * arena.size_x - std::fabs(det.position.x()), 0.5 * arena.size_y - std::fabs(det.position.y()));
      } else if (feature == "confidence") {
        v = det.confidence;
      }
      f[feature] = v;
    }
  }
  return out;
}

}  // namespace xpersif::core
