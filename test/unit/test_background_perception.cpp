// Perception that sees what a person sees (issue 36): the empty arena subtracted, objects of any colour found by
// shape, size and colour together, the robot found by its ArUco fiducial, and the checks that refuse a world the
// cameras cannot perceive, with the reason. On worlds varied from worlds/ordinary.yaml's text, so nothing here
// depends on one world's names or colours.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>

#include "xpersif/core/common/validation.h"
#include "xpersif/core/perception/background.h"
#include "xpersif/core/perception/feature_extractor.h"
#include "xpersif/core/perception/perception_check.h"
#include "xpersif/core/render/renderer.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/sim/world_generator.h"
#include "xpersif/core/sim/world_spec.h"

using namespace xpersif::core;

namespace {

constexpr double kDeg = M_PI / 180;
const std::string kWorlds = std::string(XPERSIF_SOURCE_DIR) + "/worlds";

std::string ordinaryText() {
  std::ifstream in(kWorlds + "/ordinary.yaml");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// worlds/ordinary.yaml with @p from replaced by @p to (which must occur).
std::string variant(const std::string& from, const std::string& to, std::string text = ordinaryText()) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

PhysicsWorld worldOf(const std::string& text) { return PhysicsWorld(parseWorld(text, kWorlds, "variant.yaml")); }

double headingOf(const Eigen::Isometry3d& t) { return std::atan2(t.linear()(1, 0), t.linear()(0, 0)); }

Eigen::Isometry3d planar(double x, double y, double z, double yaw) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Eigen::Vector3d(x, y, z);
  p.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

struct Seen {
  Detections detections;
  FrameTransforms world;
};

// The scene rendered with its dynamic nodes at @p current and perceived by the overhead camera, background and all.
Seen perceive(const SceneDescription& scene, const FrameTransforms& current, const std::string& camera_name = "overhead") {
  const CameraModel& camera = *scene.findCamera(camera_name);
  Seen s;
  s.world = worldTransforms(scene, current);
  const Eigen::Isometry3d pose = cameraWorldPose(scene, s.world, camera);
  cv::Mat image;
  Renderer(scene).render(camera, pose, s.world, image);
  const FeatureExtractor fx(PerceptionCatalogue::fromScene(scene), camera, PerceptionOptions(),
                            std::make_shared<RenderedBackground>(scene));
  s.detections = fx.extract(image, pose);
  return s;
}

void expectAllFound(const SceneDescription& scene, const Seen& s, double tolerance) {
  EXPECT_TRUE(s.detections.missing.empty());
  for (const auto& name : scene.objects) {
    SCOPED_TRACE(name);
    ASSERT_EQ(s.detections.objects.count(name), 1u) << "not found";
    const ObjectDetection& o = s.detections.objects.at(name);
    EXPECT_LT((o.position.head<2>() - s.world.at(name).translation().head<2>()).norm(), tolerance);
    if (o.yaw_known) {
      EXPECT_LT(std::fabs(foldAngle(o.yaw - headingOf(s.world.at(name)), o.yaw_period)), 3 * kDeg);
    }
  }
}

}  // namespace

// Grey, black and same-coloured objects on a light floor, and a light-grey robot with black wheels: all found
// where they stand, the robot by its fiducial, over random placements.
TEST(BackgroundPerception, OrdinaryColoursAndARobotWithAFiducial) {
  const PhysicsWorld world = worldOf(ordinaryText());
  const SceneDescription& scene = world.scene();
  ASSERT_FALSE(scene.robot_fiducial.node.empty());
  std::mt19937 rng(36);
  std::uniform_real_distribution<double> ux(-0.7, 0.7), uy(-0.42, 0.42), uyaw(-M_PI, M_PI);
  const FrameTransforms start = world.dynamicTransforms();
  for (int k = 0; k < 12; ++k) {
    SCOPED_TRACE("placement " + std::to_string(k));
    FrameTransforms current = start;
    std::vector<Eigen::Vector2d> taken;
    auto place = [&](const std::string& name, double clearance) {
      for (int tries = 0; tries < 200; ++tries) {
        const Eigen::Vector2d p(ux(rng), uy(rng));
        bool free = true;
        for (const auto& q : taken) free = free && (p - q).norm() > clearance;
        if (!free) continue;
        taken.push_back(p);
        current[name] = planar(p.x(), p.y(), start.at(name).translation().z(), uyaw(rng));
        return;
      }
    };
    place(scene.robot_root, 0.15);
    for (const auto& name : scene.objects) place(name, 0.15);
    const Seen s = perceive(scene, current);
    expectAllFound(scene, s, 0.004);
    ASSERT_TRUE(s.detections.robot.found);
    ASSERT_TRUE(s.detections.robot.yaw_known);
    const Eigen::Isometry3d& robot = current.at(scene.robot_root);
    EXPECT_LT(std::hypot(s.detections.robot.x - robot.translation().x(), s.detections.robot.y - robot.translation().y()),
              0.005);
    EXPECT_LT(std::fabs(foldAngle(s.detections.robot.yaw - headingOf(robot), 2 * M_PI)), 2 * kDeg);
  }
}

// An object beside the robot, the same black as its wheels: the robot's silhouette is cut out, not the object.
TEST(BackgroundPerception, AnObjectBesideTheRobotIsNotTakenForItsWheel) {
  const PhysicsWorld world = worldOf(ordinaryText());
  const SceneDescription& scene = world.scene();
  FrameTransforms current = world.dynamicTransforms();
  const Eigen::Isometry3d robot = current.at(scene.robot_root);
  // Just left of the robot (its wheel side), 1.5 cm clear of the shell.
  current["black_block"] = planar(robot.translation().x(), robot.translation().y() + 0.037 + 0.015 + 0.0225,
                                  current.at("black_block").translation().z(), 0.2);
  const Seen s = perceive(scene, current);
  expectAllFound(scene, s, 0.004);
  EXPECT_TRUE(s.detections.robot.found);
}

// The same world through the check the tools run: everything found, nothing to refuse; the robot camera reports.
TEST(PerceptionCheck, EveryShippedWorldCanBePerceivedAtTheStart) {
  int worlds = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kWorlds)) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().filename().string());
    ++worlds;
    const PhysicsWorld world(loadWorldFile(entry.path().string()));
    const PerceptionCheck check = checkPerception(world.scene(), world.dynamicTransforms());
    EXPECT_EQ(check.problem(), "") << check.describe();
    bool downward = false;
    for (const auto& c : check.cameras) downward = downward || c.downward;
    EXPECT_TRUE(downward) << check.describe();
  }
  EXPECT_GE(worlds, 5);
}

// Generated worlds (`xpersif generate-world`): every seed and count parses, every object is told apart and found by
// the cameras at the start, and the same options give the same file.
TEST(WorldGenerator, EveryGeneratedWorldCanBePerceivedAtTheStart) {
  const std::string urdf = std::string(XPERSIF_SOURCE_DIR) + "/urdf/khepera.urdf";
  std::map<std::string, int> roles;
  for (std::uint32_t seed = 1; seed <= 160; ++seed) {
    WorldGeneratorOptions options;
    options.seed = seed;
    options.objects = 1 + static_cast<int>(seed % 8);
    options.robot_urdf = urdf;
    const std::string text = generateWorld(options);
    SCOPED_TRACE(text);
    EXPECT_EQ(generateWorld(options), text);
    const WorldSpec spec = parseWorld(text, "/", "generated");
    ASSERT_EQ(static_cast<int>(spec.objects.size()), options.objects);
    for (const auto& o : spec.objects) roles[o.redrawn() ? "redrawn" : o.mass > 1 ? "immovable" : "movable"]++;
    const PhysicsWorld world(spec);
    EXPECT_EQ(checkDistinguishable(PerceptionCatalogue::fromScene(world.scene())), "");
    const PerceptionCheck check = checkPerception(world.scene(), world.dynamicTransforms());
    EXPECT_EQ(check.problem(), "") << check.describe();
  }
  EXPECT_GT(roles["redrawn"], 0);
  EXPECT_GT(roles["immovable"], 0);
  EXPECT_GT(roles["movable"], 0);
}

TEST(WorldGenerator, RolesAndCountsOutOfRangeAreRefusedWithTheReason) {
  WorldGeneratorOptions options;
  options.robot_urdf = "khepera.urdf";
  options.objects = 9;
  EXPECT_THROW(generateWorld(options), std::invalid_argument);
  options.objects = 3;
  options.roles = {"light", "floating"};
  try {
    generateWorld(options);
    ADD_FAILURE() << "an unknown role was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'floating' is not a role"), std::string::npos) << e.what();
  }
  options.roles = {"immovable"};
  const WorldSpec spec = parseWorld(
      [&] { options.robot_urdf = std::string(XPERSIF_SOURCE_DIR) + "/urdf/khepera.urdf"; return generateWorld(options); }(),
      "/", "generated");
  for (const auto& o : spec.objects) EXPECT_GT(o.mass, 1.0) << o.name;  // only the roles asked for
}

// An object the colour of the floor: refused, naming it and the cause (it looks like the floor), not a timeout.
TEST(PerceptionCheck, AnObjectLikeTheFloorIsRefusedWithTheReason) {
  const PhysicsWorld world = worldOf(variant("color: [0.08, 0.08, 0.08, 1.0]", "color: [0.9, 0.9, 0.88, 1.0]"));
  const PerceptionCheck check = checkPerception(world.scene(), world.dynamicTransforms());
  const std::string problem = check.problem();
  EXPECT_NE(problem.find("object 'black_block'"), std::string::npos) << problem;
  EXPECT_NE(problem.find("looks like the floor"), std::string::npos) << problem;
  EXPECT_NE(problem.find("camera 'overhead'"), std::string::npos) << problem;
}

// A camera too coarse for its arena: refused before anything renders, with the pixels seen, the pixels needed and
// the focal length that would do; and with that focal length the world passes.
TEST(PerceptionCheck, ACameraTooCoarseForItsArenaIsRefusedWithWhatItWouldNeed) {
  const std::string coarse = "width: 600, height: 416,\n     fx: 200.0, fy: 200.0}";
  const PhysicsWorld world = worldOf(variant("pose: {x: 0.0, y: 0.0, z: 1.8, roll: 3.14159265358979}, width: 600, "
                                             "height: 416,\n     fx: 650.0, fy: 650.0}",
                                             "pose: {x: 0.0, y: 0.0, z: 0.9, roll: 3.14159265358979}, " + coarse));
  const std::string problem = checkPerception(world.scene(), world.dynamicTransforms()).problem();
  EXPECT_NE(problem.find("too coarse"), std::string::npos) << problem;
  EXPECT_NE(problem.find("fiducial"), std::string::npos) << problem;
  EXPECT_NE(problem.find("focal length of at least"), std::string::npos) << problem;
  // The fiducial at 1.8 m and fx 650 passes (the shipped world), at fx 400 it does not.
  const PhysicsWorld blurred = worldOf(variant("fx: 650.0, fy: 650.0}", "fx: 400.0, fy: 400.0}"));
  const std::string refused = checkPerception(blurred.scene(), blurred.dynamicTransforms()).problem();
  EXPECT_NE(refused.find("a cell of the robot's fiducial"), std::string::npos) << refused;
}

// A camera that does not see the whole arena is refused, naming a corner out of view.
TEST(PerceptionCheck, ACameraThatMissesPartOfTheArenaIsRefused) {
  const PhysicsWorld world = worldOf(variant("z: 1.8, roll", "z: 1.2, roll"));
  const std::string problem = checkPerception(world.scene(), world.dynamicTransforms()).problem();
  EXPECT_NE(problem.find("does not see the whole arena"), std::string::npos) << problem;
}

// A fiducial the world file gets wrong is refused with the field named.
TEST(PerceptionCheck, BadFiducialsAreRefused) {
  EXPECT_THROW(worldOf(variant("dictionary: 4x4_50", "dictionary: 3x3_9")), WorldError);
  EXPECT_THROW(worldOf(variant("id: 7", "id: 50")), WorldError);
  EXPECT_THROW(worldOf(variant("size: 0.056}", "size: -0.05}")), WorldError);
  try {
    worldOf(variant("dictionary: 4x4_50", "dictionary: 3x3_9"));
  } catch (const WorldError& e) {
    EXPECT_NE(std::string(e.what()).find("robot.fiducial.dictionary"), std::string::npos) << e.what();
  }
}

// A robot of ordinary colours whose world gives no fiducial gets one from XPERSim (as a lab would tape one on), with
// the reason; the robot is then found by it. A robot of colours of its own (the default world's) keeps colour
// tracking, so its runs are unchanged.
TEST(PerceptionCheck, ARobotOfOrdinaryColoursGetsAFiducial) {
  const std::string text = variant("  fiducial: {dictionary: 4x4_50, id: 7, size: 0.056}\n", "");
  const WorldSpec spec = parseWorld(text, kWorlds, "no_fiducial.yaml");
  EXPECT_EQ(spec.robot.fiducial.dictionary, "4x4_50");
  EXPECT_NE(spec.robot.fiducial.automatic_reason.find("grey, black or white"), std::string::npos)
      << spec.robot.fiducial.automatic_reason;
  EXPECT_GT(spec.robot.fiducial.size, 0.04);
  const PhysicsWorld world(spec);
  const PerceptionCheck check = checkPerception(world.scene(), world.dynamicTransforms());
  EXPECT_EQ(check.problem(), "") << check.describe();
  for (const std::string name : {"default.yaml", "mixed.yaml", "structured.yaml", "large.yaml"}) {
    SCOPED_TRACE(name);
    const WorldSpec shipped = loadWorldFile(kWorlds + "/" + name);
    EXPECT_EQ(shipped.robot.fiducial.dictionary, "") << shipped.robot.fiducial.automatic_reason;
  }
}
