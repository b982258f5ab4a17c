/**
 * @file scene.h
 * @brief The scene description XPERSim builds once and clients render from: nodes (tf frames) with their
 *        visual shapes and colours, and the cameras. Per frame only the dynamic nodes' transforms change
 *        (the paper's scene nodes, sent as tf); everything here is sent once.
 *
 * Conventions: metres, radians, right-handed; a node's pose is relative to its parent frame; a camera's
 * frame is an optical frame (z forward, x right, y down), as in ROS camera drivers.
 */
#pragma once

#include <Eigen/Geometry>

#include <map>
#include <string>
#include <vector>

namespace xpersif::core {

struct Rgba {
  float r = 0.5f, g = 0.5f, b = 0.5f, a = 1.0f;
};

struct Shape {
  enum class Type { Box, Cylinder, Sphere };
  Type type = Type::Box;
  Eigen::Vector3d box_size{0.1, 0.1, 0.1};  ///< box: full extents along its x, y, z
  double radius = 0.05;                     ///< cylinder and sphere
  double length = 0.1;                      ///< cylinder, along its local z axis
};

/// One coloured shape, placed in its node's frame.
struct Visual {
  Shape shape;
  Rgba color;
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();  ///< node_from_visual
};

/// A scene node: one tf frame.
struct SceneNode {
  std::string name;    ///< the tf frame id
  std::string parent;  ///< the parent frame id (the world frame for top-level nodes)
  bool dynamic = false;  ///< moves on its own: on /tf every frame; otherwise once on /tf_static
  Eigen::Isometry3d parent_from_node = Eigen::Isometry3d::Identity();  ///< initial (dynamic) or fixed pose
  std::vector<Visual> visuals;
};

/// A pinhole camera looking along +z of its optical frame.
struct CameraModel {
  std::string name;   ///< e.g. "overhead"
  std::string frame;  ///< its optical frame, a node of the scene
  int width = 600;
  int height = 416;
  double fx = 500, fy = 500, cx = 300, cy = 208;
  double near_clip = 0.005, far_clip = 20.0;
};

/// An ArUco fiducial on top of the robot, as real overhead tracking set-ups tape one on (world file
/// `robot.fiducial`). Its node sits at the centre of the marker's top face; the node's x axis points from the
/// marker image's bottom edge to its top edge, its y axis from the right edge to the left (seen from above).
struct SceneFiducial {
  std::string node;        ///< the scene node of the marker ("" = the robot carries none)
  std::string dictionary;  ///< an ArUco dictionary, one of arucoDictionaryNames(), e.g. "4x4_50"
  int id = 0;              ///< the marker's id in that dictionary
  double size = 0;         ///< side of the marker's black square, m (a white margin of one cell surrounds it)
};

/// ArUco's predefined dictionaries by the world file's names, in OpenCV's order
/// (cv::aruco::PREDEFINED_DICTIONARY_NAME: "4x4_50" is 0, ..., "apriltag_36h11" is 20).
const std::vector<std::string>& arucoDictionaryNames();
/// The index of @p name in arucoDictionaryNames(), or -1.
int arucoDictionaryCode(const std::string& name);

struct SceneDescription {
  std::string world_frame = "world";
  std::vector<SceneNode> nodes;  ///< parents come before their children
  /// Roles, from the world file: the experimenter's catalogue of what is in the arena. Names, shapes, sizes
  /// and colours only; masses, frictions and poses are for the loop to learn.
  std::string world_file;            ///< the world file the scene was built from (for sentences)
  std::string robot_root;            ///< the robot's root link (a node), "" when the scene has no robot
  std::string robot_marker;          ///< the robot link whose visual marks its heading from above, or ""
  SceneFiducial robot_fiducial;      ///< the fiducial the overhead camera finds the robot by (node "" = none)
  std::vector<std::string> objects;  ///< the objects to experiment with (top-level dynamic nodes), in file order
  double arena_size_x = 0, arena_size_y = 0;  ///< the arena's inner extents, centred on the world origin
  std::vector<CameraModel> cameras;

  /// The node called @p name, or nullptr.
  const SceneNode* findNode(const std::string& name) const;
  const CameraModel* findCamera(const std::string& name) const;
};

/// Words that choose a camera by its mount rather than its name (components' `~camera/name`): the world file
/// names its cameras as it likes.
inline constexpr const char* kFixedCamera = "fixed";       ///< the one camera the robot does not carry
inline constexpr const char* kCameraOnRobot = "on_robot";  ///< the one camera the robot carries

/// Whether @p camera hangs (through fixed nodes) from the scene's robot.
bool carriedByRobot(const SceneDescription& scene, const CameraModel& camera);

/**
 * @brief The camera @p wanted chooses: the scene's camera of that name, else, for kFixedCamera or
 *        kCameraOnRobot, the one camera with that mount.
 * @return nullptr, with @p problem set to a sentence naming the scene's cameras and their mounts, when no camera
 *         or several fit
 */
const CameraModel* chooseCamera(const SceneDescription& scene, const std::string& wanted, std::string& problem);

/// Height of the lowest point of @p shape placed at @p world_from_shape (exact for spheres, boxes and
/// cylinders): what it takes to set a thing down on the floor.
double lowestPoint(const Shape& shape, const Eigen::Isometry3d& world_from_shape);

/// Transforms of frames, by frame id.
using FrameTransforms = std::map<std::string, Eigen::Isometry3d>;

/**
 * @brief world_from_node for every node: each node's parent_from_node, replaced by @p current where it
 *        has an entry (the dynamic nodes' latest poses), chained up to the world frame.
 * @throws std::invalid_argument if a node's parent is neither the world nor an earlier node
 */
FrameTransforms worldTransforms(const SceneDescription& scene, const FrameTransforms& current = {});

}  // namespace xpersif::core
