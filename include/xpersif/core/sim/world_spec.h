/**
 * @file world_spec.h
 * @brief What XPERSim simulates, read from a world file (YAML) and the robot's URDF: physics settings,
 *        arena, robot, objects and cameras. ROS-free (yaml-cpp, urdfdom).
 *
 * Any robot morphology the URDF can describe is accepted as long as its links' collision shapes are
 * boxes, cylinders or spheres and its moving joints are revolute or continuous (driven by velocity
 * motors); fixed joints merge a link into its parent's rigid body.
 */
#pragma once

#include <Eigen/Geometry>

#include <stdexcept>
#include <string>
#include <vector>

#include "xpersif/core/common/scene.h"

namespace xpersif::core {

/// A world file or URDF that cannot be used; what() says which file, where, and what is wrong.
class WorldError : public std::runtime_error {
 public:
  explicit WorldError(const std::string& what) : std::runtime_error(what) {}
};

struct PhysicsSpec {
  double step = 0.001;  ///< seconds per physics step
  double gravity = -9.81;
  unsigned long seed = 1;
  int iterations = 30;
  double max_speed = 5.0;  ///< m/s; faster (or non-finite) bodies count as a blow-up
  /// s of simulated time without touching the robot after which an object's next touch starts a new contact
  /// episode (when its friction is redrawn, ObjectSpec::friction_redraw_min)
  double contact_episode_gap = 0.5;
  /// How friction acts at the objects' contacts (the robot's own wheels and body always use Pyramid):
  /// Coulomb: a sliding contact's friction opposes its slip, mu times the normal force, and nothing across it
  /// (so a pushed box turns as a real one does); a contact at rest holds up to mu along any axis.
  /// Pyramid: ODE's box approximation along fixed axes, which lets a box that slides one way resist turning
  /// with friction across the slide (objects turn a tenth of what they should); kept for comparison (bench/contact.md).
  enum class FrictionModel { Coulomb, Pyramid } friction_model = FrictionModel::Coulomb;
};

struct ArenaSpec {
  double size_x = 0.9, size_y = 0.6;  ///< inner extents
  double wall_height = 0.05, wall_thickness = 0.02;
  Rgba wall_color{0.55f, 0.55f, 0.6f, 1.0f};
  Rgba floor_color{0.93f, 0.93f, 0.9f, 1.0f};

  /// The four walls as boxes in the world frame (coloured wall_color), for physics and rendering alike.
  std::vector<Visual> walls() const;
};

/// A link of the robot: its geometry and where it sits.
struct LinkSpec {
  std::string name;
  std::string parent;  ///< "" for the root link
  std::string joint;   ///< name of the joint to the parent
  enum class JointType { Root, Fixed, Revolute } joint_type = JointType::Root;
  Eigen::Isometry3d parent_from_link = Eigen::Isometry3d::Identity();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< revolute joints, in the link frame
  double mass = 0;                                  ///< 0 = massless (fixed links only)
  Eigen::Vector3d com = Eigen::Vector3d::Zero();    ///< centre of mass in the link frame
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  std::vector<Visual> collisions;  ///< collision shapes (colour unused)
  std::vector<Visual> visuals;
};

struct RobotSpec {
  std::string name;
  std::string urdf;  ///< the URDF text (for robot_description)
  std::vector<LinkSpec> links;  ///< parents before children; links[0] is the root
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  ///< world_from_root at the start (z is filled in)
  std::string left_wheel_joint, right_wheel_joint;
  double wheel_radius = 0;      ///< from the wheels' collision spheres or cylinders
  double wheel_separation = 0;  ///< distance between the wheel centres
  double max_wheel_speed = 0.5;   ///< m/s at the rim
  double max_wheel_torque = 0.005;
  double wheel_friction = 1.0, body_friction = 0.3;
  std::vector<std::string> ir_sensors;  ///< links whose +x axis is an IR ray
  double ir_range = 0.06;
  /// The link whose visual marks the heading from above (world file `heading_marker`); "" = the first link
  /// below the root with exactly one box visual, if any.
  std::string heading_marker;
  /// An ArUco fiducial on the robot's top (world file `robot.fiducial`): dictionary "" = none. The overhead camera
  /// then finds the robot by it, whatever the colours of the robot's visuals, and heading_marker is not used.
  struct Fiducial {
    std::string dictionary;  ///< one of arucoDictionaryNames(); "" = no fiducial
    int id = 0;
    double size = 0;         ///< the black square's side, m
    /// root_from_marker in the horizontal plane (x, y, yaw); its height is filled in above the robot's top
    Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
    /// Why XPERSim put this fiducial on the robot itself ("" = the world file asked for it): a robot the overhead
    /// camera could not find by its own colours (see parseWorld()).
    std::string automatic_reason;
  } fiducial;
};

struct ObjectSpec {
  std::string name;
  Shape shape;
  double mass = 0.05;
  /// Friction against the floor along the object's own x axis, and (with friction_y) across it: a sled on
  /// runners slides along x and resists sideways motion. Against the robot, walls and other objects the
  /// object's friction is the geometric mean of the two.
  double friction = 0.5;
  double friction_y = 0.5;  ///< along the object's y axis; equal to friction unless the file gives [x, y]
  /// When friction_redraw_max > 0: at the start of every contact episode with the robot (a touch after
  /// physics.contact_episode_gap without one) the simulator draws the object's friction (both axes) at random,
  /// log-uniformly in [friction_redraw_min, friction_redraw_max], from a stream seeded by the simulator's
  /// redraw seed, the object's index and the episode's number. The loop never sees it.
  double friction_redraw_min = 0, friction_redraw_max = 0;
  bool anisotropic() const { return friction != friction_y; }
  bool redrawn() const { return friction_redraw_max > 0; }
  Rgba color;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  ///< z is set so the object rests on the floor
};

struct CameraSpec {
  CameraModel model;  ///< model.frame is "<name>_optical"
  std::string parent;  ///< the world frame or a robot link
  Eigen::Isometry3d parent_from_optical = Eigen::Isometry3d::Identity();
};

struct WorldSpec {
  std::string name;
  std::string source;  ///< the file it came from
  PhysicsSpec physics;
  ArenaSpec arena;
  RobotSpec robot;
  std::vector<ObjectSpec> objects;
  std::vector<CameraSpec> cameras;

  /// Names that setPose and friends accept: the robot's name, then the objects'.
  std::vector<std::string> bodyNames() const;
};

/// Read a world file; the robot's URDF path is relative to it. @throws WorldError with one sentence that
/// names the file, the field (e.g. "arena.size[1]"), what is wrong and, from YAML, the line and column.
/// Refused: malformed YAML; unknown keys (anywhere, also keys that the object's shape does not have);
/// text where a number belongs; non-finite or non-positive sizes, radii, lengths, masses and frictions;
/// unknown shapes; names already taken (robot, its links, "world", "floor", other objects, cameras);
/// objects reaching outside the arena, overlapping another or the robot's start footprint (horizontal
/// footprints, 1 mm tolerance); the robot starting outside the arena; URDF links with negative mass or an
/// inertia that is given but not positive definite; wheel joints missing, not revolute/continuous, the
/// same twice, not hanging from the root, without a sphere/cylinder tyre, of unequal radii or with axes
/// that are not parallel; ir_sensors, heading_marker or a camera parent that is not a link.
WorldSpec loadWorldFile(const std::string& path);
/// Parse world YAML text (@p base_dir resolves the URDF path; @p source names it in errors). @throws WorldError
WorldSpec parseWorld(const std::string& yaml_text, const std::string& base_dir, const std::string& source);
/// Parse a URDF robot. @throws WorldError
RobotSpec parseRobotUrdf(const std::string& urdf_xml, const std::string& source);

/// Roll, pitch, yaw (fixed axes X, Y, Z) to a rotation, as URDF and ROS do.
Eigen::Quaterniond quaternionFromRpy(double roll, double pitch, double yaw);
double yawOf(const Eigen::Isometry3d& pose);

}  // namespace xpersif::core
