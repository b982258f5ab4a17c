#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <thread>

#include "xpersif/core/render/renderer.h"

using xpersif::core::cameraWorldPose;
using xpersif::core::CameraModel;
using xpersif::core::FrameTransforms;
using xpersif::core::Renderer;
using xpersif::core::RenderOptions;
using xpersif::core::Rgba;
using xpersif::core::SceneDescription;
using xpersif::core::SceneNode;
using xpersif::core::Shape;
using xpersif::core::Visual;
using xpersif::core::worldTransforms;

namespace {

const Rgba kRed{1, 0, 0, 1};
const Rgba kGreen{0, 1, 0, 1};
const Rgba kBlue{0, 0, 1, 1};

SceneNode boxNode(const std::string& name, const Eigen::Vector3d& size, const Eigen::Vector3d& centre,
                  const Rgba& color) {
  SceneNode node;
  node.name = name;
  node.parent = "world";
  node.parent_from_node = Eigen::Translation3d(centre) * Eigen::Isometry3d::Identity();
  Visual visual;
  visual.shape.type = Shape::Type::Box;
  visual.shape.box_size = size;
  visual.color = color;
  node.visuals.push_back(visual);
  return node;
}

CameraModel defaultCamera() {
  CameraModel camera;
  camera.name = "overhead";
  camera.frame = "overhead_optical";
  return camera;  // 600 x 416, f = 500, c = (300, 208)
}

/// Optical frame at height h above the world origin looking straight down: x_cam = x_world, y_cam = -y_world.
Eigen::Isometry3d overhead(double h) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  pose.translation() = Eigen::Vector3d(0, 0, h);
  return pose;
}

/// The continuous image point of a world point seen by overhead(h) with defaultCamera().
Eigen::Vector2d projectOverhead(const Eigen::Vector3d& p, double h) {
  const CameraModel c = defaultCamera();
  const double z = h - p.z();
  return {c.fx * p.x() / z + c.cx, c.fy * -p.y() / z + c.cy};
}

/// First pixel index whose centre (i + 0.5) is >= a, and last one whose centre is <= b.
int firstCovered(double a) { return static_cast<int>(std::ceil(a - 0.5)); }
int lastCovered(double b) { return static_cast<int>(std::floor(b - 0.5)); }

/// Distance of x from the nearest integer; the exact-extent checks below keep away from ties.
double tieDistance(double x) { return std::abs(x - std::round(x)); }

struct Region {
  int count = 0;
  int min_col = 1 << 30, max_col = -1, min_row = 1 << 30, max_row = -1;
  double sum_col = 0, sum_row = 0;
  double meanCol() const { return sum_col / count; }
  double meanRow() const { return sum_row / count; }
};

template <typename Pred>
Region region(const cv::Mat& img, Pred pred) {
  Region r;
  for (int j = 0; j < img.rows; ++j) {
    for (int i = 0; i < img.cols; ++i) {
      if (!pred(img.at<cv::Vec3b>(j, i))) continue;
      ++r.count;
      r.min_col = std::min(r.min_col, i);
      r.max_col = std::max(r.max_col, i);
      r.min_row = std::min(r.min_row, j);
      r.max_row = std::max(r.max_row, j);
      r.sum_col += i;
      r.sum_row += j;
    }
  }
  return r;
}

bool isRed(const cv::Vec3b& p) { return p[2] > 80 && p[1] == 0 && p[0] == 0; }
bool isBlue(const cv::Vec3b& p) { return p[0] > 80 && p[1] == 0 && p[2] == 0; }

cv::Mat renderScene(const SceneDescription& scene, const Eigen::Isometry3d& world_from_camera,
                    const FrameTransforms& current = {}, const RenderOptions& options = RenderOptions()) {
  Renderer renderer(scene, options);
  cv::Mat img;
  renderer.render(defaultCamera(), world_from_camera, worldTransforms(scene, current), img);
  return img;
}

int countNot(const cv::Mat& img, const cv::Vec3b& bg) {
  return region(img, [&](const cv::Vec3b& p) { return p != bg; }).count;
}

}  // namespace

TEST(Renderer, BuildsTheDocumentedMeshes) {
  SceneDescription scene;
  scene.nodes.push_back(boxNode("box", {0.1, 0.1, 0.1}, {0, 0, 0}, kRed));
  EXPECT_EQ(Renderer(scene).triangleCount(), 12u);
  scene.nodes[0].visuals[0].shape.type = Shape::Type::Cylinder;
  EXPECT_EQ(Renderer(scene).triangleCount(), 24u * 4u);  // 24 side quads + 2 caps of 24
  scene.nodes[0].visuals[0].shape.type = Shape::Type::Sphere;
  EXPECT_EQ(Renderer(scene).triangleCount(), 2u * 24u + 10u * 2u * 24u);
  scene.nodes[0].visuals[0].shape.radius = 0;
  EXPECT_THROW(Renderer{scene}, std::invalid_argument);
  RenderOptions dark;
  dark.light_direction.setZero();
  EXPECT_THROW(Renderer(SceneDescription(), dark), std::invalid_argument);
}

TEST(Renderer, EmptySceneIsUniformBackgroundOfTheCameraSize) {
  SceneDescription scene;
  cv::Mat img = renderScene(scene, overhead(2.0));
  ASSERT_EQ(img.type(), CV_8UC3);
  ASSERT_EQ(img.cols, 600);
  ASSERT_EQ(img.rows, 416);
  const cv::Vec3b bg = RenderOptions().background_bgr;
  EXPECT_EQ(bg[0], bg[1]);
  EXPECT_EQ(bg[1], bg[2]);
  EXPECT_LT(bg[0], 128) << "default background is a dark grey";
  EXPECT_EQ(countNot(img, bg), 0);

  RenderOptions options;
  options.background_bgr = cv::Vec3b(10, 200, 30);
  img = renderScene(scene, overhead(2.0), {}, options);
  EXPECT_EQ(countNot(img, options.background_bgr), 0);
}

TEST(Renderer, ReusesOrReallocatesTheOutputImage) {
  SceneDescription scene;
  Renderer renderer(scene);
  cv::Mat img(10, 10, CV_8UC1, cv::Scalar(7));
  renderer.render(defaultCamera(), overhead(2.0), worldTransforms(scene), img);
  EXPECT_EQ(img.type(), CV_8UC3);
  EXPECT_EQ(img.size(), cv::Size(600, 416));
  const uchar* data = img.data;
  renderer.render(defaultCamera(), overhead(2.0), worldTransforms(scene), img);
  EXPECT_EQ(img.data, data) << "a right-sized image is drawn into, not reallocated";
}

// (a) overhead camera, red box centred below it: the red pixels are exactly the pixels whose centres lie in
// the pinhole projection of the top face (the top face is the whole silhouette here).
TEST(Renderer, OverheadBoxTopFaceMatchesThePinholeProjection) {
  const double h = 2.0;
  const Eigen::Vector3d size(0.4, 0.3, 0.1), centre(0.031, -0.017, 0.05);
  SceneDescription scene;
  scene.nodes.push_back(boxNode("box", size, centre, kRed));
  const cv::Mat img = renderScene(scene, overhead(h));

  const Eigen::Vector2d c0 = projectOverhead(centre + Eigen::Vector3d(-size.x(), size.y(), size.z()) / 2, h);
  const Eigen::Vector2d c1 = projectOverhead(centre + Eigen::Vector3d(size.x(), -size.y(), size.z()) / 2, h);
  // Precondition so that "exactly" is well defined: no corner is within 0.02 px of a pixel-centre tie.
  for (double x : {c0.x(), c0.y(), c1.x(), c1.y()}) ASSERT_GT(tieDistance(x - 0.5), 0.02) << x;

  const Region red = region(img, isRed);
  ASSERT_GT(red.count, 0);
  EXPECT_EQ(red.min_col, firstCovered(c0.x()));
  EXPECT_EQ(red.max_col, lastCovered(c1.x()));
  EXPECT_EQ(red.min_row, firstCovered(c0.y()));
  EXPECT_EQ(red.max_row, lastCovered(c1.y()));
  EXPECT_EQ(red.count, (red.max_col - red.min_col + 1) * (red.max_row - red.min_row + 1)) << "a full rectangle";
  EXPECT_EQ(countNot(img, RenderOptions().background_bgr), red.count) << "nothing else drawn";
  // The continuous width of the top face (fx * 0.4 / 1.9 = 105.26 px) is the pixel count within 1 px.
  EXPECT_NEAR(red.max_col - red.min_col + 1, c1.x() - c0.x(), 1.0);
  EXPECT_NEAR(red.max_row - red.min_row + 1, c1.y() - c0.y(), 1.0);
}

// Pixel centres exactly on a shared edge (here the top face's diagonal, through the principal point) belong
// to exactly one of the two triangles: no cracks, and the face is still exactly its projected rectangle.
TEST(Renderer, SharedEdgesLeaveNoCracks) {
  const double h = 2.0;
  for (const double half : {0.05, 0.1, 0.15, 0.2}) {
    SceneDescription scene;
    scene.nodes.push_back(boxNode("cube", {2 * half, 2 * half, 0.1}, {0, 0, 0.05}, kRed));
    const cv::Mat img = renderScene(scene, overhead(h));
    const Region red = region(img, isRed);
    const Eigen::Vector2d c0 = projectOverhead({-half, half, 0.1}, h), c1 = projectOverhead({half, -half, 0.1}, h);
    EXPECT_EQ(red.min_col, firstCovered(c0.x()));
    EXPECT_EQ(red.max_col, lastCovered(c1.x()));
    EXPECT_EQ(red.count, (red.max_col - red.min_col + 1) * (red.max_row - red.min_row + 1)) << half;
  }
}

// (a, continued) a box off to the side: its top face is still exactly where the pinhole model puts it, and
// the side facing the optical axis shows, reaching out to the projection of the bottom edge, in a
// different shade of the same hue.
TEST(Renderer, OffCentreBoxShowsItsInnerSideInAnotherShadeOfTheSameHue) {
  const double h = 2.0;
  const Eigen::Vector3d size(0.2, 0.2, 0.2), centre(0.617, 0.0, 0.1);
  SceneDescription scene;
  scene.nodes.push_back(boxNode("box", size, centre, kRed));
  const cv::Mat img = renderScene(scene, overhead(h));

  const Eigen::Vector2d top0 = projectOverhead(centre + Eigen::Vector3d(-0.1, 0.1, 0.1), h);
  const Eigen::Vector2d top1 = projectOverhead(centre + Eigen::Vector3d(0.1, -0.1, 0.1), h);
  const Eigen::Vector2d bottom0 = projectOverhead(centre + Eigen::Vector3d(-0.1, 0.1, -0.1), h);
  for (double x : {top0.x(), top0.y(), top1.x(), top1.y(), bottom0.x()}) {
    ASSERT_GT(tieDistance(x - 0.5), 0.02) << x;
  }
  const Eigen::Vector2d mid = projectOverhead(centre + Eigen::Vector3d(0, 0, 0.1), h);
  const cv::Vec3b top_color = img.at<cv::Vec3b>(static_cast<int>(mid.y()), static_cast<int>(mid.x()));
  ASSERT_TRUE(isRed(top_color));

  const Region top = region(img, [&](const cv::Vec3b& p) { return p == top_color; });
  EXPECT_EQ(top.min_col, firstCovered(top0.x()));
  EXPECT_EQ(top.max_col, lastCovered(top1.x()));
  EXPECT_EQ(top.min_row, firstCovered(top0.y()));
  EXPECT_EQ(top.max_row, lastCovered(top1.y()));
  EXPECT_EQ(top.count, (top.max_col - top.min_col + 1) * (top.max_row - top.min_row + 1));

  const Region red = region(img, isRed);
  EXPECT_EQ(red.min_col, firstCovered(bottom0.x())) << "the -x side reaches the bottom edge's projection";
  EXPECT_GT(red.count, top.count);
  const cv::Vec3b side_color = img.at<cv::Vec3b>(static_cast<int>(mid.y()), red.min_col + 1);
  EXPECT_TRUE(isRed(side_color)) << "same hue";
  EXPECT_LT(side_color[2], top_color[2]) << "a different shade: faces are distinguishable";
}

TEST(Renderer, ShadingIsBaseColourTimesAmbientPlusDiffuse) {
  const double h = 2.0;
  SceneDescription scene;
  scene.nodes.push_back(boxNode("box", {0.2, 0.2, 0.2}, {0.613, 0.0, 0.1}, kRed));
  RenderOptions options;
  options.light_direction = Eigen::Vector3d(0, 0, 5);  // straight down, not unit length
  const cv::Mat img = renderScene(scene, overhead(h), {}, options);
  const Eigen::Vector2d mid = projectOverhead({0.613, 0, 0.2}, h);
  const Region red = region(img, isRed);
  EXPECT_EQ(img.at<cv::Vec3b>(static_cast<int>(mid.y()), static_cast<int>(mid.x())), cv::Vec3b(0, 0, 255))
      << "top face: 0.45 + 0.55 * 1";
  EXPECT_EQ(img.at<cv::Vec3b>(static_cast<int>(mid.y()), red.min_col + 1), cv::Vec3b(0, 0, 115))
      << "side face: ambient only, round(0.45 * 255)";
}

// (b) the nearer box hides the farther one wherever they overlap, whatever the drawing order.
TEST(Renderer, NearerBoxOccludesFartherOneRegardlessOfOrder) {
  const double h = 2.0;
  const SceneNode near_box = boxNode("near", {0.2, 0.2, 0.2}, {0.0, 0.0, 0.6}, kBlue);
  const SceneNode far_box = boxNode("far", {0.5, 0.4, 0.1}, {0.05, 0.02, 0.05}, kRed);
  SceneDescription near_first, far_first, near_only;
  near_first.nodes = {near_box, far_box};
  far_first.nodes = {far_box, near_box};
  near_only.nodes = {near_box};

  const cv::Mat a = renderScene(near_first, overhead(h));
  const cv::Mat b = renderScene(far_first, overhead(h));
  const cv::Mat alone = renderScene(near_only, overhead(h));
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0) << "drawing order must not matter";

  const Region blue = region(a, isBlue), blue_alone = region(alone, isBlue);
  ASSERT_GT(blue_alone.count, 1000);
  EXPECT_EQ(blue.count, blue_alone.count) << "the near box is drawn whole, over the far one";
  const Region red = region(a, isRed);
  EXPECT_GT(red.count, 0);
  EXPECT_EQ(red.count + blue.count, countNot(a, RenderOptions().background_bgr));
  // The far box spans the near one's whole silhouette, so red surrounds blue on all sides.
  EXPECT_LT(red.min_col, blue.min_col);
  EXPECT_GT(red.max_col, blue.max_col);
  EXPECT_LT(red.min_row, blue.min_row);
  EXPECT_GT(red.max_row, blue.max_row);
}

// (b, continued) two interpenetrating plates: which one is in front changes across the image, which no
// per-object ordering can get right, only a per-pixel depth test.
TEST(Renderer, InterpenetratingPlatesSplitAtTheirIntersection) {
  const double h = 2.0;
  SceneDescription scene;
  scene.nodes.push_back(boxNode("flat", {0.6, 0.3, 0.01}, {0, 0, 0.5}, kRed));
  SceneNode tilted = boxNode("tilted", {0.6, 0.3, 0.01}, {0, 0, 0.5}, kBlue);
  tilted.parent_from_node.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()));
  scene.nodes.push_back(tilted);
  const cv::Mat img = renderScene(scene, overhead(h));
  // Rotating about +y by +0.3 raises the tilted plate at -x and lowers it at +x (z = -x sin 0.3).
  const Eigen::Vector2d left = projectOverhead({-0.2, 0, 0.5}, h), right = projectOverhead({0.2, 0, 0.5}, h);
  EXPECT_TRUE(isBlue(img.at<cv::Vec3b>(static_cast<int>(left.y()), static_cast<int>(left.x()))));
  EXPECT_TRUE(isRed(img.at<cv::Vec3b>(static_cast<int>(right.y()), static_cast<int>(right.x()))));
}

// (c) nothing behind the camera is drawn, not even mirrored through the camera centre.
TEST(Renderer, NothingBehindTheCameraIsDrawn) {
  SceneDescription scene;
  scene.nodes.push_back(boxNode("behind", {0.3, 0.3, 0.3}, {0.1, 0.05, 3.0}, kRed));    // above an h=2 camera
  scene.nodes.push_back(boxNode("beside", {0.3, 0.3, 0.3}, {-0.2, 0.1, 2.3}, kGreen));  // all of it above too
  const cv::Mat img = renderScene(scene, overhead(2.0));
  EXPECT_EQ(countNot(img, RenderOptions().background_bgr), 0);
}

// (c, continued) a bar from behind the camera to 2 m in front of it, beside the optical axis: only its face
// towards the axis shows, clipped at the near plane, as the exact wedge the pinhole model predicts.
TEST(Renderer, GeometryCrossingTheNearPlaneIsClippedNotSmeared) {
  SceneDescription scene;
  // In the camera frame (camera at the world origin, identity pose): x in [0.2, 0.4], |y| <= 0.1, z in [-1, 2].
  scene.nodes.push_back(boxNode("bar", {0.2, 0.2, 3.0}, {0.3, 0.0, 0.5}, kRed));
  const cv::Mat img = renderScene(scene, Eigen::Isometry3d::Identity());
  const CameraModel c = defaultCamera();
  const cv::Vec3b bg = RenderOptions().background_bgr;

  // Its x = 0.2 face projects to u >= cx + fx * 0.2 / 2 = 350, |v - cy| <= (u - cx) * (fy * 0.1) / (fx * 0.2).
  int checked = 0;
  for (int i = 0; i < img.cols; ++i) {
    const double u = i + 0.5;
    int drawn = 0, first = -1, last = -1;
    for (int j = 0; j < img.rows; ++j) {
      if (img.at<cv::Vec3b>(j, i) == bg) continue;
      ASSERT_TRUE(isRed(img.at<cv::Vec3b>(j, i)));
      ++drawn;
      if (first < 0) first = j;
      last = j;
    }
    if (u < 350 - 1) {
      EXPECT_EQ(drawn, 0) << "column " << i;
      continue;
    }
    if (u < 351) continue;  // the tip of the wedge is at u = 350
    const double half = (u - c.cx) * 0.5;
    EXPECT_EQ(drawn, last - first + 1) << "one contiguous span in column " << i;
    EXPECT_NEAR(first, c.cy - half - 0.5, 1.0) << "column " << i;
    EXPECT_NEAR(last, c.cy + half - 0.5, 1.0) << "column " << i;
    ++checked;
  }
  EXPECT_GT(checked, 200);
}

TEST(Renderer, CameraInsideABoxSeesOutOfIt) {
  SceneDescription scene;
  scene.nodes.push_back(boxNode("housing", {0.1, 0.1, 0.1}, {0, 0, 2.0}, kBlue));  // around the camera
  scene.nodes.push_back(boxNode("target", {0.2, 0.2, 0.2}, {0, 0, 0.1}, kRed));
  const cv::Mat img = renderScene(scene, overhead(2.0));
  EXPECT_EQ(region(img, isBlue).count, 0);
  EXPECT_GT(region(img, isRed).count, 1000);
}

TEST(Renderer, NothingBeyondTheFarPlaneIsDrawn) {
  SceneDescription scene;
  scene.nodes.push_back(boxNode("far", {1, 1, 1}, {0, 0, -25}, kRed));  // 27 m below an h=2 camera; far = 20
  EXPECT_EQ(countNot(renderScene(scene, overhead(2.0)), RenderOptions().background_bgr), 0);
}

// (d) moving a node's transform moves its pixels by the predicted amount.
TEST(Renderer, MovingANodeMovesItsPixelsAsPredicted) {
  const double h = 2.0, top = 0.1;
  SceneDescription scene;
  scene.nodes.push_back(boxNode("cube", {0.1, 0.1, 0.1}, {0, 0, 0.05}, kRed));
  scene.nodes[0].dynamic = true;
  const cv::Mat before_img = renderScene(scene, overhead(h));
  const Eigen::Vector3d moved(0.237, -0.141, 0.05);
  FrameTransforms current;
  current["cube"] = Eigen::Translation3d(moved) * Eigen::Isometry3d::Identity();
  const cv::Mat after_img = renderScene(scene, overhead(h), current);

  // Compare the top faces: off-centre, the cube also shows two of its sides.
  auto topFace = [&](const cv::Mat& img, const Eigen::Vector3d& centre) {
    const Eigen::Vector2d mid = projectOverhead(centre + Eigen::Vector3d(0, 0, 0.05), h);
    const cv::Vec3b top_color = img.at<cv::Vec3b>(static_cast<int>(mid.y()), static_cast<int>(mid.x()));
    EXPECT_TRUE(isRed(top_color));
    return region(img, [&](const cv::Vec3b& p) { return p == top_color; });
  };
  const Region before = topFace(before_img, {0, 0, 0.05});
  const Region after = topFace(after_img, moved);
  ASSERT_GT(before.count, 500);
  // A translation parallel to the image plane keeps the top's size (up to a pixel row and column).
  EXPECT_NEAR(after.count, before.count, 2 * std::sqrt(before.count) + 1);

  const CameraModel c = defaultCamera();
  const double du = c.fx * 0.237 / (h - top), dv = c.fy * 0.141 / (h - top);  // y_cam = -y_world
  EXPECT_NEAR(after.min_col - before.min_col, du, 1.0);
  EXPECT_NEAR(after.max_col - before.max_col, du, 1.0);
  EXPECT_NEAR(after.min_row - before.min_row, dv, 1.0);
  EXPECT_NEAR(after.max_row - before.max_row, dv, 1.0);
  EXPECT_NEAR(after.meanCol() - before.meanCol(), du, 0.5);
  EXPECT_NEAR(after.meanRow() - before.meanRow(), dv, 0.5);
  const Eigen::Vector2d corner = projectOverhead(moved + Eigen::Vector3d(0.05, -0.05, 0.05), h);
  EXPECT_EQ(after.max_col, lastCovered(corner.x()));
  EXPECT_EQ(after.max_row, lastCovered(corner.y()));
  // The whole silhouette moved too: nothing red is left where the cube was.
  const Region all_after = region(after_img, isRed);
  EXPECT_GT(all_after.min_col, before.max_col);
}

TEST(Renderer, ChildNodesFollowTheirParentAndRotationsTurnTheFootprint) {
  const double h = 2.0;
  SceneDescription scene;
  SceneNode robot;
  robot.name = "robot";
  robot.parent = "world";
  robot.dynamic = true;
  scene.nodes.push_back(robot);
  SceneNode plate = boxNode("plate", {0.4, 0.1, 0.02}, {0, 0, 0.3}, kRed);  // long along x
  plate.parent = "robot";
  scene.nodes.push_back(plate);

  const Region straight = region(renderScene(scene, overhead(h)), isRed);
  FrameTransforms current;
  current["robot"] = Eigen::Isometry3d(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  const Region turned = region(renderScene(scene, overhead(h), current), isRed);
  const int sw = straight.max_col - straight.min_col + 1, sh = straight.max_row - straight.min_row + 1;
  const int tw = turned.max_col - turned.min_col + 1, th = turned.max_row - turned.min_row + 1;
  EXPECT_NEAR(sw, 500 * 0.4 / (h - 0.31), 1.0);
  EXPECT_NEAR(sh, 500 * 0.1 / (h - 0.31), 1.0);
  EXPECT_NEAR(tw, sh, 1);
  EXPECT_NEAR(th, sw, 1);
  EXPECT_NEAR(turned.count, straight.count, 0.02 * straight.count);
}

TEST(Renderer, MovingTheCameraShiftsTheImageTheOtherWay) {
  const double h = 2.0;
  SceneDescription scene;
  scene.nodes.push_back(boxNode("cube", {0.1, 0.1, 0.1}, {0, 0, 0.05}, kRed));
  const Region before = region(renderScene(scene, overhead(h)), isRed);
  Eigen::Isometry3d moved = overhead(h);
  moved.translation().x() += 0.19;  // camera 0.19 m towards +x: the cube appears 0.19 m towards -x
  const Region after = region(renderScene(scene, moved), isRed);
  EXPECT_NEAR(after.meanCol() - before.meanCol(), -500 * 0.19 / (h - 0.1), 1.0);
  EXPECT_NEAR(after.meanRow(), before.meanRow(), 1.0);
}

// (e) a pure green box lit from above is green, and nothing but green.
TEST(Renderer, GreenBoxRendersGreen) {
  SceneDescription scene;
  scene.nodes.push_back(boxNode("green", {0.2, 0.2, 0.2}, {0.4, 0.3, 0.1}, kGreen));
  const cv::Mat img = renderScene(scene, overhead(2.0));
  const cv::Vec3b bg = RenderOptions().background_bgr;
  int green = 0;
  for (int j = 0; j < img.rows; ++j) {
    for (int i = 0; i < img.cols; ++i) {
      const cv::Vec3b p = img.at<cv::Vec3b>(j, i);
      if (p == bg) continue;
      ++green;
      EXPECT_GT(p[1], 100) << "at " << i << "," << j;
      EXPECT_EQ(p[0], 0);
      EXPECT_EQ(p[2], 0);
    }
  }
  EXPECT_GT(green, 1000);
  const Eigen::Vector2d mid = projectOverhead({0.4, 0.3, 0.2}, 2.0);
  EXPECT_GT(img.at<cv::Vec3b>(static_cast<int>(mid.y()), static_cast<int>(mid.x()))[1], 230)
      << "the top face faces the light";
}

TEST(Renderer, CylinderAndSphereSilhouettesHaveTheExpectedArea) {
  const double h = 2.0;
  SceneDescription scene;
  SceneNode node = boxNode("cylinder", {1, 1, 1}, {0, 0, 0.2}, kRed);
  node.visuals[0].shape.type = Shape::Type::Cylinder;
  node.visuals[0].shape.radius = 0.15;
  node.visuals[0].shape.length = 0.4;  // standing upright: top disc at z = 0.4
  scene.nodes = {node};
  const double r_cyl = 500 * 0.15 / (h - 0.4);
  // A 24-gon inscribed in the circle has (24 / 2pi) sin(2pi / 24) = 0.9886 of its area.
  EXPECT_NEAR(region(renderScene(scene, overhead(h)), isRed).count, 0.9886 * M_PI * r_cyl * r_cyl,
              0.01 * M_PI * r_cyl * r_cyl);

  node.visuals[0].shape.type = Shape::Type::Sphere;
  node.visuals[0].shape.radius = 0.2;
  node.parent_from_node.translation() = Eigen::Vector3d(0, 0, 0.5);
  scene.nodes = {node};
  const double d = h - 0.5;
  const double r_sph = 500 * 0.2 / std::sqrt(d * d - 0.2 * 0.2);  // the silhouette cone of a sphere
  const int count = region(renderScene(scene, overhead(h)), isRed).count;
  EXPECT_LT(count, M_PI * r_sph * r_sph);
  EXPECT_GT(count, 0.96 * M_PI * r_sph * r_sph);
}

TEST(Renderer, VisualOffsetsAreApplied) {
  const double h = 2.0;
  SceneDescription scene;
  SceneNode node = boxNode("node", {0.1, 0.1, 0.1}, {0, 0, 0.05}, kRed);
  node.visuals[0].offset.translation() = Eigen::Vector3d(0.2, 0, 0);
  scene.nodes = {node};
  const Region red = region(renderScene(scene, overhead(h)), isRed);
  const Eigen::Vector2d corner = projectOverhead({0.25, -0.05, 0.1}, h);
  EXPECT_EQ(red.max_col, lastCovered(corner.x()));
  EXPECT_EQ(red.max_row, lastCovered(corner.y()));
}

TEST(Renderer, NodesWithoutATransformAreSkipped) {
  SceneDescription scene;
  scene.nodes.push_back(boxNode("a", {0.2, 0.2, 0.2}, {0.3, 0, 0.1}, kRed));
  scene.nodes.push_back(boxNode("b", {0.2, 0.2, 0.2}, {-0.3, 0, 0.1}, kBlue));
  FrameTransforms world = worldTransforms(scene);
  world.erase("a");
  Renderer renderer(scene);
  cv::Mat img;
  ASSERT_NO_THROW(renderer.render(defaultCamera(), overhead(2.0), world, img));
  EXPECT_EQ(region(img, isRed).count, 0);
  EXPECT_GT(region(img, isBlue).count, 0) << "nodes after a skipped one are still drawn";
}

TEST(Renderer, RejectsUnusableCameras) {
  SceneDescription scene;
  Renderer renderer(scene);
  cv::Mat img;
  CameraModel c = defaultCamera();
  c.near_clip = 0;
  EXPECT_THROW(renderer.render(c, overhead(2), {}, img), std::invalid_argument);
  c = defaultCamera();
  c.far_clip = c.near_clip;
  EXPECT_THROW(renderer.render(c, overhead(2), {}, img), std::invalid_argument);
  c = defaultCamera();
  c.width = 0;
  EXPECT_THROW(renderer.render(c, overhead(2), {}, img), std::invalid_argument);
}

TEST(Renderer, CameraWorldPoseIsThePoseOfItsOpticalFrame) {
  SceneDescription scene;
  SceneNode cam;
  cam.name = "overhead_optical";
  cam.parent = "world";
  cam.parent_from_node = overhead(2.5);
  scene.nodes.push_back(cam);
  const FrameTransforms world = worldTransforms(scene);
  EXPECT_TRUE(cameraWorldPose(scene, world, defaultCamera()).isApprox(overhead(2.5)));
  CameraModel at_world = defaultCamera();
  at_world.frame = "world";
  EXPECT_TRUE(cameraWorldPose(scene, {}, at_world).isApprox(Eigen::Isometry3d::Identity()));
  CameraModel nowhere = defaultCamera();
  nowhere.frame = "no_such_frame";
  EXPECT_THROW(cameraWorldPose(scene, world, nowhere), std::invalid_argument);
}

TEST(Renderer, ConcurrentRendersMatchASingleThreadedOne) {
  SceneDescription scene;
  scene.nodes.push_back(boxNode("a", {0.2, 0.2, 0.2}, {0.3, 0.1, 0.1}, kRed));
  scene.nodes.push_back(boxNode("b", {0.3, 0.2, 0.4}, {-0.3, 0, 0.2}, kBlue));
  const Renderer renderer(scene);
  const FrameTransforms world = worldTransforms(scene);
  cv::Mat reference;
  renderer.render(defaultCamera(), overhead(2.0), world, reference);
  CameraModel small = defaultCamera();
  small.width = 320;
  small.height = 240;
  small.cx = 160;
  small.cy = 120;

  cv::Mat results[4];
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      cv::Mat other;
      for (int k = 0; k < 20; ++k) {
        renderer.render(defaultCamera(), overhead(2.0), world, results[t]);
        renderer.render(small, overhead(2.0), world, other);  // a different buffer size in between
      }
    });
  }
  for (auto& thread : threads) thread.join();
  for (const auto& result : results) EXPECT_EQ(cv::norm(result, reference, cv::NORM_INF), 0);
}
