#include "xpersif/core/render/renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <tuple>
#include <utility>

namespace xpersif::core {

namespace {

constexpr int kCylinderSegments = 24;
constexpr int kSphereSlices = 24;
constexpr int kSphereStacks = 12;

// Vertices are snapped to 1/256 pixel so that coverage is decided with exact integer edge functions:
// two triangles sharing an edge then neither overlap nor leave cracks along it.
constexpr int kSubpixelBits = 8;
constexpr std::int64_t kSubpixel = std::int64_t{1} << kSubpixelBits;
constexpr std::int64_t kHalfPixel = kSubpixel / 2;

// Triangles are clipped in the image plane to the image plus this margin, which keeps the fixed-point
// coordinates small (no int64 overflow for huge projections near the camera plane) while the clipping
// seams stay outside the visible pixels.
constexpr double kGuardBandPx = 8.0;

struct LocalMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;
};

LocalMesh boxMesh(const Eigen::Vector3d& size) {
  const Eigen::Vector3d h = 0.5 * size;
  LocalMesh mesh;
  for (int i = 0; i < 8; ++i) {
    mesh.vertices.emplace_back((i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(), (i & 4) ? h.z() : -h.z());
  }
  // Winding is fixed up later (outward normals), so only the quads' vertex order around the face matters.
  const int quads[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};
  for (const auto& q : quads) {
    mesh.triangles.push_back({q[0], q[1], q[2]});
    mesh.triangles.push_back({q[0], q[2], q[3]});
  }
  return mesh;
}

LocalMesh cylinderMesh(double radius, double length) {
  LocalMesh mesh;
  const int n = kCylinderSegments;
  for (int ring = 0; ring < 2; ++ring) {
    const double z = ring == 0 ? -0.5 * length : 0.5 * length;
    for (int i = 0; i < n; ++i) {
      const double a = 2.0 * M_PI * i / n;
      mesh.vertices.emplace_back(radius * std::cos(a), radius * std::sin(a), z);
    }
  }
  const int bottom_centre = static_cast<int>(mesh.vertices.size());
  mesh.vertices.emplace_back(0.0, 0.0, -0.5 * length);
  mesh.vertices.emplace_back(0.0, 0.0, 0.5 * length);
  const int top_centre = bottom_centre + 1;
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    mesh.triangles.push_back({i, j, n + j});
    mesh.triangles.push_back({i, n + j, n + i});
    mesh.triangles.push_back({bottom_centre, i, j});
    mesh.triangles.push_back({top_centre, n + i, n + j});
  }
  return mesh;
}

LocalMesh sphereMesh(double radius) {
  LocalMesh mesh;
  const int slices = kSphereSlices, stacks = kSphereStacks;
  mesh.vertices.emplace_back(0.0, 0.0, radius);  // north pole: 0
  for (int s = 1; s < stacks; ++s) {
    const double polar = M_PI * s / stacks;
    for (int i = 0; i < slices; ++i) {
      const double az = 2.0 * M_PI * i / slices;
      mesh.vertices.emplace_back(radius * std::sin(polar) * std::cos(az), radius * std::sin(polar) * std::sin(az),
                                 radius * std::cos(polar));
    }
  }
  const int south = static_cast<int>(mesh.vertices.size());
  mesh.vertices.emplace_back(0.0, 0.0, -radius);
  auto ring = [&](int s, int i) { return 1 + (s - 1) * slices + (i % slices); };
  for (int i = 0; i < slices; ++i) {
    mesh.triangles.push_back({0, ring(1, i), ring(1, i + 1)});
    mesh.triangles.push_back({south, ring(stacks - 1, i), ring(stacks - 1, i + 1)});
    for (int s = 1; s + 1 < stacks; ++s) {
      mesh.triangles.push_back({ring(s, i), ring(s + 1, i), ring(s + 1, i + 1)});
      mesh.triangles.push_back({ring(s, i), ring(s + 1, i + 1), ring(s, i + 1)});
    }
  }
  return mesh;
}

LocalMesh shapeMesh(const Shape& shape, const std::string& node_name) {
  switch (shape.type) {
    case Shape::Type::Box:
      if (!(shape.box_size.minCoeff() > 0)) {
        throw std::invalid_argument("box on node '" + node_name + "' needs positive extents");
      }
      return boxMesh(shape.box_size);
    case Shape::Type::Cylinder:
      if (!(shape.radius > 0 && shape.length > 0)) {
        throw std::invalid_argument("cylinder on node '" + node_name + "' needs a positive radius and length");
      }
      return cylinderMesh(shape.radius, shape.length);
    case Shape::Type::Sphere:
      if (!(shape.radius > 0)) {
        throw std::invalid_argument("sphere on node '" + node_name + "' needs a positive radius");
      }
      return sphereMesh(shape.radius);
  }
  throw std::invalid_argument("unknown shape type on node '" + node_name + "'");
}

// A vertex in the image plane: u, v in pixels and w = 1/z. All three are affine in the image plane within
// one triangle, so clipping there by linear interpolation is exact, and so is the depth test on w.
struct ScreenVertex {
  double u, v, w;
};

using Polygon = std::array<ScreenVertex, 12>;  // a triangle clipped by 5 planes has at most 8 corners

// Both triangles that share an edge must compute the same intersection point bit for bit, whichever
// direction they walk the edge; so interpolate from the lexicographically smaller endpoint.
template <typename V, typename Less>
V interpolateCanonical(V a, double da, V b, double db, Less less) {
  if (less(b, a)) {
    std::swap(a, b);
    std::swap(da, db);
  }
  const double t = da / (da - db);
  return a + t * (b - a);
}

bool lessCam(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::tie(a.x(), a.y(), a.z()) < std::tie(b.x(), b.y(), b.z());
}

struct ScreenVec {  // ScreenVertex with the arithmetic interpolateCanonical needs
  ScreenVertex p;
  ScreenVec operator+(const ScreenVec& o) const { return {{p.u + o.p.u, p.v + o.p.v, p.w + o.p.w}}; }
  ScreenVec operator-(const ScreenVec& o) const { return {{p.u - o.p.u, p.v - o.p.v, p.w - o.p.w}}; }
  friend ScreenVec operator*(double s, const ScreenVec& a) { return {{s * a.p.u, s * a.p.v, s * a.p.w}}; }
};

bool lessScreen(const ScreenVec& a, const ScreenVec& b) {
  return std::tie(a.p.u, a.p.v, a.p.w) < std::tie(b.p.u, b.p.v, b.p.w);
}

// Clips polygon in[0..n) to the half plane where dist(vertex) >= 0 (Sutherland-Hodgman); returns the new size.
template <typename Dist>
int clipScreen(const Polygon& in, int n, Polygon& out, Dist dist) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const ScreenVertex& a = in[i];
    const ScreenVertex& b = in[(i + 1) % n];
    const double da = dist(a), db = dist(b);
    if (da >= 0) out[m++] = a;
    if ((da >= 0) != (db >= 0)) {
      out[m++] = interpolateCanonical(ScreenVec{a}, da, ScreenVec{b}, db, lessScreen).p;
    }
  }
  return m;
}

std::int64_t floorDiv(std::int64_t a, std::int64_t b) {  // b > 0
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}

struct Target {
  int width, height;
  float* depth;  // inverse depth 1/z per pixel, row-major; larger is nearer
  cv::Mat* bgr;
};

// Fills the pixels whose centres the triangle covers and whose stored inverse depth is smaller.
void rasterizeTriangle(const ScreenVertex& p0, ScreenVertex p1, ScreenVertex p2, const cv::Vec3b& color,
                       const Target& target) {
  std::int64_t x0 = std::llround(p0.u * kSubpixel), y0 = std::llround(p0.v * kSubpixel);
  std::int64_t x1 = std::llround(p1.u * kSubpixel), y1 = std::llround(p1.v * kSubpixel);
  std::int64_t x2 = std::llround(p2.u * kSubpixel), y2 = std::llround(p2.v * kSubpixel);
  std::int64_t area = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0);
  if (area == 0) return;
  if (area < 0) {
    std::swap(x1, x2);
    std::swap(y1, y2);
    std::swap(p1, p2);
    area = -area;
  }

  const std::int64_t min_x = std::min({x0, x1, x2}), max_x = std::max({x0, x1, x2});
  const std::int64_t min_y = std::min({y0, y1, y2}), max_y = std::max({y0, y1, y2});
  // Pixel i's centre is at i * kSubpixel + kHalfPixel.
  const std::int64_t i_begin = std::max<std::int64_t>(0, floorDiv(min_x - kHalfPixel + kSubpixel - 1, kSubpixel));
  const std::int64_t i_end = std::min<std::int64_t>(target.width - 1, floorDiv(max_x - kHalfPixel, kSubpixel));
  const std::int64_t j_begin = std::max<std::int64_t>(0, floorDiv(min_y - kHalfPixel + kSubpixel - 1, kSubpixel));
  const std::int64_t j_end = std::min<std::int64_t>(target.height - 1, floorDiv(max_y - kHalfPixel, kSubpixel));
  if (i_begin > i_end || j_begin > j_end) return;

  // Edge function of edge a->b at P: (xb - xa)(Py - ya) - (yb - ya)(Px - xa); >= 0 on the inside.
  // A pixel centre exactly on an edge belongs to only one of the two triangles sharing that edge: the
  // rule below is antisymmetric in the edge's direction, and a non-owning edge needs E >= 1.
  struct Edge {
    std::int64_t row_start, step_x, step_y;
  };
  const std::int64_t px0 = i_begin * kSubpixel + kHalfPixel, py0 = j_begin * kSubpixel + kHalfPixel;
  auto makeEdge = [&](std::int64_t xa, std::int64_t ya, std::int64_t xb, std::int64_t yb, std::int64_t& raw) {
    const std::int64_t dx = xb - xa, dy = yb - ya;
    raw = dx * (py0 - ya) - dy * (px0 - xa);
    const bool owns_ties = dy > 0 || (dy == 0 && dx < 0);
    return Edge{raw - (owns_ties ? 0 : 1), -dy * kSubpixel, dx * kSubpixel};
  };
  std::int64_t raw12, raw20, raw01;
  Edge e12 = makeEdge(x1, y1, x2, y2, raw12);  // weight of vertex 0
  Edge e20 = makeEdge(x2, y2, x0, y0, raw20);  // weight of vertex 1
  Edge e01 = makeEdge(x0, y0, x1, y1, raw01);  // weight of vertex 2

  // w is affine in the image plane: w = (E12 w0 + E20 w1 + E01 w2) / area, with the raw edge functions.
  const double inv_area = 1.0 / static_cast<double>(area);
  const double w_start = (raw12 * p0.w + raw20 * p1.w + raw01 * p2.w) * inv_area;
  const double w_step_x = (e12.step_x * p0.w + e20.step_x * p1.w + e01.step_x * p2.w) * inv_area;
  const double w_step_y = (e12.step_y * p0.w + e20.step_y * p1.w + e01.step_y * p2.w) * inv_area;

  for (std::int64_t j = j_begin; j <= j_end; ++j) {
    const std::int64_t dj = j - j_begin;
    std::int64_t a = e12.row_start + dj * e12.step_y;
    std::int64_t b = e20.row_start + dj * e20.step_y;
    std::int64_t c = e01.row_start + dj * e01.step_y;
    double w = w_start + static_cast<double>(dj) * w_step_y;
    float* depth_row = target.depth + j * target.width;
    auto* pixel_row = target.bgr->ptr<cv::Vec3b>(static_cast<int>(j));
    bool inside_before = false;
    for (std::int64_t i = i_begin; i <= i_end; ++i) {
      if ((a | b | c) >= 0) {
        inside_before = true;
        const float wf = static_cast<float>(w);
        if (wf > depth_row[i]) {
          depth_row[i] = wf;
          pixel_row[i] = color;
        }
      } else if (inside_before) {
        break;  // the triangle is convex: once left, the rest of the row is outside
      }
      a += e12.step_x;
      b += e20.step_x;
      c += e01.step_x;
      w += w_step_x;
    }
  }
}

// Per-thread scratch so render() can run concurrently and reuse its buffers frame to frame.
struct Scratch {
  std::vector<float> depth;
  std::vector<Eigen::Vector3d> camera_vertices;
};

}  // namespace

Renderer::Renderer(const SceneDescription& scene, const RenderOptions& options) : options_(options) {
  const double light_norm = options.light_direction.norm();
  if (!(light_norm > 0) || !std::isfinite(light_norm)) {
    throw std::invalid_argument("renderer light_direction must be a non-zero vector");
  }
  light_world_ = options.light_direction / light_norm;

  for (const auto& node : scene.nodes) {
    if (node.visuals.empty()) continue;
    NodeMesh node_mesh;
    node_mesh.name = node.name;
    for (const auto& visual : node.visuals) {
      const LocalMesh local = shapeMesh(visual.shape, node.name);
      const int base = static_cast<int>(node_mesh.vertices.size());
      for (const auto& v : local.vertices) node_mesh.vertices.push_back(visual.offset * v);
      const Eigen::Vector3d centre = visual.offset.translation();
      const Eigen::Vector3d color(std::clamp(static_cast<double>(visual.color.r), 0.0, 1.0),
                                  std::clamp(static_cast<double>(visual.color.g), 0.0, 1.0),
                                  std::clamp(static_cast<double>(visual.color.b), 0.0, 1.0));
      for (const auto& t : local.triangles) {
        Triangle tri{base + t[0], base + t[1], base + t[2], Eigen::Vector3d::Zero(), color};
        const Eigen::Vector3d& va = node_mesh.vertices[tri.a];
        const Eigen::Vector3d& vb = node_mesh.vertices[tri.b];
        const Eigen::Vector3d& vc = node_mesh.vertices[tri.c];
        Eigen::Vector3d n = (vb - va).cross(vc - va);
        const double len = n.norm();
        if (!(len > 0)) continue;  // degenerate (e.g. a sphere's pole fan never is, but be safe)
        n /= len;
        // All shapes are convex around their centre, so "outward" means away from it.
        if (n.dot((va + vb + vc) / 3.0 - centre) < 0) {
          std::swap(tri.b, tri.c);
          n = -n;
        }
        tri.normal = n;
        node_mesh.triangles.push_back(tri);
      }
    }
    nodes_.push_back(std::move(node_mesh));
  }
}

std::size_t Renderer::triangleCount() const {
  std::size_t n = 0;
  for (const auto& node : nodes_) n += node.triangles.size();
  return n;
}

void Renderer::render(const CameraModel& camera, const Eigen::Isometry3d& world_from_camera,
                      const FrameTransforms& world_from_node, cv::Mat& bgr) const {
  if (camera.width <= 0 || camera.height <= 0 || !(camera.fx > 0) || !(camera.fy > 0) ||
      !(camera.near_clip > 0) || !(camera.far_clip > camera.near_clip)) {
    throw std::invalid_argument("camera '" + camera.name +
                                "' needs a positive image size and focal lengths and 0 < near_clip < far_clip");
  }
  const int width = camera.width, height = camera.height;
  bgr.create(height, width, CV_8UC3);
  bgr.setTo(cv::Scalar(options_.background_bgr[0], options_.background_bgr[1], options_.background_bgr[2]));

  thread_local Scratch scratch;
  // Starting at 1/far makes the depth test also reject everything beyond the far plane.
  scratch.depth.assign(static_cast<std::size_t>(width) * height, static_cast<float>(1.0 / camera.far_clip));
  const Target target{width, height, scratch.depth.data(), &bgr};

  const double near = camera.near_clip, far = camera.far_clip;
  const double u_lo = -kGuardBandPx, u_hi = width + kGuardBandPx;
  const double v_lo = -kGuardBandPx, v_hi = height + kGuardBandPx;
  auto project = [&](const Eigen::Vector3d& p) {
    const double iz = 1.0 / p.z();
    return ScreenVertex{camera.fx * p.x() * iz + camera.cx, camera.fy * p.y() * iz + camera.cy, iz};
  };

  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  for (const auto& node : nodes_) {
    const auto pose = world_from_node.find(node.name);
    if (pose == world_from_node.end()) continue;
    const Eigen::Isometry3d camera_from_node = camera_from_world * pose->second;
    const Eigen::Matrix3d world_r_node = pose->second.linear();
    const Eigen::Matrix3d camera_r_node = camera_from_node.linear();

    auto& verts = scratch.camera_vertices;
    verts.resize(node.vertices.size());
    for (std::size_t k = 0; k < node.vertices.size(); ++k) verts[k] = camera_from_node * node.vertices[k];

    for (const auto& tri : node.triangles) {
      const Eigen::Vector3d* v[3] = {&verts[tri.a], &verts[tri.b], &verts[tri.c]};
      if (v[0]->z() < near && v[1]->z() < near && v[2]->z() < near) continue;
      if (v[0]->z() > far && v[1]->z() > far && v[2]->z() > far) continue;
      // Back face: the camera (at the origin) is on the inner side of the face's plane.
      if ((camera_r_node * tri.normal).dot(*v[0]) >= 0) continue;

      const double shade =
          options_.ambient + options_.diffuse * std::max(0.0, (world_r_node * tri.normal).dot(light_world_));
      cv::Vec3b color;
      for (int ch = 0; ch < 3; ++ch) {  // ch 0 = blue
        const double value = 255.0 * tri.color[2 - ch] * shade;
        color[ch] = static_cast<std::uint8_t>(std::clamp(std::lround(value), 0L, 255L));
      }

      // Near-plane clip in the camera frame; then everything has z >= near > 0 and projects.
      Polygon poly, tmp;
      int n = 0;
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d& a = *v[k];
        const Eigen::Vector3d& b = *v[(k + 1) % 3];
        const double da = a.z() - near, db = b.z() - near;
        if (da >= 0) poly[n++] = project(a);
        if ((da >= 0) != (db >= 0)) {
          Eigen::Vector3d p = interpolateCanonical(a, da, b, db, lessCam);
          p.z() = near;  // exactly on the plane, whatever the rounding
          poly[n++] = project(p);
        }
      }
      if (n < 3) continue;

      bool in_band = true;
      for (int k = 0; k < n; ++k) {
        in_band = in_band && poly[k].u >= u_lo && poly[k].u <= u_hi && poly[k].v >= v_lo && poly[k].v <= v_hi;
      }
      if (!in_band) {
        n = clipScreen(poly, n, tmp, [&](const ScreenVertex& p) { return p.u - u_lo; });
        n = clipScreen(tmp, n, poly, [&](const ScreenVertex& p) { return u_hi - p.u; });
        n = clipScreen(poly, n, tmp, [&](const ScreenVertex& p) { return p.v - v_lo; });
        n = clipScreen(tmp, n, poly, [&](const ScreenVertex& p) { return v_hi - p.v; });
        if (n < 3) continue;
      }
      for (int k = 1; k + 1 < n; ++k) rasterizeTriangle(poly[0], poly[k], poly[k + 1], color, target);
    }
  }
}

Eigen::Isometry3d cameraWorldPose(const SceneDescription& scene, const FrameTransforms& world_from_node,
                                  const CameraModel& camera) {
  const auto it = world_from_node.find(camera.frame);
  if (it != world_from_node.end()) return it->second;
  if (camera.frame == scene.world_frame) return Eigen::Isometry3d::Identity();
  throw std::invalid_argument("camera '" + camera.name + "': no world pose for its frame '" + camera.frame + "'");
}

}  // namespace xpersif::core
