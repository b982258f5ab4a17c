// Building the physics world from its spec: the arena, the robot's links and joints (from its URDF), the objects;
// and the scene description clients render (physics_world.h).
#include <opencv2/aruco.hpp>
#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "physics_internal.h"

namespace xpersif::core {

using namespace physics_detail;

namespace {

void setGeomOffset(dGeomID geom, const Eigen::Isometry3d& t) {
  dGeomSetOffsetPosition(geom, t.translation().x(), t.translation().y(), t.translation().z());
  const Eigen::Quaterniond q(t.rotation());
  const dQuaternion dq = {q.w(), q.x(), q.y(), q.z()};
  dGeomSetOffsetQuaternion(geom, dq);
}

dGeomID createGeom(dSpaceID space, const Shape& shape) {
  switch (shape.type) {
    case Shape::Type::Box: return dCreateBox(space, shape.box_size.x(), shape.box_size.y(), shape.box_size.z());
    case Shape::Type::Cylinder: return dCreateCylinder(space, shape.radius, shape.length);
    case Shape::Type::Sphere: return dCreateSphere(space, shape.radius);
  }
  return nullptr;
}

void setMass(dBodyID body, const LinkSpec& link) {
  dMass m;
  const Eigen::Matrix3d& i = link.inertia;
  const bool usable = i.trace() > 0 && i.determinant() > 0;
  if (usable) {
    dMassSetParameters(&m, link.mass, 0, 0, 0, i(0, 0), i(1, 1), i(2, 2), i(0, 1), i(0, 2), i(1, 2));
  } else if (!link.collisions.empty()) {
    // No usable inertia in the URDF: take the first collision shape's, with the link's mass.
    const Shape& s = link.collisions[0].shape;
    if (s.type == Shape::Type::Box) {
      dMassSetBoxTotal(&m, link.mass, s.box_size.x(), s.box_size.y(), s.box_size.z());
    } else if (s.type == Shape::Type::Cylinder) {
      dMassSetCylinderTotal(&m, link.mass, 3, s.radius, s.length);
    } else {
      dMassSetSphereTotal(&m, link.mass, s.radius);
    }
  } else {
    dMassSetSphereTotal(&m, link.mass, 0.01);
  }
  dBodySetMass(body, &m);
}

}  // namespace

void PhysicsWorld::Impl::build() {
  initOde();
  random_seed = spec.physics.seed;
  world = dWorldCreate();
  space = dHashSpaceCreate(nullptr);
  contacts = dJointGroupCreate(0);
  dWorldSetGravity(world, 0, 0, spec.physics.gravity);
  dWorldSetQuickStepNumIterations(world, spec.physics.iterations);
  dWorldSetERP(world, 0.2);
  dWorldSetCFM(world, 1e-6);
  dWorldSetContactSurfaceLayer(world, 0.0002);
  dWorldSetContactMaxCorrectingVel(world, 0.5);
  dWorldSetAutoDisableFlag(world, 0);  // disabling bodies would make results depend on history

  buildArena();
  buildRobot();
  for (const auto& object : spec.objects) buildObject(object);
  saveGoodState();
  updateFallHeight();
}

void PhysicsWorld::Impl::destroy() {
  for (auto ray : ir_rays) dGeomDestroy(ray);
  ir_rays.clear();
  if (contacts) dJointGroupDestroy(contacts);
  if (space) dSpaceDestroy(space);  // destroys its geoms (cleanup mode is on)
  if (world) dWorldDestroy(world);  // destroys bodies and joints
  contacts = nullptr;
  space = nullptr;
  world = nullptr;
  robot_bodies.clear();
  link_body.clear();
  body_from_link.clear();
  link_joint.clear();
  objects.clear();
  object_states.clear();
  geom_infos.clear();
  pending.clear();
  ir_mounts.clear();
}

dGeomID PhysicsWorld::Impl::addGeom(const Shape& shape, dBodyID body, const Eigen::Isometry3d& offset,
                                    double friction, bool robot, int object) {
  dGeomID geom = createGeom(space, shape);
  geom_infos.push_back(std::make_unique<GeomInfo>(GeomInfo{friction, robot, false, object}));
  dGeomSetData(geom, geom_infos.back().get());
  if (body) {
    dGeomSetBody(geom, body);
    setGeomOffset(geom, offset);
  } else {
    dGeomSetPosition(geom, offset.translation().x(), offset.translation().y(), offset.translation().z());
  }
  return geom;
}

void PhysicsWorld::Impl::buildArena() {
  const ArenaSpec& a = spec.arena;
  dGeomID floor = dCreatePlane(space, 0, 0, 1, 0);
  geom_infos.push_back(std::make_unique<GeomInfo>(GeomInfo{1.0, false, true, -1}));
  dGeomSetData(floor, geom_infos.back().get());
  for (const Visual& wall : a.walls()) addGeom(wall.shape, nullptr, wall.offset, 0.5, false);
}

void PhysicsWorld::Impl::buildRobot() {
  const RobotSpec& robot = spec.robot;
  // World pose of every link at the start, and the lowest point, to set the robot on the floor.
  std::map<std::string, Eigen::Isometry3d> world_from_link;
  double lowest = std::numeric_limits<double>::infinity();
  for (const auto& link : robot.links) {
    world_from_link[link.name] = link.parent.empty() ? robot.pose : world_from_link[link.parent] * link.parent_from_link;
    for (const auto& c : link.collisions) {
      lowest = std::min(lowest, lowestPoint(c.shape, world_from_link[link.name] * c.offset));
    }
  }
  const double lift = std::isfinite(lowest) ? robot.pose.translation().z() - lowest + 0.0001 : 0;
  for (auto& entry : world_from_link) entry.second.translation().z() += lift;
  const Eigen::Isometry3d& start = world_from_link[robot.links[0].name];
  odometry.x = start.translation().x();
  odometry.y = start.translation().y();
  odometry.yaw = yawOf(start);

  for (const auto& link : robot.links) {
    dBodyID body;
    if (link.joint_type == LinkSpec::JointType::Fixed) {
      body = link_body.at(link.parent);
      body_from_link[link.name] = body_from_link.at(link.parent) * link.parent_from_link;
    } else {
      body = dBodyCreate(world);
      setMass(body, link);
      setPoseOf(body, world_from_link[link.name]);
      robot_bodies.push_back(body);
      body_from_link[link.name] = Eigen::Isometry3d::Identity();
      if (link.joint_type == LinkSpec::JointType::Revolute) {
        dJointID hinge = dJointCreateHinge(world, nullptr);
        // ODE measures a hinge's angle and rate as body1 relative to body2: the link is body1.
        dJointAttach(hinge, body, link_body.at(link.parent));
        const Eigen::Vector3d anchor = world_from_link[link.name].translation();
        const Eigen::Vector3d axis = world_from_link[link.name].rotation() * link.axis.normalized();
        dJointSetHingeAnchor(hinge, anchor.x(), anchor.y(), anchor.z());
        dJointSetHingeAxis(hinge, axis.x(), axis.y(), axis.z());
        link_joint[link.name] = hinge;
        if (link.joint == robot.left_wheel_joint) left_wheel = hinge;
        if (link.joint == robot.right_wheel_joint) right_wheel = hinge;
        dJointSetHingeParam(hinge, dParamFMax, robot.max_wheel_torque);
        dJointSetHingeParam(hinge, dParamVel, 0.0);
      }
    }
    link_body[link.name] = body;
    const bool wheel = link.joint == robot.left_wheel_joint || link.joint == robot.right_wheel_joint;
    // Passive links below the body (sliders) slide without friction; wheels grip.
    const bool slider = link.joint_type == LinkSpec::JointType::Fixed && link.mass == 0 && link.visuals.empty();
    const double friction = wheel ? robot.wheel_friction : slider ? 0.0 : robot.body_friction;
    for (const auto& c : link.collisions) addGeom(c.shape, body, body_from_link[link.name] * c.offset, friction, true);
  }
  for (const auto& ir : robot.ir_sensors) {
    ir_mounts.emplace_back(link_body.at(ir), body_from_link.at(ir));
    dGeomID ray = dCreateRay(nullptr, robot.ir_range);
    ir_rays.push_back(ray);
  }
}

void PhysicsWorld::Impl::buildObject(const ObjectSpec& object) {
  dBodyID body = dBodyCreate(world);
  dMass m;
  switch (object.shape.type) {
    case Shape::Type::Box:
      dMassSetBoxTotal(&m, object.mass, object.shape.box_size.x(), object.shape.box_size.y(), object.shape.box_size.z());
      break;
    case Shape::Type::Cylinder: dMassSetCylinderTotal(&m, object.mass, 3, object.shape.radius, object.shape.length); break;
    case Shape::Type::Sphere: dMassSetSphereTotal(&m, object.mass, object.shape.radius); break;
  }
  dBodySetMass(body, &m);
  Eigen::Isometry3d pose = object.pose;
  pose.translation().z() += -lowestPoint(object.shape, pose) + 0.0001;  // rest on the floor
  setPoseOf(body, pose);
  ObjectState state;
  state.friction_x = object.friction;
  state.friction_y = object.friction_y;
  object_states.push_back(state);
  addGeom(object.shape, body, Eigen::Isometry3d::Identity(), object.friction, false,
          static_cast<int>(object_states.size()) - 1);
  if (object.shape.type == Shape::Type::Sphere) {
    // ODE has no rolling resistance: a ball would roll forever. Damp its spin at kBallSpinDamping per
    // second (whatever the step), down to standstill, so that it comes to rest like a ball on a mat.
    dBodySetAngularDamping(body, 1 - std::exp(-kBallSpinDamping * spec.physics.step));
    dBodySetAngularDampingThreshold(body, 0);
  }
  objects.emplace_back(object.name, body);
}

namespace {

// The height of the robot's highest visual above its root link's origin (links at their zero joint angles).
double robotTop(const RobotSpec& robot) {
  std::map<std::string, Eigen::Isometry3d> root_from_link;
  double top = 0;
  for (const auto& link : robot.links) {
    const Eigen::Isometry3d pose =
        link.parent.empty() ? Eigen::Isometry3d::Identity() : root_from_link.at(link.parent) * link.parent_from_link;
    root_from_link[link.name] = pose;
    for (const Visual& v : link.visuals) {
      // Boxes, cylinders and spheres are symmetric about their centre: the top is as far above it as the bottom
      // is below.
      const Eigen::Isometry3d at = pose * v.offset;
      top = std::max(top, 2 * at.translation().z() - lowestPoint(v.shape, at));
    }
  }
  return top;
}

// The robot's ArUco fiducial as XPERSim shows it: a square of cells on top of the robot, the marker's cells in a
// margin of one white cell on each side, drawn as one thin box per run of same-coloured cells in a row. The boxes
// tile the square without overlapping: a black cell drawn over a white plate would lie a fraction of a millimetre
// above it, closer than a viewer's depth buffer can tell apart (rviz's top-down orthographic view, whose depth
// range is kilometres), and which of the two showed would depend on the viewer's drawing order.
// The node's origin is the marker's top centre, its x axis the marker image's up.
SceneNode fiducialNode(const RobotSpec& robot) {
  constexpr double kThickness = 0.0015, kGap = 0.0005;
  const RobotSpec::Fiducial& f = robot.fiducial;
  const cv::Ptr<cv::aruco::Dictionary> dictionary = cv::aruco::getPredefinedDictionary(arucoDictionaryCode(f.dictionary));
  const cv::Mat bits = cv::aruco::Dictionary::getBitsFromByteList(dictionary->bytesList.rowRange(f.id, f.id + 1),
                                                                  dictionary->markerSize);
  const int cells = dictionary->markerSize + 2;  // the marker with its black border
  const int squares = cells + 2;                 // and the white margin
  const double cell = f.size / cells;
  SceneNode node;
  node.name = robot.links.front().name + "_fiducial";
  node.parent = robot.links.front().name;
  node.parent_from_node = f.offset;
  node.parent_from_node.translation().z() = robotTop(robot) + kGap + kThickness;
  // Square (row, column) of the margined square: row 0 the top (+x), column 0 the left (+y), seen from above.
  auto black = [&](int row, int column) {
    const int r = row - 1, c = column - 1;  // the marker's cell
    if (r < 0 || c < 0 || r >= cells || c >= cells) return false;
    const bool border = r == 0 || c == 0 || r == cells - 1 || c == cells - 1;
    return border || bits.at<uchar>(r - 1, c - 1) == 0;
  };
  for (int row = 0; row < squares; ++row) {
    for (int column = 0; column < squares;) {
      const bool ink = black(row, column);
      int end = column;
      while (end < squares && black(row, end) == ink) ++end;
      Visual run;
      run.color = ink ? Rgba{0, 0, 0, 1} : Rgba{1, 1, 1, 1};
      run.shape.box_size = Eigen::Vector3d(cell, (end - column) * cell, kThickness);
      run.offset.translation() = Eigen::Vector3d((squares / 2.0 - row - 0.5) * cell,
                                                 (squares / 2.0 - (column + end) / 2.0) * cell, -kThickness / 2);
      node.visuals.push_back(run);
      column = end;
    }
  }
  return node;
}

}  // namespace

SceneDescription PhysicsWorld::buildScene() const {
  SceneDescription scene;
  const ArenaSpec& a = spec_.arena;
  scene.world_file = spec_.source;
  scene.arena_size_x = a.size_x;
  scene.arena_size_y = a.size_y;
  if (!spec_.robot.links.empty()) scene.robot_root = spec_.robot.links.front().name;
  // A fiducial gives the heading; without one, the heading marker (by default the first small box link) does.
  const bool fiducial = !spec_.robot.fiducial.dictionary.empty() && !spec_.robot.links.empty();
  scene.robot_marker = fiducial ? "" : spec_.robot.heading_marker;
  for (std::size_t i = 1; !fiducial && scene.robot_marker.empty() && i < spec_.robot.links.size(); ++i) {
    const auto& visuals = spec_.robot.links[i].visuals;
    if (visuals.size() == 1 && visuals.front().shape.type == Shape::Type::Box) {
      scene.robot_marker = spec_.robot.links[i].name;
    }
  }
  for (const ObjectSpec& o : spec_.objects) scene.objects.push_back(o.name);
  SceneNode arena;
  arena.name = "arena";
  arena.parent = scene.world_frame;
  Visual floor;
  floor.shape.box_size = Eigen::Vector3d(a.size_x + 2 * a.wall_thickness, a.size_y + 2 * a.wall_thickness, 0.002);
  floor.offset.translation() = Eigen::Vector3d(0, 0, -0.001);
  floor.color = a.floor_color;
  arena.visuals.push_back(floor);
  for (const Visual& wall : a.walls()) arena.visuals.push_back(wall);
  scene.nodes.push_back(arena);

  const FrameTransforms now = dynamicTransforms();
  for (const auto& link : spec_.robot.links) {
    SceneNode node;
    node.name = link.name;
    node.parent = link.parent.empty() ? scene.world_frame : link.parent;
    node.dynamic = link.joint_type != LinkSpec::JointType::Fixed;
    node.parent_from_node = node.dynamic ? now.at(link.name) : link.parent_from_link;
    node.visuals = link.visuals;
    scene.nodes.push_back(node);
  }
  if (fiducial) {
    scene.nodes.push_back(fiducialNode(spec_.robot));
    scene.robot_fiducial = {scene.nodes.back().name, spec_.robot.fiducial.dictionary, spec_.robot.fiducial.id,
                            spec_.robot.fiducial.size};
  }
  for (std::size_t i = 0; i < spec_.objects.size(); ++i) {
    const ObjectSpec& o = spec_.objects[i];
    SceneNode node;
    node.name = o.name;
    node.parent = scene.world_frame;
    node.dynamic = true;
    node.parent_from_node = now.at(o.name);
    Visual v;
    v.shape = o.shape;
    v.color = o.color;
    node.visuals.push_back(v);
    scene.nodes.push_back(node);
  }
  for (const auto& c : spec_.cameras) {
    SceneNode node;
    node.name = c.model.frame;
    node.parent = c.parent;
    node.parent_from_node = c.parent_from_optical;
    scene.nodes.push_back(node);
    scene.cameras.push_back(c.model);
  }
  return scene;
}

}  // namespace xpersif::core
