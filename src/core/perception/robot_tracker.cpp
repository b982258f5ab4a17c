#include "xpersif/core/perception/robot_tracker.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

// The robot's parts as one node, all white: drawn on black, any lit pixel is the robot.
SceneDescription bodyScene(const RobotAppearance& robot) {
  SceneDescription scene;
  SceneNode node;
  node.name = "robot";
  node.parent = scene.world_frame;
  node.dynamic = true;
  for (Visual v : robot.parts) {
    v.color = Rgba{1, 1, 1, 1};
    node.visuals.push_back(v);
  }
  scene.nodes.push_back(node);
  return scene;
}

RenderOptions blackBackground() {
  RenderOptions options;
  options.background_bgr = cv::Vec3b(0, 0, 0);
  return options;
}

cv::Ptr<cv::aruco::Dictionary> dictionaryOf(const RobotAppearance& robot) {
  if (robot.fiducial.dictionary < 0 || robot.fiducial.dictionary >= static_cast<int>(arucoDictionaryNames().size())) {
    throw ValidationError("the robot has no fiducial to be tracked by");
  }
  return cv::aruco::getPredefinedDictionary(robot.fiducial.dictionary);
}

// Where the ray through OpenCV pixel point @p p meets the horizontal plane at height @p z.
bool toPlane(const CameraModel& camera, const Eigen::Isometry3d& world_from_camera, const cv::Point2f& p, double z,
             Eigen::Vector3d& out) {
  const double u = p.x + 0.5, v = p.y + 0.5;  // OpenCV pixel centres are at integers, the renderer's at +0.5
  const Eigen::Vector3d d =
      world_from_camera.linear() * Eigen::Vector3d((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
  const Eigen::Vector3d o = world_from_camera.translation();
  if (std::fabs(d.z()) < 1e-12) return false;
  const double s = (z - o.z()) / d.z();
  if (!(s > 0)) return false;
  out = o + s * d;
  return true;
}

}  // namespace

RobotTracker::RobotTracker(const RobotAppearance& robot, const CameraModel& camera)
    : robot_(robot),
      camera_(camera),
      dictionary_(dictionaryOf(robot)),
      parameters_(cv::aruco::DetectorParameters::create()),
      body_(bodyScene(robot)),
      renderer_(body_, blackBackground()) {
  parameters_->cornerRefinementMethod = cv::aruco::CORNER_REFINE_SUBPIX;
  // A small marker far from the camera: accept outlines down to 1 % of the image's larger side.
  parameters_->minMarkerPerimeterRate = 0.01;
}

double fiducialCellSize(const RobotAppearance& robot) {
  return robot.fiducial.size / (dictionaryOf(robot)->markerSize + 2);
}

double RobotTracker::cellPixels(double depth) const {
  return std::min(camera_.fx, camera_.fy) * robot_.fiducial.size / (dictionary_->markerSize + 2) / depth;
}

RobotDetection RobotTracker::find(const cv::Mat& bgr, const Eigen::Isometry3d& world_from_camera) const {
  RobotDetection found;
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  // One adaptive-threshold window about two cells wide at the camera's distance, not OpenCV's three (a third of
  // the time); OpenCV's range only when that does not find the marker.
  const Eigen::Vector3d axis = world_from_camera.linear().col(2);
  const double distance = std::fabs(world_from_camera.translation().z() - robot_.root_height -
                                    robot_.fiducial.root_from_marker.translation().z()) /
                          std::max(0.2, std::fabs(axis.z()));
  const int window = 2 * static_cast<int>(std::lround(cellPixels(distance))) + 1;
  cv::Ptr<cv::aruco::DetectorParameters> one = cv::makePtr<cv::aruco::DetectorParameters>(*parameters_);
  one->adaptiveThreshWinSizeMin = one->adaptiveThreshWinSizeMax = std::max(5, window);
  cv::aruco::detectMarkers(grey, dictionary_, corners, ids, one);
  if (std::find(ids.begin(), ids.end(), robot_.fiducial.id) == ids.end()) {
    cv::aruco::detectMarkers(grey, dictionary_, corners, ids, parameters_);
  }
  const RobotAppearance::Fiducial& f = robot_.fiducial;
  const double top = robot_.root_height + f.root_from_marker.translation().z();
  for (std::size_t k = 0; k < ids.size(); ++k) {
    if (ids[k] != f.id || corners[k].size() != 4) continue;
    Eigen::Vector3d c[4];
    bool ok = true;
    for (int i = 0; i < 4; ++i) ok = ok && toPlane(camera_, world_from_camera, corners[k][i], top, c[i]);
    if (!ok) continue;
    // Corners in the marker image's order: top-left, top-right, bottom-right, bottom-left; the top is +x.
    const Eigen::Vector3d centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
    const Eigen::Vector3d up = 0.5 * (c[0] + c[1]) - 0.5 * (c[2] + c[3]);
    const double marker_yaw = std::atan2(up.y(), up.x());
    const Eigen::Matrix3d r = f.root_from_marker.linear();
    const double yaw = foldAngle(marker_yaw - std::atan2(r(1, 0), r(0, 0)), 2 * M_PI);
    const Eigen::Vector2d offset = Eigen::Rotation2Dd(yaw) * f.root_from_marker.translation().head<2>();
    found.found = true;
    found.yaw_known = true;
    found.yaw = yaw;
    found.x = centre.x() - offset.x();
    found.y = centre.y() - offset.y();
    const double side = 0.25 * ((c[1] - c[0]).norm() + (c[2] - c[1]).norm() + (c[3] - c[2]).norm() +
                                (c[0] - c[3]).norm());
    found.confidence = std::min(side / f.size, f.size / side);
    cv::Point2f mean(0, 0);
    for (const auto& p : corners[k]) {
      mean += 0.25f * p;
      found.contour.emplace_back(cvRound(p.x), cvRound(p.y));
    }
    found.centroid = cv::Point2d(mean.x + 0.5, mean.y + 0.5);
    found.pixel_area = cv::contourArea(corners[k]);
    return found;
  }
  return found;
}

cv::Mat RobotTracker::silhouette(const RobotDetection& robot, const Eigen::Isometry3d& world_from_camera,
                                 int margin) const {
  Eigen::Isometry3d world_from_root = Eigen::Isometry3d::Identity();
  world_from_root.translation() = Eigen::Vector3d(robot.x, robot.y, robot_.root_height);
  world_from_root.linear() = Eigen::AngleAxisd(robot.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  cv::Mat drawn, mask;
  renderer_.render(camera_, world_from_camera, {{"robot", world_from_root}}, drawn);
  cv::cvtColor(drawn, mask, cv::COLOR_BGR2GRAY);
  cv::threshold(mask, mask, 0, 255, cv::THRESH_BINARY);
  if (margin > 0) {
    cv::dilate(mask, mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * margin + 1, 2 * margin + 1}));
  }
  return mask;
}

}  // namespace xpersif::core
