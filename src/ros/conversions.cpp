#include "xpersif/ros/conversions.h"

#include <stdexcept>

namespace xpersif {

geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& t) {
  geometry_msgs::Pose p;
  p.position.x = t.translation().x();
  p.position.y = t.translation().y();
  p.position.z = t.translation().z();
  const Eigen::Quaterniond q(t.rotation());
  p.orientation.x = q.x();
  p.orientation.y = q.y();
  p.orientation.z = q.z();
  p.orientation.w = q.w();
  return p;
}

geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& t) {
  const geometry_msgs::Pose p = toPoseMsg(t);
  geometry_msgs::Transform out;
  out.translation.x = p.position.x;
  out.translation.y = p.position.y;
  out.translation.z = p.position.z;
  out.rotation = p.orientation;
  return out;
}

Eigen::Isometry3d fromPoseMsg(const geometry_msgs::Pose& pose) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  t.linear() = Eigen::Quaterniond(pose.orientation.w, pose.orientation.x, pose.orientation.y, pose.orientation.z)
                   .normalized()
                   .toRotationMatrix();
  return t;
}

Eigen::Isometry3d fromTransformMsg(const geometry_msgs::Transform& t) {
  geometry_msgs::Pose p;
  p.position.x = t.translation.x;
  p.position.y = t.translation.y;
  p.position.z = t.translation.z;
  p.orientation = t.rotation;
  return fromPoseMsg(p);
}

xpersif::Scene toSceneMsg(const core::SceneDescription& scene) {
  xpersif::Scene msg;
  msg.world_frame = scene.world_frame;
  msg.header.frame_id = scene.world_frame;
  msg.world_file = scene.world_file;
  msg.robot_root = scene.robot_root;
  msg.robot_marker = scene.robot_marker;
  msg.robot_fiducial = scene.robot_fiducial.node;
  msg.robot_fiducial_dictionary = scene.robot_fiducial.dictionary;
  msg.robot_fiducial_id = scene.robot_fiducial.id;
  msg.robot_fiducial_size = scene.robot_fiducial.size;
  msg.objects = scene.objects;
  msg.arena_size_x = scene.arena_size_x;
  msg.arena_size_y = scene.arena_size_y;
  for (const auto& node : scene.nodes) {
    xpersif::SceneNode n;
    n.name = node.name;
    n.parent = node.parent;
    n.dynamic = node.dynamic;
    n.transform = toTransformMsg(node.parent_from_node);
    for (const auto& v : node.visuals) {
      xpersif::VisualShape s;
      s.type = static_cast<std::uint8_t>(v.shape.type);
      s.box_size.x = v.shape.box_size.x();
      s.box_size.y = v.shape.box_size.y();
      s.box_size.z = v.shape.box_size.z();
      s.radius = v.shape.radius;
      s.length = v.shape.length;
      s.color.r = v.color.r;
      s.color.g = v.color.g;
      s.color.b = v.color.b;
      s.color.a = v.color.a;
      s.offset = toPoseMsg(v.offset);
      n.visuals.push_back(s);
    }
    msg.nodes.push_back(n);
  }
  for (const auto& c : scene.cameras) {
    xpersif::SceneCamera cam;
    cam.name = c.name;
    cam.frame = c.frame;
    cam.width = static_cast<std::uint32_t>(c.width);
    cam.height = static_cast<std::uint32_t>(c.height);
    cam.fx = c.fx;
    cam.fy = c.fy;
    cam.cx = c.cx;
    cam.cy = c.cy;
    msg.cameras.push_back(cam);
  }
  return msg;
}

core::SceneDescription fromSceneMsg(const xpersif::Scene& msg) {
  core::SceneDescription scene;
  scene.world_frame = msg.world_frame;
  scene.world_file = msg.world_file;
  scene.robot_root = msg.robot_root;
  scene.robot_marker = msg.robot_marker;
  scene.robot_fiducial = {msg.robot_fiducial, msg.robot_fiducial_dictionary, msg.robot_fiducial_id,
                          msg.robot_fiducial_size};
  scene.objects = msg.objects;
  scene.arena_size_x = msg.arena_size_x;
  scene.arena_size_y = msg.arena_size_y;
  for (const auto& n : msg.nodes) {
    core::SceneNode node;
    node.name = n.name;
    node.parent = n.parent;
    node.dynamic = n.dynamic;
    node.parent_from_node = fromTransformMsg(n.transform);
    for (const auto& s : n.visuals) {
      if (s.type > xpersif::VisualShape::SPHERE) {
        throw std::invalid_argument("scene node '" + n.name + "' has a shape of unknown type " + std::to_string(s.type));
      }
      core::Visual v;
      v.shape.type = static_cast<core::Shape::Type>(s.type);
      v.shape.box_size = Eigen::Vector3d(s.box_size.x, s.box_size.y, s.box_size.z);
      v.shape.radius = s.radius;
      v.shape.length = s.length;
      v.color = {s.color.r, s.color.g, s.color.b, s.color.a};
      v.offset = fromPoseMsg(s.offset);
      node.visuals.push_back(v);
    }
    scene.nodes.push_back(node);
  }
  for (const auto& c : msg.cameras) {
    core::CameraModel cam;
    cam.name = c.name;
    cam.frame = c.frame;
    cam.width = static_cast<int>(c.width);
    cam.height = static_cast<int>(c.height);
    cam.fx = c.fx;
    cam.fy = c.fy;
    cam.cx = c.cx;
    cam.cy = c.cy;
    scene.cameras.push_back(cam);
  }
  return scene;
}

}  // namespace xpersif
