/**
 * @file renderer.h
 * @brief A ROS-free software renderer for XPERSim's scene: it draws the scene description (scene.h) as
 *        seen by one of its pinhole cameras, given the current world poses of the nodes.
 *
 * XPERSim only publishes transforms per frame; every client renders the scene itself from the scene
 * description it received once (the paper's TeleSimView idea). This renderer is that client-side
 * drawing step, kept free of ROS and OpenGL so it runs anywhere (tests, headless nodes) and so its
 * geometry is exact and documented: later stages measure object poses from these images.
 *
 * Image conventions (important for anyone measuring in these images):
 *  - The camera frame is an optical frame: z forward, x right, y down.
 *  - A camera-frame point (x, y, z) projects to the continuous image point
 *    u = fx * x / z + cx, v = fy * y / z + cy.
 *  - Pixel (column i, row j) covers [i, i+1) x [j, j+1) of that continuous image plane and is coloured by
 *    whatever surface covers its centre (i + 0.5, j + 0.5). A shape whose projection spans [u0, u1]
 *    therefore fills the columns i with u0 <= i + 0.5 <= u1. Note that this differs by half a pixel from
 *    OpenCV's convention (where pixel i's centre is at u = i): convert when using cv:: geometry functions.
 *  - Vertices are snapped to 1/256 pixel before rasterising, so edges are exact to about 0.002 pixel.
 *
 * Drawing model: every visual is a triangle mesh (box: 12 triangles; cylinder: 24 sides plus caps;
 * sphere: UV sphere of 24 x 12), rasterised with a per-pixel depth test (z-buffer), clipped to
 * z >= near_clip (so geometry crossing the camera plane is drawn correctly and nothing behind the camera
 * is drawn), and drawn only up to far_clip. Faces are flat shaded with one fixed directional light plus
 * ambient: colour = base colour * (ambient + diffuse * max(0, n . l)), n the face's outward normal and l
 * the direction towards the light, both in the world frame. Back faces are culled (all shapes are closed),
 * so a camera inside a shape, e.g. inside its own housing, sees out of it. Alpha is ignored (opaque).
 */
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstddef>
#include <string>
#include <vector>

#include "xpersif/core/common/scene.h"

namespace xpersif::core {

/// @brief How the renderer colours things: background and the fixed light.
struct RenderOptions {
  cv::Vec3b background_bgr{64, 64, 64};  ///< colour of pixels no surface covers (neutral dark grey)
  double ambient = 0.45;                  ///< light every face gets, as a fraction of its base colour
  double diffuse = 0.55;                  ///< extra light for a face facing the light squarely
  /// Direction towards the light in the world frame (need not be unit length, must not be zero). The default
  /// comes mostly from above and a little from +x and +y, so a box's top and its +x and +y sides all differ.
  Eigen::Vector3d light_direction{0.4, 0.25, 1.0};
};

/**
 * @brief Draws a SceneDescription from one camera, given world_from_node for its nodes.
 *
 * The meshes are built once in the constructor; render() only transforms and rasterises them.
 * Thread safety: render() is const and keeps its scratch buffers (depth buffer, transformed vertices)
 * in thread_local storage, so several threads may render with one Renderer at once, each into its own
 * image. The buffers are reused from frame to frame, so steady-state rendering does not allocate.
 */
class Renderer {
 public:
  /// @throws std::invalid_argument if options.light_direction is zero or a shape has a non-positive size
  explicit Renderer(const SceneDescription& scene, const RenderOptions& options = RenderOptions());

  /**
   * @brief Draws the scene into @p bgr (CV_8UC3, camera.height rows x camera.width columns; (re)allocated
   *        only if it does not have that size and type already).
   * @param camera intrinsics, image size and clipping distances (camera.frame is not used here)
   * @param world_from_camera pose of the camera's optical frame in the world (see cameraWorldPose())
   * @param world_from_node world poses of the nodes, e.g. from worldTransforms(); nodes without an entry
   *        are not drawn
   * @throws std::invalid_argument for an unusable camera (non-positive size or focal length,
   *         near_clip <= 0 or far_clip <= near_clip)
   */
  void render(const CameraModel& camera, const Eigen::Isometry3d& world_from_camera,
              const FrameTransforms& world_from_node, cv::Mat& bgr) const;

  const RenderOptions& options() const { return options_; }
  /// Total number of triangles in the prepared meshes (for tests and budgeting).
  std::size_t triangleCount() const;

 private:
  struct Triangle {
    int a, b, c;               // indices into NodeMesh::vertices, counter-clockwise seen from outside
    Eigen::Vector3d normal;    // outward unit normal, node frame
    Eigen::Vector3d color;     // base colour r, g, b in [0, 1]
  };
  struct NodeMesh {
    std::string name;
    std::vector<Eigen::Vector3d> vertices;  // node frame (the visuals' offsets already applied)
    std::vector<Triangle> triangles;
  };

  RenderOptions options_;
  Eigen::Vector3d light_world_;  // unit
  std::vector<NodeMesh> nodes_;  // only nodes that have visuals
};

/**
 * @brief The camera's optical-frame pose in the world: world_from_node of camera.frame.
 * @throws std::invalid_argument if camera.frame is neither in @p world_from_node nor the world frame
 */
Eigen::Isometry3d cameraWorldPose(const SceneDescription& scene, const FrameTransforms& world_from_node,
                                  const CameraModel& camera);

}  // namespace xpersif::core
