// FEATUREEXTRACTION, FEATURESELECTION and VISION on images of the default world drawn by the project's
// Renderer: the measured poses are compared with the poses the scene was rendered at.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "xpersif/core/perception/background.h"
#include "xpersif/core/perception/feature_extractor.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/render/renderer.h"
#include "xpersif/core/common/validation.h"
#include "xpersif/core/perception/vision.h"
#include "xpersif/core/sim/world_spec.h"

using namespace xpersif::core;

namespace {

constexpr double kDeg = M_PI / 180;
const char* const kCubes[] = {"red_cube", "green_cube", "blue_cube", "yellow_cube"};

/// The default world's scene and its initial dynamic transforms (built once: ODE setup is not free).
struct DefaultWorld {
  WorldSpec spec;
  SceneDescription scene;
  FrameTransforms initial;
  double robot_z = 0;
  DefaultWorld() {
    spec = loadWorldFile(std::string(XPERSIF_SOURCE_DIR) + "/worlds/default.yaml");
    PhysicsWorld world(spec);
    scene = world.scene();
    initial = world.dynamicTransforms();
    robot_z = initial.at("base_link").translation().z();
  }
};

const DefaultWorld& defaultWorld() {
  static const DefaultWorld w;
  return w;
}

Eigen::Isometry3d planar(double x, double y, double z, double yaw) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Eigen::Vector3d(x, y, z);
  p.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

struct Frame {
  cv::Mat image;
  Eigen::Isometry3d world_from_camera;
};

/// Render @p scene with the dynamic nodes at @p current, seen by the camera called @p camera_name.
Frame render(const SceneDescription& scene, const FrameTransforms& current, const std::string& camera_name) {
  const CameraModel& camera = *scene.findCamera(camera_name);
  const FrameTransforms world = worldTransforms(scene, current);
  Frame f;
  f.world_from_camera = cameraWorldPose(scene, world, camera);
  Renderer(scene).render(camera, f.world_from_camera, world, f.image);
  return f;
}

FeatureExtractor extractorFor(const std::string& camera_name) {
  const SceneDescription& scene = defaultWorld().scene;
  return FeatureExtractor(PerceptionCatalogue::fromScene(scene), *scene.findCamera(camera_name));
}

double yawError(double measured, double truth, double period) {
  return std::fabs(foldAngle(measured - truth, period));
}

/// Check every cube of the default world against the pose it was rendered at.
void expectCubesAt(const Detections& d, const FrameTransforms& current, double pos_tol, double yaw_tol) {
  for (const char* name : kCubes) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(d.objects.count(name)) << "not detected";
    const ObjectDetection& det = d.objects.at(name);
    const Eigen::Isometry3d& truth = current.at(name);
    EXPECT_LT((det.position - truth.translation()).norm(), pos_tol)
        << "measured " << det.position.transpose() << ", truth " << truth.translation().transpose();
    ASSERT_TRUE(det.yaw_known);
    EXPECT_DOUBLE_EQ(det.yaw_period, M_PI / 2);
    EXPECT_GT(det.yaw, -M_PI / 4 - 1e-12);
    EXPECT_LE(det.yaw, M_PI / 4 + 1e-12);
    EXPECT_LT(yawError(det.yaw, yawOf(truth), M_PI / 2), yaw_tol) << "measured " << det.yaw / kDeg << " deg";
    EXPECT_GT(det.confidence, 0.8);
  }
}

/// A random arrangement: cubes at least 8 cm apart and clear of the robot, random yaws.
FrameTransforms randomScene(std::mt19937& rng) {
  const DefaultWorld& w = defaultWorld();
  std::uniform_real_distribution<double> ux(-0.40, 0.40), uy(-0.25, 0.25), uyaw(-M_PI, M_PI);
  FrameTransforms current = w.initial;
  std::vector<Eigen::Vector2d> taken;
  auto place = [&](double clearance) {
    for (;;) {
      const Eigen::Vector2d p(ux(rng), uy(rng));
      bool free = true;
      for (const auto& q : taken) free = free && (p - q).norm() > clearance;
      if (free) {
        taken.push_back(p);
        return p;
      }
    }
  };
  const Eigen::Vector2d r = place(0.0);
  current["base_link"] = planar(r.x(), r.y(), w.robot_z, uyaw(rng));
  for (const char* name : kCubes) {
    const Eigen::Vector2d p = place(0.085);
    current[name] = planar(p.x(), p.y(), 0.02, uyaw(rng));
  }
  return current;
}

SceneNode boxNode(const std::string& name, const Eigen::Vector3d& size, const Eigen::Isometry3d& pose, Rgba color) {
  SceneNode n;
  n.name = name;
  n.parent = "world";
  n.dynamic = true;
  n.parent_from_node = pose;
  Visual v;
  v.shape.box_size = size;
  v.color = color;
  n.visuals.push_back(v);
  return n;
}

}  // namespace

TEST(PerceptionCatalogue, FromTheDefaultScene) {
  const PerceptionCatalogue cat = PerceptionCatalogue::fromScene(defaultWorld().scene);
  ASSERT_EQ(cat.objects.size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(cat.objects[i].name, kCubes[i]);
  EXPECT_FLOAT_EQ(cat.objects[0].color.r, 0.85f);
  EXPECT_TRUE(cat.objects[2].shape.box_size.isApprox(Eigen::Vector3d(0.04, 0.04, 0.04)));
  EXPECT_DOUBLE_EQ(cat.objects[2].height(), 0.04);
  EXPECT_EQ(cat.robot.name, defaultWorld().scene.robot_root);
  EXPECT_EQ(cat.robot.body_shape.type, Shape::Type::Cylinder);
  ASSERT_TRUE(cat.robot.present);
  EXPECT_DOUBLE_EQ(cat.robot.body_radius, 0.035);
  EXPECT_FLOAT_EQ(cat.robot.body_color.g, 0.45f);
  EXPECT_FLOAT_EQ(cat.robot.marker_color.b, 0.2f);
  EXPECT_TRUE(cat.robot.marker_offset.isApprox(Eigen::Vector3d(0.03, 0, 0.018), 1e-9));
  EXPECT_NEAR(cat.robot.body_top, defaultWorld().robot_z + 0.015, 1e-9);
  EXPECT_NEAR(cat.robot.marker_top, defaultWorld().robot_z + 0.021, 1e-9);
  EXPECT_FALSE(cat.other_colors.empty()) << "floor, walls, wheels";
  EXPECT_EQ(cat.find("blue_cube"), &cat.objects[2]);
  EXPECT_EQ(cat.find("nothing"), nullptr);
}

TEST(FeatureExtractor, DefaultWorldFromTheOverheadCamera) {
  const DefaultWorld& w = defaultWorld();
  const FeatureExtractor fx = extractorFor("overhead");
  const Frame f = render(w.scene, w.initial, "overhead");
  const Detections d = fx.extract(f.image, f.world_from_camera);
  EXPECT_TRUE(d.downward);
  EXPECT_TRUE(d.missing.empty());
  EXPECT_EQ(d.objects.size(), 4u);
  expectCubesAt(d, w.initial, 0.005, 3 * kDeg);
  // The yellow cube's yaw is 0.4 rad in the world file.
  EXPECT_NEAR(d.objects.at("yellow_cube").yaw, 0.4, 3 * kDeg);
  ASSERT_TRUE(d.robot.found);
  EXPECT_NEAR(d.robot.x, -0.3, 0.005);
  EXPECT_NEAR(d.robot.y, 0.0, 0.005);
  ASSERT_TRUE(d.robot.yaw_known);
  EXPECT_NEAR(d.robot.yaw, 0.0, 3 * kDeg);
  EXPECT_GT(d.robot.confidence, 0.8);
  const ObjectDetection& red = d.objects.at("red_cube");
  EXPECT_EQ(red.top_corners.size(), 4u);
  EXPECT_GT(red.pixel_area, 400);
  EXPECT_FALSE(red.contour.empty());
  EXPECT_FALSE(red.top_contour.empty());
  EXPECT_NEAR(red.measured_length, 0.04, 0.001);
  EXPECT_NEAR(red.measured_width, 0.04, 0.001);
}

TEST(FeatureExtractor, RandomScenesFromTheOverheadCamera) {
  const DefaultWorld& w = defaultWorld();
  const FeatureExtractor fx = extractorFor("overhead");
  std::mt19937 rng(20261121);
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();
  int n = 0;
  for (int k = 0; k < 40; ++k) {
    SCOPED_TRACE("scene " + std::to_string(k));
    const FrameTransforms current = randomScene(rng);
    const Frame f = render(w.scene, current, "overhead");
    const Detections d = fx.extract(f.image, f.world_from_camera);
    EXPECT_TRUE(d.missing.empty());
    expectCubesAt(d, current, 0.005, 3 * kDeg);
    for (const char* name : kCubes) {
      if (!d.objects.count(name)) continue;
      bias += d.objects.at(name).position - current.at(name).translation();
      ++n;
    }
    const Eigen::Isometry3d& robot = current.at("base_link");
    ASSERT_TRUE(d.robot.found);
    EXPECT_LT(std::hypot(d.robot.x - robot.translation().x(), d.robot.y - robot.translation().y()), 0.005);
    ASSERT_TRUE(d.robot.yaw_known);
    EXPECT_LT(yawError(d.robot.yaw, yawOf(robot), 2 * M_PI), 3 * kDeg) << "the heading, not modulo pi";
  }
  // No systematic offset: half a pixel (the renderer's pixel-centre convention ignored) would be ~0.9 mm.
  bias /= std::max(n, 1);
  EXPECT_LT(bias.head<2>().norm(), 0.0002) << "mean error " << bias.transpose();
  EXPECT_LT(std::fabs(bias.z()), 1e-9) << "cubes rest on the floor: z is half their height";
}

// Sensor noise (sigma = 3 grey levels, seeded) must not break the top faces up: the robot's dark body disc
// was the first casualty of a threshold relative to the brightest pixel.
TEST(FeatureExtractor, OverheadPosesSurviveImageNoise) {
  const DefaultWorld& w = defaultWorld();
  const FeatureExtractor fx = extractorFor("overhead");
  std::mt19937 rng(99);
  cv::RNG noise_rng(12345);
  for (int k = 0; k < 15; ++k) {
    SCOPED_TRACE("scene " + std::to_string(k));
    const FrameTransforms current = randomScene(rng);
    Frame f = render(w.scene, current, "overhead");
    cv::Mat noise(f.image.size(), CV_16SC3), wide;
    noise_rng.fill(noise, cv::RNG::NORMAL, 0, 3);
    f.image.convertTo(wide, CV_16SC3);
    wide += noise;
    wide.convertTo(f.image, CV_8UC3);
    const Detections d = fx.extract(f.image, f.world_from_camera);
    expectCubesAt(d, current, 0.005, 3 * kDeg);
    const Eigen::Isometry3d& robot = current.at("base_link");
    ASSERT_TRUE(d.robot.found);
    EXPECT_LT(std::hypot(d.robot.x - robot.translation().x(), d.robot.y - robot.translation().y()), 0.005);
    ASSERT_TRUE(d.robot.yaw_known);
    EXPECT_LT(yawError(d.robot.yaw, yawOf(robot), 2 * M_PI), 3 * kDeg);
  }
}

TEST(FeatureExtractor, OutOfViewAndOccludedCubesAreMissingNotInvented) {
  const DefaultWorld& w = defaultWorld();
  const FeatureExtractor fx = extractorFor("overhead");  // catalogue of the plain default scene
  FrameTransforms current = w.initial;
  current["blue_cube"] = planar(3.0, 0.0, 0.02, 0.0);  // far outside the image
  SceneDescription scene = w.scene;
  // A grey plate 5 cm above the green cube hides it entirely; another hides 70 % of the red cube's top.
  const Eigen::Vector3d green = current.at("green_cube").translation(), red = current.at("red_cube").translation();
  scene.nodes.push_back(boxNode("roof", {0.08, 0.08, 0.005}, planar(green.x(), green.y(), 0.09, 0), {0.5, 0.5, 0.5, 1}));
  current["roof"] = scene.nodes.back().parent_from_node;
  scene.nodes.push_back(
      boxNode("shade", {0.028, 0.06, 0.005}, planar(red.x() - 0.007, red.y(), 0.09, 0), {0.5, 0.5, 0.5, 1}));
  current["shade"] = scene.nodes.back().parent_from_node;
  const Frame f = render(scene, current, "overhead");
  const Detections d = fx.extract(f.image, f.world_from_camera);
  EXPECT_EQ(d.objects.count("blue_cube"), 0u);
  EXPECT_EQ(d.objects.count("green_cube"), 0u);
  EXPECT_EQ(d.objects.count("red_cube"), 0u) << "a mostly hidden top face is not guessed at";
  EXPECT_EQ(d.missing, (std::vector<std::string>{"red_cube", "green_cube", "blue_cube"}));
  ASSERT_EQ(d.objects.count("yellow_cube"), 1u);
  EXPECT_LT((d.objects.at("yellow_cube").position - current.at("yellow_cube").translation()).norm(), 0.005);
  EXPECT_TRUE(d.robot.found);

  // No robot in view: not found, and nothing else is taken for it.
  current = w.initial;
  current["base_link"] = planar(4.0, 0.0, w.robot_z, 0);
  const Frame g = render(w.scene, current, "overhead");
  const Detections e = fx.extract(g.image, g.world_from_camera);
  EXPECT_FALSE(e.robot.found);
  EXPECT_EQ(e.objects.size(), 4u);
}

TEST(FeatureExtractor, UnknownColoursAreIgnored) {
  const DefaultWorld& w = defaultWorld();
  const FeatureExtractor fx = extractorFor("overhead");
  SceneDescription scene = w.scene;
  FrameTransforms current = w.initial;
  const Rgba magenta{0.8f, 0.1f, 0.8f, 1}, orange{0.95f, 0.5f, 0.05f, 1}, cyan{0.1f, 0.8f, 0.8f, 1};
  const Eigen::Isometry3d poses[] = {planar(-0.1, 0.1, 0.02, 0.3), planar(-0.1, -0.15, 0.02, -0.2),
                                     planar(0.2, -0.2, 0.02, 0.7)};
  const Rgba colors[] = {magenta, orange, cyan};
  for (int i = 0; i < 3; ++i) {
    scene.nodes.push_back(boxNode("stranger_" + std::to_string(i), {0.04, 0.04, 0.04}, poses[i], colors[i]));
    current[scene.nodes.back().name] = poses[i];
  }
  const Frame f = render(scene, current, "overhead");
  const Detections d = fx.extract(f.image, f.world_from_camera);
  EXPECT_EQ(d.objects.size(), 4u);
  EXPECT_TRUE(d.missing.empty());
  expectCubesAt(d, current, 0.005, 3 * kDeg);
}

TEST(FeatureExtractor, RejectsBadInput) {
  const DefaultWorld& w = defaultWorld();
  const FeatureExtractor fx = extractorFor("overhead");
  const Frame f = render(w.scene, w.initial, "overhead");
  EXPECT_THROW(fx.extract(cv::Mat(), f.world_from_camera), ValidationError);
  cv::Mat gray;
  cv::extractChannel(f.image, gray, 0);
  EXPECT_THROW(fx.extract(gray, f.world_from_camera), ValidationError);
  EXPECT_THROW(fx.extract(f.image(cv::Rect(0, 0, 300, 208)).clone(), f.world_from_camera), ValidationError);
  Eigen::Isometry3d nan_pose = f.world_from_camera;
  nan_pose.translation().x() = std::nan("");
  try {
    fx.extract(f.image, nan_pose);
    ADD_FAILURE() << "a NaN pose was accepted";
  } catch (const ValidationError& e) {
    EXPECT_NE(std::string(e.what()).find("world_from_camera"), std::string::npos) << e.what();
  }
  Eigen::Isometry3d scaled = f.world_from_camera;
  scaled.linear() *= 2.0;
  EXPECT_THROW(fx.extract(f.image, scaled), ValidationError);

  // Unusable cameras and catalogues.
  const PerceptionCatalogue cat = PerceptionCatalogue::fromScene(w.scene);
  CameraModel camera = *w.scene.findCamera("overhead");
  camera.fx = 0;
  EXPECT_THROW(FeatureExtractor(cat, camera), ValidationError);
  camera = *w.scene.findCamera("overhead");
  PerceptionCatalogue twins = cat;
  twins.objects[1].color = twins.objects[0].color;  // two red 4 cm cubes: the camera cannot tell them apart
  try {
    FeatureExtractor bad(twins, camera);
    ADD_FAILURE() << "two objects of one colour were accepted";
  } catch (const ValidationError& e) {
    EXPECT_NE(std::string(e.what()).find("red_cube"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("green_cube"), std::string::npos) << e.what();
  }
  PerceptionCatalogue flat = cat;
  flat.objects[0].shape.box_size.z() = 0;
  EXPECT_THROW(FeatureExtractor(flat, camera), ValidationError);
  PerceptionOptions options;
  options.morphology_kernel = 2;
  EXPECT_THROW(FeatureExtractor(cat, camera, options), ValidationError);
}

TEST(FeatureExtractor, RobotCameraFindsACubeAheadByGroundContact) {
  const DefaultWorld& w = defaultWorld();
  const FeatureExtractor fx = extractorFor("robot_camera");
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> dist(0.12, 0.30), side(-0.3, 0.3), yaw(-M_PI, M_PI);
  double worst = 0;
  for (int k = 0; k < 20; ++k) {
    SCOPED_TRACE("case " + std::to_string(k));
    FrameTransforms current = w.initial;
    // The robot at (-0.3, 0) facing +x; the red cube ahead of it within the camera's view; the others away.
    const double r = dist(rng), a = side(rng) * std::atan(80.0 / 120.0);
    current["red_cube"] = planar(-0.3 + 0.03 + r * std::cos(a), r * std::sin(a), 0.02, yaw(rng));
    current["green_cube"] = planar(-0.4, 0.25, 0.02, 0);
    current["blue_cube"] = planar(-0.4, -0.25, 0.02, 0);
    current["yellow_cube"] = planar(-0.42, 0.0, 0.02, 0);
    const Frame f = render(w.scene, current, "robot_camera");
    EXPECT_FALSE(fx.isDownward(f.world_from_camera));
    const Detections d = fx.extract(f.image, f.world_from_camera);
    EXPECT_FALSE(d.downward);
    EXPECT_FALSE(d.robot.found);
    ASSERT_EQ(d.objects.count("red_cube"), 1u);
    const ObjectDetection& red = d.objects.at("red_cube");
    EXPECT_FALSE(red.yaw_known);
    const double err = (red.position.head<2>() - current.at("red_cube").translation().head<2>()).norm();
    worst = std::max(worst, err);
    // The footprint from the blob's lower outline: 4.9 mm worst over these 20 cases when written; a pixel of
    // the 160 x 120 image spans 5-20 mm of floor at 12-30 cm, so 1 cm is the bound.
    EXPECT_LT(err, 0.010) << "measured " << red.position.transpose();
    EXPECT_EQ(d.objects.count("green_cube"), 0u) << "behind the robot";
  }
  RecordProperty("worst_robot_camera_error_mm", std::to_string(worst * 1000));
  std::printf("robot camera: worst position error %.1f mm over 20 cases\n", worst * 1000);
}

TEST(Vision, FeaturesOfTheDefaultWorld) {
  const DefaultWorld& w = defaultWorld();
  const FeatureExtractor fx = extractorFor("overhead");
  const Frame f = render(w.scene, w.initial, "overhead");
  const Detections d = fx.extract(f.image, f.world_from_camera);
  std::vector<std::string> all;
  for (const auto& info : availableFeatures()) all.push_back(info.name);
  const FeatureSelection everything(all);
  const auto features = Vision().compute(f.image, d, everything, {w.spec.arena.size_x, w.spec.arena.size_y});
  ASSERT_EQ(features.size(), 4u);

  // The top face's shade: base colour * (ambient + diffuse * cos), light (0.4, 0.25, 1) (renderer.h).
  const RenderOptions ro;
  const double shade = ro.ambient + ro.diffuse * ro.light_direction.normalized().z();
  const PerceptionCatalogue cat = PerceptionCatalogue::fromScene(w.scene);
  for (const ObjectAppearance& o : cat.objects) {
    SCOPED_TRACE(o.name);
    const auto& v = features.at(o.name);
    EXPECT_EQ(v.size(), all.size());
    EXPECT_NEAR(v.at("color_r"), o.color.r * shade, 1.0 / 255);
    EXPECT_NEAR(v.at("color_g"), o.color.g * shade, 1.0 / 255);
    EXPECT_NEAR(v.at("color_b"), o.color.b * shade, 1.0 / 255);
    EXPECT_NEAR(v.at("size"), 0.04, 0.001);
    EXPECT_NEAR(v.at("area"), 0.0016, 0.0001);
    EXPECT_NEAR(v.at("elongation"), 1.0, 0.05);
    const Eigen::Vector3d p = w.initial.at(o.name).translation();
    EXPECT_NEAR(v.at("x"), p.x(), 0.005);
    EXPECT_NEAR(v.at("distance_to_robot"), std::hypot(p.x() + 0.3, p.y()), 0.005);
    EXPECT_NEAR(v.at("bearing_from_robot"), std::atan2(p.y(), p.x() + 0.3), 3 * kDeg);
    EXPECT_NEAR(v.at("distance_to_wall"), std::min(0.45 - std::fabs(p.x()), 0.3 - std::fabs(p.y())), 0.005);
    EXPECT_GT(v.at("confidence"), 0.8);
  }
  // Hues of the default cubes' base colours: red 0, green 125, blue 232, yellow 52.5 degrees.
  EXPECT_NEAR(foldAngle(features.at("red_cube").at("hue") * kDeg, 2 * M_PI), 0.0, 2 * kDeg);
  EXPECT_NEAR(features.at("green_cube").at("hue"), 125.0, 2.0);
  EXPECT_NEAR(features.at("blue_cube").at("hue"), 232.0, 2.0);
  EXPECT_NEAR(features.at("yellow_cube").at("hue"), 52.5, 2.0);
  EXPECT_NEAR(features.at("yellow_cube").at("orientation"), 0.4, 3 * kDeg);

  // An explicit robot pose overrides the detected one; the selection decides the keys.
  const FeatureSelection two({"distance_to_robot", "bearing_from_robot"});
  const auto rel = Vision().compute(f.image, d, two, {0.9, 0.6}, Pose2D{0.05, 0.0, M_PI / 2});
  ASSERT_EQ(rel.at("red_cube").size(), 2u);
  EXPECT_NEAR(rel.at("red_cube").at("distance_to_robot"), 0.15, 0.005);
  EXPECT_NEAR(rel.at("red_cube").at("bearing_from_robot"), 0.0, 3 * kDeg) << "straight ahead when facing +y";
  EXPECT_THROW(Vision().compute(f.image, d, two, {0.0, 0.6}), ValidationError);
  EXPECT_THROW(Vision().compute(cv::Mat(), d, two, {0.9, 0.6}), ValidationError);
  EXPECT_THROW(Vision().compute(f.image, d, two, {0.9, 0.6}, Pose2D{std::nan(""), 0, 0}), ValidationError);
}

TEST(Vision, UnmeasurableFeaturesAreNaN) {
  const DefaultWorld& w = defaultWorld();
  FrameTransforms current = w.initial;
  current["red_cube"] = planar(-0.1, 0.0, 0.02, 0.3);
  const Frame f = render(w.scene, current, "robot_camera");
  const Detections d = extractorFor("robot_camera").extract(f.image, f.world_from_camera);
  ASSERT_EQ(d.objects.count("red_cube"), 1u);
  const FeatureSelection sel({"hue", "orientation", "distance_to_robot", "size"});
  const auto v = Vision().compute(f.image, d, sel, {0.9, 0.6}).at("red_cube");
  EXPECT_TRUE(std::isnan(v.at("orientation")));
  EXPECT_TRUE(std::isnan(v.at("distance_to_robot"))) << "no robot pose given, none detected";
  EXPECT_NEAR(foldAngle(v.at("hue") * kDeg, 2 * M_PI), 0.0, 3 * kDeg);
  EXPECT_NEAR(v.at("size"), 0.04, 0.006) << "visible height at the contact depth";
}

TEST(FeatureSelection, Validation) {
  FeatureSelection s;
  EXPECT_EQ(s.names(), FeatureSelection::defaultNames());
  EXPECT_TRUE(s.contains("hue"));
  for (const std::string& n : FeatureSelection::defaultNames()) {
    bool listed = false;
    for (const auto& info : availableFeatures()) listed = listed || info.name == n;
    EXPECT_TRUE(listed) << n;
  }
  s.set({"size", "hue", "size", "color_r", "hue"});
  EXPECT_EQ(s.names(), (std::vector<std::string>{"size", "hue", "color_r"}));
  try {
    s.set({"hue", "colour"});
    ADD_FAILURE() << "an unknown feature was accepted";
  } catch (const ValidationError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'colour'"), std::string::npos) << what;
    EXPECT_NE(what.find("distance_to_wall"), std::string::npos) << "lists what exists: " << what;
  }
  EXPECT_EQ(s.names(), (std::vector<std::string>{"size", "hue", "color_r"})) << "unchanged after a bad set";
  EXPECT_THROW(s.set({}), ValidationError);
  EXPECT_THROW(FeatureSelection({"nope"}), ValidationError);
  s.reset();
  EXPECT_EQ(s.names(), FeatureSelection::defaultNames());
  for (const auto& info : availableFeatures()) {
    EXPECT_FALSE(info.unit.empty()) << info.name;
    EXPECT_FALSE(info.description.empty()) << info.name;
  }
}

TEST(Perception, FoldAngle) {
  EXPECT_NEAR(foldAngle(0.4, M_PI / 2), 0.4, 1e-12);
  EXPECT_NEAR(foldAngle(M_PI / 2 + 0.1, M_PI / 2), 0.1, 1e-12);
  EXPECT_NEAR(foldAngle(-M_PI / 4, M_PI / 2), M_PI / 4, 1e-12) << "(-p/2, p/2]";
  EXPECT_NEAR(foldAngle(3 * M_PI, 2 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(foldAngle(-7.0, 2 * M_PI), -7.0 + 2 * M_PI, 1e-12);
}

// ---- boxes, cylinders and spheres ---------------------------------------------------------------------

namespace {

/// The default world with other objects: a cube and a long box of one colour, a cylinder, a sphere, and a
/// cylinder and a sphere of another shared colour (the world file's objects block replaced).
struct ShapesWorld {
  WorldSpec spec;
  SceneDescription scene;
  FrameTransforms initial;
  ShapesWorld() {
    const std::string dir = std::string(XPERSIF_SOURCE_DIR) + "/worlds";
    std::ifstream in(dir + "/default.yaml");
    std::stringstream text;
    text << in.rdbuf();
    std::string yaml = text.str();
    const std::size_t from = yaml.find("\nobjects:"), to = yaml.find("\ncameras:");
    yaml.replace(from, to - from, R"(
objects:
  - {name: red_cube, size: 0.04, color: [0.85, 0.1, 0.1, 1.0], pose: {x: 0.05, y: 0.15}}
  - {name: red_bar, size: [0.08, 0.03, 0.03], color: [0.85, 0.1, 0.1, 1.0], pose: {x: 0.2, y: 0.15, yaw: 0.5}}
  - {name: blue_can, shape: cylinder, radius: 0.02, length: 0.05, color: [0.1, 0.2, 0.85, 1.0], pose: {x: 0.25, y: -0.1}}
  - {name: green_ball, shape: sphere, radius: 0.025, color: [0.1, 0.7, 0.15, 1.0], pose: {x: 0.0, y: -0.15}}
  - {name: orange_can, shape: cylinder, radius: 0.02, length: 0.04, color: [0.95, 0.5, 0.05, 1.0], pose: {x: -0.15, y: 0.2}}
  - {name: orange_ball, shape: sphere, radius: 0.02, color: [0.95, 0.5, 0.05, 1.0], pose: {x: -0.1, y: -0.2}}
)");
    spec = parseWorld(yaml, dir, "shapes");
    PhysicsWorld world(spec);
    scene = world.scene();
    initial = world.dynamicTransforms();
  }
};

const ShapesWorld& shapesWorld() {
  static const ShapesWorld w;
  return w;
}

const char* const kShapes[] = {"red_cube", "red_bar", "blue_can", "green_ball", "orange_can", "orange_ball"};

/// Every object of @p names found within @p tol of where it was drawn (3-D centre; @p planar_only: x, y).
void expectShapesAt(const Detections& d, const FrameTransforms& current, const std::vector<std::string>& names,
                    double tol, bool planar_only = false) {
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(d.objects.count(name)) << "not detected";
    const ObjectDetection& det = d.objects.at(name);
    const Eigen::Vector3d truth = current.at(name).translation();
    const double err = planar_only ? (det.position - truth).head<2>().norm() : (det.position - truth).norm();
    EXPECT_LT(err, tol) << "measured " << det.position.transpose() << ", truth " << truth.transpose();
  }
}

}  // namespace

TEST(PerceptionCatalogue, ShapesFromTheSceneRoles) {
  const PerceptionCatalogue cat = PerceptionCatalogue::fromScene(shapesWorld().scene);
  ASSERT_EQ(cat.objects.size(), 6u);
  EXPECT_EQ(cat.find("blue_can")->shape.type, Shape::Type::Cylinder);
  EXPECT_DOUBLE_EQ(cat.find("blue_can")->height(), 0.05);
  EXPECT_EQ(cat.find("green_ball")->shape.type, Shape::Type::Sphere);
  EXPECT_DOUBLE_EQ(cat.find("green_ball")->height(), 0.05);
  EXPECT_TRUE(cat.find("red_bar")->footprint().isApprox(Eigen::Vector2d(0.08, 0.03)));
  EXPECT_TRUE(cat.find("orange_ball")->footprint().isApprox(Eigen::Vector2d(0.04, 0.04)));
  EXPECT_EQ(checkDistinguishable(cat), "");
}

TEST(FeatureExtractor, ShapesFromTheOverheadCamera) {
  const ShapesWorld& w = shapesWorld();
  const FeatureExtractor fx(PerceptionCatalogue::fromScene(w.scene), *w.scene.findCamera("overhead"));
  const Frame f = render(w.scene, w.initial, "overhead");
  const Detections d = fx.extract(f.image, f.world_from_camera);
  EXPECT_TRUE(d.missing.empty());
  expectShapesAt(d, w.initial, {std::begin(kShapes), std::end(kShapes)}, 0.003);
  ASSERT_EQ(d.objects.count("red_bar"), 1u);
  const ObjectDetection& bar = d.objects.at("red_bar");
  EXPECT_DOUBLE_EQ(bar.yaw_period, M_PI);
  EXPECT_LT(yawError(bar.yaw, 0.5, M_PI), 3 * kDeg);
  EXPECT_NEAR(bar.measured_length, 0.08, 0.002);
  EXPECT_NEAR(bar.measured_width, 0.03, 0.002);
  for (const char* name : {"blue_can", "green_ball", "orange_can", "orange_ball"}) {
    SCOPED_TRACE(name);
    ASSERT_EQ(d.objects.count(name), 1u);
    const ObjectDetection& o = d.objects.at(name);
    EXPECT_FALSE(o.yaw_known) << "rotationally symmetric";
    EXPECT_DOUBLE_EQ(o.yaw_period, 2 * M_PI);
    EXPECT_EQ(o.yaw, 0.0);
    EXPECT_NEAR(o.measured_length, 2 * PerceptionCatalogue::fromScene(w.scene).find(name)->shape.radius, 0.004);
    EXPECT_GT(o.confidence, 0.7);
  }
  EXPECT_TRUE(d.robot.found);
}

// Random places and yaws, the pairs of one colour included: each found where it is, never swapped (a swap
// puts both centimetres off).
TEST(FeatureExtractor, RandomShapeScenesFromTheOverheadCamera) {
  const ShapesWorld& w = shapesWorld();
  const FeatureExtractor fx(PerceptionCatalogue::fromScene(w.scene), *w.scene.findCamera("overhead"));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(-0.38, 0.38), uy(-0.23, 0.23), uyaw(-M_PI, M_PI);
  double worst = 0;
  for (int k = 0; k < 25; ++k) {
    SCOPED_TRACE("scene " + std::to_string(k));
    FrameTransforms current = w.initial;
    std::vector<Eigen::Vector2d> taken{current.at(w.scene.robot_root).translation().head<2>()};
    for (const char* name : kShapes) {
      for (;;) {
        const Eigen::Vector2d p(ux(rng), uy(rng));
        bool free = true;
        for (const auto& q : taken) free = free && (p - q).norm() > 0.11;
        if (!free) continue;
        taken.push_back(p);
        current[name] = planar(p.x(), p.y(), current.at(name).translation().z(), uyaw(rng));
        break;
      }
    }
    const Frame f = render(w.scene, current, "overhead");
    const Detections d = fx.extract(f.image, f.world_from_camera);
    EXPECT_TRUE(d.missing.empty());
    expectShapesAt(d, current, {std::begin(kShapes), std::end(kShapes)}, 0.003);
    for (const char* name : kShapes) {
      if (d.objects.count(name)) {
        worst = std::max(worst, (d.objects.at(name).position - current.at(name).translation()).norm());
      }
    }
    if (d.objects.count("red_bar")) {
      EXPECT_LT(yawError(d.objects.at("red_bar").yaw, yawOf(current.at("red_bar")), M_PI), 3 * kDeg);
    }
  }
  std::printf("shapes, overhead: worst position error %.2f mm over 25 scenes\n", worst * 1000);
}

TEST(FeatureExtractor, RobotCameraFindsEachShapeAhead) {
  const ShapesWorld& w = shapesWorld();
  const FeatureExtractor fx(PerceptionCatalogue::fromScene(w.scene), *w.scene.findCamera("robot_camera"));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> dist(0.12, 0.25), side(-0.25, 0.25), yaw(-M_PI, M_PI);
  for (const char* target : kShapes) {
    for (int k = 0; k < 6; ++k) {
      SCOPED_TRACE(std::string(target) + " case " + std::to_string(k));
      // The robot at (-0.3, 0) facing +x; the target ahead; everything else behind the robot, out of view.
      FrameTransforms current = w.initial;
      double y_behind = -0.25;
      for (const char* name : kShapes) {
        current[name] = planar(-0.42, y_behind, current.at(name).translation().z(), 0);
        y_behind += 0.1;
      }
      const double r = dist(rng), a = side(rng);
      current[target] = planar(-0.3 + 0.03 + r * std::cos(a), r * std::sin(a), current.at(target).translation().z(),
                               yaw(rng));
      const Frame f = render(w.scene, current, "robot_camera");
      const Detections d = fx.extract(f.image, f.world_from_camera);
      EXPECT_FALSE(d.downward);
      ASSERT_EQ(d.objects.count(target), 1u);
      EXPECT_EQ(d.objects.size(), 1u) << "the others are behind the robot";
      expectShapesAt(d, current, {target}, 0.010, true);
      EXPECT_FALSE(d.objects.at(target).yaw_known);
    }
  }
}

TEST(FeatureExtractor, RobotCameraKeepsSameColouredObjectsApart) {
  const ShapesWorld& w = shapesWorld();
  const FeatureExtractor fx(PerceptionCatalogue::fromScene(w.scene), *w.scene.findCamera("robot_camera"));
  FrameTransforms current = w.initial;
  for (const char* name : kShapes) current[name] = planar(-0.42, 0.25, current.at(name).translation().z(), 0);
  // Side by side in the view (bearings from the camera near (-0.27, 0): 21, -21, 6 and -5 degrees), none hidden.
  current["red_cube"] = planar(-0.05, 0.09, 0.02, 0.3);
  current["red_bar"] = planar(0.05, -0.12, 0.015, 1.4);
  current["orange_can"] = planar(0.0, 0.03, 0.02, 0);
  current["orange_ball"] = planar(-0.05, -0.02, 0.02, 0);
  const Frame f = render(w.scene, current, "robot_camera");
  const Detections d = fx.extract(f.image, f.world_from_camera);
  expectShapesAt(d, current, {"red_cube", "red_bar", "orange_can", "orange_ball"}, 0.015, true);
}

TEST(FeatureExtractor, LookAlikeObjectsAreRefusedNamingBoth) {
  PerceptionCatalogue cat = PerceptionCatalogue::fromScene(shapesWorld().scene);
  ObjectAppearance twin = *cat.find("orange_can");
  twin.name = "orange_can_2";
  twin.shape.radius *= 1.1;  // within 15 %
  cat.objects.push_back(twin);
  const std::string why = checkDistinguishable(cat);
  EXPECT_NE(why.find("'orange_can'"), std::string::npos) << why;
  EXPECT_NE(why.find("'orange_can_2'"), std::string::npos) << why;
  EXPECT_NE(why.find("cylinders"), std::string::npos) << why;
  try {
    FeatureExtractor fx(cat, *shapesWorld().scene.findCamera("overhead"));
    ADD_FAILURE() << "look-alikes accepted";
  } catch (const ValidationError& e) {
    EXPECT_EQ(std::string(e.what()).find(why), 0u) << e.what();
  }
  cat.objects.back().shape.radius = 0.03;  // 50 % larger: told apart by size
  EXPECT_EQ(checkDistinguishable(cat), "");
  cat.objects.back().shape.radius = 0.02;
  cat.objects.back().shape.type = Shape::Type::Sphere;  // like orange_ball now
  EXPECT_NE(checkDistinguishable(cat).find("'orange_ball' and 'orange_can_2'"), std::string::npos);
}

// A robot whose root link is not called base_link, with a box body and its marker on another link.
TEST(FeatureExtractor, RobotWithABoxBodyAndAnotherRootName) {
  const ShapesWorld& w = shapesWorld();
  SceneDescription scene = w.scene;
  const std::string old_root = scene.robot_root;
  FrameTransforms current = w.initial;
  for (SceneNode& n : scene.nodes) {
    if (n.name == old_root) n.name = "chassis";
    if (n.parent == old_root) n.parent = "chassis";
    if (n.name == old_root || n.name == "chassis") {
      for (Visual& v : n.visuals) {
        if (v.shape.type == Shape::Type::Cylinder && v.shape.radius > 0.02) {
          v.shape.type = Shape::Type::Box;
          v.shape.box_size = Eigen::Vector3d(0.07, 0.05, 0.03);
        }
      }
    }
  }
  scene.robot_root = "chassis";
  current["chassis"] = current.at(old_root);
  current.erase(old_root);
  const PerceptionCatalogue cat = PerceptionCatalogue::fromScene(scene);
  ASSERT_TRUE(cat.robot.present);
  EXPECT_EQ(cat.robot.name, "chassis");
  EXPECT_EQ(cat.robot.body_shape.type, Shape::Type::Box);
  EXPECT_NEAR(cat.robot.body_area, 0.07 * 0.05, 1e-12);
  const FeatureExtractor fx(cat, *scene.findCamera("overhead"));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-0.35, 0.35), uy(-0.2, 0.2), uyaw(-M_PI, M_PI);
  for (int k = 0; k < 10; ++k) {
    SCOPED_TRACE("pose " + std::to_string(k));
    const Eigen::Isometry3d pose = planar(ux(rng), uy(rng), current.at("chassis").translation().z(), uyaw(rng));
    for (const char* name : kShapes) current[name] = planar(5.0, 5.0, 0.02, 0);  // out of view
    current["chassis"] = pose;
    const Frame f = render(scene, current, "overhead");
    const Detections d = fx.extract(f.image, f.world_from_camera);
    ASSERT_TRUE(d.robot.found);
    EXPECT_LT(std::hypot(d.robot.x - pose.translation().x(), d.robot.y - pose.translation().y()), 0.005);
    ASSERT_TRUE(d.robot.yaw_known);
    EXPECT_LT(yawError(d.robot.yaw, yawOf(pose), 2 * M_PI), 3 * kDeg);
    EXPECT_GT(d.robot.confidence, 0.8);
  }
}

// A grey object: found when no grey in view can take its shades (told apart by brightness), refused with a
// sentence naming it and the grey it would be confused with otherwise.
TEST(FeatureExtractor, GreyObjects) {
  const ShapesWorld& w = shapesWorld();
  SceneDescription scene = w.scene;
  FrameTransforms current = w.initial;
  scene.nodes.push_back(boxNode("grey_block", {0.04, 0.04, 0.04}, planar(-0.1, 0.1, 0.02, 0.3), {0.2f, 0.2f, 0.2f, 1}));
  scene.objects.push_back("grey_block");
  current["grey_block"] = scene.nodes.back().parent_from_node;
  // The default robot's wheels are near-black: dark enough to be confused with a dark grey.
  try {
    FeatureExtractor bad(PerceptionCatalogue::fromScene(scene), *scene.findCamera("overhead"));
    ADD_FAILURE() << "a dark grey object beside near-black wheels was accepted";
  } catch (const ValidationError& e) {
    EXPECT_NE(std::string(e.what()).find("grey_block"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("brightness"), std::string::npos) << e.what();
  }
  for (SceneNode& n : scene.nodes) {
    for (Visual& v : n.visuals) {
      if (v.color.r == 0.1f && v.color.g == 0.1f && v.color.b == 0.1f) v.color = {0.1f, 0.1f, 0.35f, 1};
    }
  }
  const FeatureExtractor fx(PerceptionCatalogue::fromScene(scene), *scene.findCamera("overhead"));
  const Frame f = render(scene, current, "overhead");
  const Detections d = fx.extract(f.image, f.world_from_camera);
  EXPECT_TRUE(d.missing.empty());
  expectShapesAt(d, current, {"grey_block", "red_cube", "blue_can", "green_ball"}, 0.003);
  EXPECT_LT(yawError(d.objects.at("grey_block").yaw, 0.3, M_PI / 2), 3 * kDeg);
  EXPECT_TRUE(d.robot.found);
}

// Every shipped world, as its file places things: the overhead camera finds every object where it stands (and
// the turn of those whose turn can be seen), and the robot; so a world's colours and shapes tell its objects apart.
TEST(FeatureExtractor, EveryShippedWorldsObjectsAreFoundFromAbove) {
  int worlds = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(XPERSIF_SOURCE_DIR) + "/worlds")) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().filename().string());
    ++worlds;
    const PhysicsWorld world(loadWorldFile(entry.path().string()));
    const SceneDescription& scene = world.scene();
    const CameraModel* camera = nullptr;
    for (const auto& node : scene.nodes) {
      for (const auto& c : scene.cameras) {
        if (!camera && node.name == c.frame && node.parent == scene.world_frame) camera = &c;
      }
    }
    ASSERT_NE(camera, nullptr) << "no camera hangs from the world";
    const FrameTransforms current = world.dynamicTransforms();
    const Frame f = render(scene, current, camera->name);
    // As the loop perceives: with the empty arena subtracted (worlds with grey or black objects need it).
    const Detections d = FeatureExtractor(PerceptionCatalogue::fromScene(scene), *camera, PerceptionOptions(),
                                          std::make_shared<RenderedBackground>(scene))
                             .extract(f.image, f.world_from_camera);
    EXPECT_TRUE(d.missing.empty());
    EXPECT_TRUE(d.robot.found);
    for (const auto& name : scene.objects) {
      SCOPED_TRACE(name);
      ASSERT_EQ(d.objects.count(name), 1u) << "not found";
      const ObjectDetection& o = d.objects.at(name);
      const Eigen::Isometry3d& truth = current.at(name);
      EXPECT_LT((o.position.head<2>() - truth.translation().head<2>()).norm(), 0.004);
      if (o.yaw_known) {
        EXPECT_LT(yawError(o.yaw, yawOf(truth), o.yaw_period), 3 * kDeg);
      }
      EXPECT_GT(o.confidence, 0.7);
    }
  }
  EXPECT_GE(worlds, 4);
}
