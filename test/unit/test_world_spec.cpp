// World files and URDF robots: the default world loads, malformed input gets a sentence that says where.
#include <gtest/gtest.h>

#include "xpersif/core/world_spec.h"

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
  EXPECT_NE(errorOf(kRobot + "physics: {step: -1}\n").find("physics.step (line 2) must be greater than zero"),
            std::string::npos)
      << errorOf(kRobot + "physics: {step: -1}\n");
  EXPECT_NE(errorOf(kRobot + "physics: {step: .nan}\n").find("must be a finite number"), std::string::npos);
  EXPECT_NE(errorOf(kRobot + "objects: [{name: a, mass: 0}]\n").find("objects[0].mass"), std::string::npos);
  EXPECT_NE(errorOf(kRobot + "objects: [{name: a}, {name: a}]\n").find("'a' is already taken"), std::string::npos);
  EXPECT_NE(errorOf(kRobot + "objects: [{name: a, shape: cone}]\n").find("must be box, cylinder or sphere"),
            std::string::npos);
  EXPECT_NE(errorOf(kRobot + "objects: [{name: a, color: [2, 0, 0]}]\n").find("components must lie in 0..1"),
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
