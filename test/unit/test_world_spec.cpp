// World files and URDF robots: the default world loads, malformed input gets a sentence that says where.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "xpersif/core/common/package_path.h"
#include "xpersif/core/sim/world_spec.h"

using namespace xpersif::core;

namespace {
const std::string kWorlds = std::string(XPERSIF_SOURCE_DIR) + "/worlds";

std::string errorOf(const std::string& yaml) {
  try {
    parseWorld(yaml, kWorlds, "test.yaml");
  } catch (const WorldError& e) {
    return e.what();
  }
  return "";
}

const std::string kRobot = "robot: {urdf: ../urdf/khepera.urdf}\n";
}  // namespace

TEST(WorldSpec, DefaultWorldLoads) {
  const WorldSpec w = loadWorldFile(kWorlds + "/default.yaml");
  EXPECT_EQ(w.name, "default");
  EXPECT_DOUBLE_EQ(w.physics.step, 0.002);
  EXPECT_EQ(w.robot.name, "khepera");
  EXPECT_EQ(w.robot.links[0].name, "base_link");
  EXPECT_NEAR(w.robot.wheel_radius, 0.0075, 1e-12);
  EXPECT_NEAR(w.robot.wheel_separation, 0.053, 1e-12);
  EXPECT_EQ(w.robot.ir_sensors.size(), 8u);
  ASSERT_EQ(w.objects.size(), 4u);
  EXPECT_EQ(w.objects[2].name, "blue_cube");
  EXPECT_DOUBLE_EQ(w.objects[2].mass, 2.0);
  ASSERT_EQ(w.cameras.size(), 2u);
  EXPECT_EQ(w.cameras[0].model.width, 600);
  EXPECT_EQ(w.cameras[0].model.height, 416);
  EXPECT_EQ(w.cameras[1].model.frame, "robot_camera_optical");
  EXPECT_EQ(w.bodyNames(), (std::vector<std::string>{"khepera", "red_cube", "green_cube", "blue_cube", "yellow_cube"}));
}

TEST(WorldSpec, MalformedFilesGetASentenceThatSaysWhere) {
  EXPECT_NE(errorOf("robot: [unclosed").find("test.yaml: not valid YAML"), std::string::npos);
  EXPECT_NE(errorOf("name: x\n").find("the world has no robot"), std::string::npos);
  EXPECT_NE(errorOf(kRobot + "gravity: 3\n").find("unknown key 'gravity'"), std::string::npos);
  EXPECT_NE(errorOf("robot: {urdf: nowhere.urdf}\n").find("cannot read URDF"), std::string::npos);
  EXPECT_NE(errorOf(kRobot + "physics: {step: -1}\n").find("physics.step is '-1'; it must be greater than zero (line 2"),
            std::string::npos)
      << errorOf(kRobot + "physics: {step: -1}\n");
  EXPECT_NE(errorOf(kRobot + "physics: {step: .nan}\n").find("must be a finite number"), std::string::npos);
  EXPECT_NE(errorOf(kRobot + "objects: [{name: a, mass: 0}]\n").find("objects[0].mass"), std::string::npos);
  EXPECT_NE(errorOf(kRobot + "objects: [{name: a}, {name: a, pose: {x: 0.2}}]\n").find("'a' is already taken"),
            std::string::npos);
  EXPECT_NE(errorOf(kRobot + "objects: [{name: a, shape: cone}]\n").find("must be box, cylinder or sphere"),
            std::string::npos);
  EXPECT_NE(errorOf(kRobot + "objects: [{name: a, color: [2, 0, 0]}]\n").find("color[0] is '2'; it must lie in 0..1"),
            std::string::npos);
  EXPECT_NE(errorOf(kRobot + "cameras: [{name: c, parent: moon}]\n").find("neither 'world' nor a robot link"),
            std::string::npos);
  EXPECT_NE(errorOf("robot: {urdf: ../urdf/khepera.urdf, ir_sensors: [nose]}\n").find("'nose', which is not a link"),
            std::string::npos);
  EXPECT_NE(errorOf("robot: {urdf: ../urdf/khepera.urdf, left_wheel_joint: ir_0_joint}\n").find("must be revolute"),
            std::string::npos);
}

TEST(WorldSpec, MalformedUrdfIsRefused) {
  EXPECT_THROW(parseRobotUrdf("<robot name='r'><link name='a'></robot>", "bad.urdf"), WorldError);
  try {
    parseRobotUrdf(
        "<robot name='r'><link name='a'><inertial><mass value='1'/><inertia ixx='1' iyy='1' izz='1' ixy='0' ixz='0' "
        "iyz='0'/></inertial><collision><geometry><mesh filename='x.stl'/></geometry></collision></link></robot>",
        "mesh.urdf");
    FAIL() << "a mesh collision shape must be refused";
  } catch (const WorldError& e) {
    EXPECT_NE(std::string(e.what()).find("uses a mesh"), std::string::npos);
  }
}

// ---- Bad worlds, one case each: the sentence names the file, the field and what is wrong --------------

namespace {

namespace fs = std::filesystem;

/// A fresh directory under the system's temp directory, removed afterwards.
class TempDir {
 public:
  TempDir() {
    static int counter = 0;
    path_ = fs::temp_directory_path() /
            ("xpersif_world_spec_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  std::string write(const std::string& name, const std::string& text) const {
    const std::string file = (path_ / name).string();
    std::ofstream(file) << text;
    return file;
  }

 private:
  fs::path path_;
};

const std::string kUrdf = std::string(XPERSIF_SOURCE_DIR) + "/urdf/khepera.urdf";
const std::string kRobotAt = "robot: {urdf: " + kUrdf + ", pose: {x: -0.3}}\n";  // objects near the origin are clear of it

std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Write @p yaml as bad.yaml in a temp directory and load it; the sentence it is refused with ("" if loaded).
std::string refusal(const std::string& yaml) {
  TempDir dir;
  const std::string file = dir.write("bad.yaml", yaml);
  try {
    loadWorldFile(file);
  } catch (const WorldError& e) {
    const std::string what = e.what();
    return what.rfind(file, 0) == 0 ? "bad.yaml" + what.substr(file.size()) : what;  // the path, shortened
  }
  return "";
}

/// The khepera URDF with @p from replaced by @p to, written next to a world that uses it; the refusal.
std::string urdfRefusal(const std::string& from, const std::string& to, const std::string& robot_keys = "") {
  TempDir dir;
  std::string urdf = readText(kUrdf);
  const auto at = urdf.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) urdf.replace(at, from.size(), to);
  const std::string urdf_file = dir.write("bent.urdf", urdf);
  const std::string file = dir.write("bad.yaml", "robot: {urdf: " + urdf_file + robot_keys + "}\n");
  try {
    loadWorldFile(file);
  } catch (const WorldError& e) {
    std::string what = e.what();
    for (const std::string& path : {urdf_file, file}) {
      const auto p = what.find(path);
      if (p != std::string::npos) what.replace(p, path.size(), path == file ? "bad.yaml" : "bent.urdf");
    }
    return what;
  }
  return "";
}

/// One sentence: it begins with the file and contains each of @p parts.
::testing::AssertionResult says(const std::string& sentence, const std::string& file, const std::vector<std::string>& parts) {
  if (sentence.rfind(file + ":", 0) != 0) return ::testing::AssertionFailure() << "'" << sentence << "' does not begin with " << file;
  for (const auto& part : parts) {
    if (sentence.find(part) == std::string::npos) {
      return ::testing::AssertionFailure() << "'" << sentence << "' lacks '" << part << "'";
    }
  }
  if (sentence.find('\n') != std::string::npos) return ::testing::AssertionFailure() << "more than one line: " << sentence;
  return ::testing::AssertionSuccess();
}

}  // namespace

TEST(BadWorld, TextWhereANumberBelongs) {
  EXPECT_TRUE(says(refusal(kRobotAt + "arena: {size: [0.9, wide]}\n"), "bad.yaml",
                   {"arena.size[1] is 'wide'; it must be a number (line 2, column 21)"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects:\n  - {name: a, size: big}\n"), "bad.yaml",
                   {"objects[0].size is 'big'; it must be a number (line 3, column 21)"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "physics: {iterations: many}\n"), "bad.yaml",
                   {"physics.iterations is 'many'; it must be a whole number"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "arena: {size: 0.9}\n"), "bad.yaml", {"arena.size is '0.9'; it must be [x, y]"}));
}

TEST(BadWorld, MalformedYamlNamesTheFileLineAndColumn) {
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a\n"), "bad.yaml", {"not valid YAML: end of map flow not found (line 3, column 1)"}));
}

TEST(BadWorld, DuplicateObjectNames) {
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a}, {name: a, pose: {x: 0.2}}]\n"), "bad.yaml",
                   {"objects[1].name", "'a' is already taken"}));
}

TEST(BadWorld, ObjectNamedLikeARobotLinkOrTheWorld) {
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: left_wheel}]\n"), "bad.yaml",
                   {"objects[0].name", "'left_wheel' is already taken"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: world}]\n"), "bad.yaml", {"objects[0].name", "'world' is already taken"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: khepera}]\n"), "bad.yaml", {"'khepera' is already taken"}));
}

TEST(BadWorld, ObjectOutsideTheArena) {
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, pose: {x: 0.44}}]\n"), "bad.yaml",
                   {"objects[0] ('a')", "reaches outside the 0.9 x 0.6 m arena", "(line 2"}));
  // A 4 cm cube turned by 45 degrees reaches 2.8 cm from its centre: 2.5 cm from a wall is too close.
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, pose: {y: 0.275, yaw: 0.7854}}]\n"), "bad.yaml",
                   {"objects[0] ('a')", "outside"}));
  EXPECT_EQ(refusal(kRobotAt + "objects: [{name: a, pose: {y: 0.275}}]\n"), "");
}

TEST(BadWorld, ObjectsOverlapping) {
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a}, {name: b, shape: sphere, radius: 0.03, pose: {x: 0.04}}]\n"),
                   "bad.yaml", {"objects[1] ('b')", "overlaps objects[0] ('a')"}));
  // Two 4 cm cubes 4.5 cm apart: clear side by side, overlapping when one is turned by 45 degrees.
  EXPECT_EQ(refusal(kRobotAt + "objects: [{name: a}, {name: b, pose: {x: 0.045}}]\n"), "");
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a}, {name: b, pose: {x: 0.045, yaw: 0.7854}}]\n"), "bad.yaml",
                   {"objects[1] ('b')", "overlaps objects[0] ('a')"}));
  // A long box lying across: 8 cm along y reaches a cube 3.5 cm away along y.
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a}, {name: b, size: [0.08, 0.02, 0.02], pose: {y: 0.055, yaw: 1.5708}}]\n"),
                   "bad.yaml", {"objects[1] ('b')", "overlaps objects[0] ('a')"}));
  // An upright cylinder's footprint is its disc.
  EXPECT_EQ(refusal(kRobotAt + "objects: [{name: a}, {name: b, shape: cylinder, radius: 0.02, pose: {x: 0.035, y: 0.035}}]\n"), "");
}

TEST(BadWorld, ObjectOnTheRobotsStartFootprint) {
  EXPECT_TRUE(says(refusal("robot: {urdf: " + kUrdf + ", pose: {x: 0.1}}\nobjects: [{name: a, pose: {x: 0.15}}]\n"),
                   "bad.yaml", {"objects[0] ('a')", "overlaps the robot at its start pose"}));
  EXPECT_TRUE(says(refusal("robot: {urdf: " + kUrdf + ", pose: {x: 0.43}}\n"), "bad.yaml", {"robot.pose", "outside"}));
}

TEST(BadWorld, NonPositiveOrNonFiniteSizes) {
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, size: [0.04, 0, 0.04]}]\n"), "bad.yaml",
                   {"objects[0].size[1] is '0'; it must be greater than zero"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, shape: sphere, radius: -0.02}]\n"), "bad.yaml",
                   {"objects[0].radius is '-0.02'; it must be greater than zero"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, shape: cylinder, length: .inf}]\n"), "bad.yaml",
                   {"objects[0].length is '.inf'; it must be a finite number"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, mass: 0}]\n"), "bad.yaml",
                   {"objects[0].mass is '0'; it must be greater than zero"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction: 0}]\n"), "bad.yaml",
                   {"objects[0].friction is '0'; it must be greater than zero"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "arena: {wall_height: -1}\n"), "bad.yaml", {"arena.wall_height is '-1'"}));
  EXPECT_TRUE(says(refusal("robot: {urdf: " + kUrdf + ", body_friction: .nan}\n"), "bad.yaml",
                   {"robot.body_friction is '.nan'; it must be a finite number"}));
}

TEST(BadWorld, UnknownShape) {
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, shape: cone}]\n"), "bad.yaml",
                   {"objects[0].shape is 'cone'; it must be box, cylinder or sphere"}));
}

TEST(BadWorld, UnknownKeysAnywhere) {
  EXPECT_TRUE(says(refusal(kRobotAt + "gravity: 3\n"), "bad.yaml", {"unknown key 'gravity'", "(line 2, column 1)"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, colour: [1, 0, 0]}]\n"), "bad.yaml",
                   {"objects[0]", "unknown key 'colour'"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, pose: {x: 0.1, theta: 1}}]\n"), "bad.yaml",
                   {"objects[0].pose", "unknown key 'theta'"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, shape: sphere, length: 0.1}]\n"), "bad.yaml",
                   {"objects[0] (a sphere)", "unknown key 'length'"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "cameras: [{name: c, focal: 3}]\n"), "bad.yaml", {"cameras[0]", "unknown key 'focal'"}));
  EXPECT_TRUE(says(refusal("robot: {urdf: " + kUrdf + ", speed: 3}\n"), "bad.yaml", {"robot", "unknown key 'speed'"}));
}

TEST(BadWorld, UrdfInertiaNotPositiveDefinite) {
  EXPECT_TRUE(says(urdfRefusal("ixx=\"2.7e-5\"", "ixx=\"-2.7e-5\""), "bent.urdf",
                   {"link 'base_link'", "inertia matrix that is not positive definite"}));
  EXPECT_TRUE(says(urdfRefusal("<mass value=\"0.07\"/>", "<mass value=\"-0.07\"/>"), "bent.urdf",
                   {"link 'base_link'", "has mass -0.07", "zero or more"}));
}

TEST(BadWorld, WheelJointMissing) {
  EXPECT_TRUE(says(refusal("robot: {urdf: " + kUrdf + ", left_wheel_joint: leftie}\n"), "bad.yaml",
                   {"robot.left_wheel_joint names 'leftie', which is not a joint of " + kUrdf}));
}

TEST(BadWorld, WheelJointNotRevolute) {
  EXPECT_TRUE(says(refusal("robot: {urdf: " + kUrdf + ", right_wheel_joint: camera_joint}\n"), kUrdf,
                   {"wheel joint 'camera_joint' must be revolute or continuous"}));
}

TEST(BadWorld, SameWheelJointTwice) {
  EXPECT_TRUE(says(refusal("robot: {urdf: " + kUrdf + ", right_wheel_joint: left_wheel_joint}\n"), "bad.yaml",
                   {"robot.left_wheel_joint and right_wheel_joint both name 'left_wheel_joint'"}));
}

TEST(BadWorld, WheelAxesNotParallel) {
  const std::string right_axis = "<origin xyz=\"0 -0.0265 -0.0105\"/><axis xyz=\"0 1 0\"/>";
  EXPECT_TRUE(says(urdfRefusal(right_axis, "<origin xyz=\"0 -0.0265 -0.0105\"/><axis xyz=\"1 0 0\"/>"), "bent.urdf",
                   {"'left_wheel_joint' and 'right_wheel_joint' turn about axes that are not parallel"}));
}

TEST(BadWorld, HeadingMarkerMustNameALink) {
  EXPECT_TRUE(says(refusal("robot: {urdf: " + kUrdf + ", heading_marker: nose}\n"), "bad.yaml",
                   {"robot.heading_marker names 'nose', which is not a link of"}));
}

// ---- friction: per axis, redrawn per contact episode; the friction model ----------------------------------

TEST(WorldSpec, StructuredWorldLoadsItsFrictions) {
  const WorldSpec w = loadWorldFile(kWorlds + "/structured.yaml");
  EXPECT_EQ(w.physics.friction_model, PhysicsSpec::FrictionModel::Coulomb);
  EXPECT_DOUBLE_EQ(w.physics.contact_episode_gap, 0.5);
  std::map<std::string, const ObjectSpec*> by_name;
  for (const auto& o : w.objects) by_name[o.name] = &o;
  ASSERT_EQ(by_name.count("orange_bar"), 1u);
  ASSERT_EQ(by_name.count("purple_cube"), 1u);
  const ObjectSpec& bar = *by_name["orange_bar"];
  EXPECT_TRUE(bar.anisotropic());
  EXPECT_DOUBLE_EQ(bar.friction, 0.15);
  EXPECT_DOUBLE_EQ(bar.friction_y, 0.6);
  EXPECT_FALSE(bar.redrawn());
  const ObjectSpec& purple = *by_name["purple_cube"];
  EXPECT_TRUE(purple.redrawn());
  EXPECT_FALSE(purple.anisotropic());
  EXPECT_DOUBLE_EQ(purple.friction_redraw_min, 0.1);
  EXPECT_DOUBLE_EQ(purple.friction_redraw_max, 2.5);
  // Without the keys: one friction for both axes, never redrawn, Coulomb friction, half a second between episodes.
  const WorldSpec d = loadWorldFile(kWorlds + "/default.yaml");
  EXPECT_EQ(d.physics.friction_model, PhysicsSpec::FrictionModel::Coulomb);
  EXPECT_DOUBLE_EQ(d.physics.contact_episode_gap, 0.5);
  for (const auto& o : d.objects) {
    EXPECT_FALSE(o.anisotropic()) << o.name;
    EXPECT_FALSE(o.redrawn()) << o.name;
    EXPECT_DOUBLE_EQ(o.friction, o.friction_y) << o.name;
  }
  const WorldSpec p = parseWorld(kRobot + "physics: {friction_model: pyramid, contact_episode_gap: 2}\n", kWorlds, "p.yaml");
  EXPECT_EQ(p.physics.friction_model, PhysicsSpec::FrictionModel::Pyramid);
  EXPECT_DOUBLE_EQ(p.physics.contact_episode_gap, 2.0);
}

TEST(BadWorld, MalformedFrictions) {
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction: [0.3]}]\n"), "bad.yaml",
                   {"objects[0].friction is a list of 1; it must be one number or [along x, along y]", "(line 2"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction: [0.3, -1]}]\n"), "bad.yaml",
                   {"objects[0].friction[1] is '-1'; it must be greater than zero"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction: [slippery, 0.5]}]\n"), "bad.yaml",
                   {"objects[0].friction[0] is 'slippery'; it must be a number"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, shape: sphere, friction: [0.2, 0.5]}]\n"), "bad.yaml",
                   {"objects[0].friction differs along x and y on a sphere"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction_redraw: 0.3}]\n"), "bad.yaml",
                   {"objects[0].friction_redraw is '0.3'; it must be [min, max]"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction_redraw: [0.1, 0.2, 0.3]}]\n"), "bad.yaml",
                   {"objects[0].friction_redraw is a list; it must be [min, max]"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction_redraw: [0, 1]}]\n"), "bad.yaml",
                   {"objects[0].friction_redraw[0] is '0'; it must be greater than zero"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction_redraw: [0.9, .inf]}]\n"), "bad.yaml",
                   {"objects[0].friction_redraw[1] is '.inf'; it must be a finite number"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction_redraw: [2, 0.5]}]\n"), "bad.yaml",
                   {"objects[0].friction_redraw is [2, 0.5]; its min must not exceed its max"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction: [0.2, 0.5], friction_redraw: [0.1, 1]}]\n"),
                   "bad.yaml", {"objects[0].friction_redraw is given with a friction that differs along x and y"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "physics: {friction_model: cone}\n"), "bad.yaml",
                   {"physics.friction_model is 'cone'; it must be coulomb or pyramid"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "physics: {contact_episode_gap: 0}\n"), "bad.yaml",
                   {"physics.contact_episode_gap is '0'; it must be greater than zero"}));
  EXPECT_TRUE(says(refusal(kRobotAt + "objects: [{name: a, friction_noise: [0.1, 1]}]\n"), "bad.yaml",
                   {"unknown key 'friction_noise'", "friction_redraw"}));
}

// ---- package:// URDFs: a world that loads wherever it is copied ---------------------------------------------

namespace {
/// Sets ROS_PACKAGE_PATH for one test and puts back what it was.
class PackagePathScope {
 public:
  explicit PackagePathScope(const std::string& value) {
    if (const char* old = std::getenv("ROS_PACKAGE_PATH")) old_ = old;
    ::setenv("ROS_PACKAGE_PATH", value.c_str(), 1);
  }
  ~PackagePathScope() {
    if (old_) ::setenv("ROS_PACKAGE_PATH", old_->c_str(), 1);
    else ::unsetenv("ROS_PACKAGE_PATH");
  }

 private:
  std::optional<std::string> old_;
};

std::string packageXml(const std::string& name) {
  return "<?xml version=\"1.0\"?>\n<package format=\"2\">\n  <name> " + name + " </name>\n  <version>1.0.0</version>\n</package>\n";
}
}  // namespace

TEST(PackageUri, FoundAsRospackFindsIt) {
  TempDir ws;
  const fs::path root = fs::path(ws.write("README", "")).parent_path();
  for (const auto& dir : {"src/alpha/inner", "src/group/beta", "src/.hidden/gamma"}) fs::create_directories(root / dir);
  ws.write("src/group/notes.txt", "a file beside packages is passed over");
  ws.write("src/alpha/package.xml", packageXml("alpha"));
  ws.write("src/alpha/inner/package.xml", packageXml("inner"));  // below another package: not searched
  ws.write("src/group/beta/package.xml", packageXml("beta"));
  ws.write("src/.hidden/gamma/package.xml", packageXml("gamma"));
  const std::string path = "/nonexistent:" + (root / "src").string();

  EXPECT_TRUE(isPackageUri("package://beta/urdf/r.urdf"));
  EXPECT_FALSE(isPackageUri("../urdf/r.urdf"));
  EXPECT_EQ(resolvePackageUri("package://beta/urdf/r.urdf", path), (root / "src/group/beta/urdf/r.urdf").string());
  EXPECT_EQ(resolvePackageUri("package://alpha/a/../b.urdf", path), (root / "src/alpha/b.urdf").string());
  // An entry that is the package itself.
  EXPECT_EQ(resolvePackageUri("package://alpha/r.urdf", (root / "src/alpha").string()), (root / "src/alpha/r.urdf").string());
  for (const std::string hidden : {"inner", "gamma", "nothere"}) {
    try {
      resolvePackageUri("package://" + hidden + "/r.urdf", path);
      ADD_FAILURE() << hidden << " was found";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("names the package '" + hidden + "', which is not on ROS_PACKAGE_PATH"),
                std::string::npos) << e.what();
    }
  }
  for (const std::string malformed : {"package://", "package://beta", "package://beta/", "package:///r.urdf"}) {
    try {
      resolvePackageUri(malformed, path);
      ADD_FAILURE() << malformed << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("must be package://PACKAGE/PATH"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(resolvePackageUri("package://beta/r.urdf", ""), std::invalid_argument);
}

TEST(PackageUri, AWorldNamingItsRobotByPackageLoadsFromAnyDirectory) {
  TempDir elsewhere;
  const std::string world = elsewhere.write("copied.yaml", "robot: {urdf: package://xpersif/urdf/khepera.urdf}\n");
  {
    PackagePathScope scope(std::string("/nonexistent:") + XPERSIF_SOURCE_DIR);
    EXPECT_EQ(loadWorldFile(world).robot.name, "khepera");
  }
  PackagePathScope scope("/nonexistent");
  const std::string said = refusal("robot: {urdf: package://xpersif/urdf/khepera.urdf}\n");
  EXPECT_TRUE(says(said, "bad.yaml", {"robot.urdf 'package://xpersif/urdf/khepera.urdf' names the package 'xpersif', "
                                      "which is not on ROS_PACKAGE_PATH ('/nonexistent')"}))
      << said;
}
