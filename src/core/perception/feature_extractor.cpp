#include "xpersif/core/perception/feature_extractor.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <set>
#include <utility>

#include "xpersif/core/perception/robot_tracker.h"
#include "xpersif/core/render/renderer.h"
#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

// Chromaticity of a base colour, in OpenCV's (b, g, r) order.
cv::Vec3f chromaOf(const Rgba& c) {
  const double sum = static_cast<double>(c.r) + c.g + c.b;
  if (sum <= 0) return {1.0f / 3, 1.0f / 3, 1.0f / 3};  // black: treat as neutral
  return {static_cast<float>(c.b / sum), static_cast<float>(c.g / sum), static_cast<float>(c.r / sum)};
}

float chebyshev(const cv::Vec3f& a, const cv::Vec3f& b) {
  return std::max({std::fabs(a[0] - b[0]), std::fabs(a[1] - b[1]), std::fabs(a[2] - b[2])});
}

std::string describeColor(const Rgba& c) {
  return "(" + describeNumber(c.r) + ", " + describeNumber(c.g) + ", " + describeNumber(c.b) + ")";
}

// The renderer's pinhole model, both ways. (u, v) are continuous image coordinates in the renderer's
// convention: pixel (i, j) has its centre at (i + 0.5, j + 0.5).
class Pinhole {
 public:
  Pinhole(const CameraModel& camera, const Eigen::Isometry3d& world_from_camera)
      : c_(camera), wc_(world_from_camera) {}

  Eigen::Vector3d rayWorld(double u, double v) const {
    return wc_.linear() * Eigen::Vector3d((u - c_.cx) / c_.fx, (v - c_.cy) / c_.fy, 1.0);
  }
  /// Where the ray through (u, v) meets the horizontal plane at height z (in front of the camera only).
  bool toPlane(double u, double v, double z, Eigen::Vector3d& out) const {
    const Eigen::Vector3d d = rayWorld(u, v);
    const Eigen::Vector3d o = wc_.translation();
    if (std::fabs(d.z()) < 1e-12) return false;
    const double s = (z - o.z()) / d.z();
    if (!(s > 0)) return false;
    out = o + s * d;
    return true;
  }
  /// Camera-frame depth (optical z) of a world point.
  double depth(const Eigen::Vector3d& world) const { return (wc_.inverse() * world).z(); }
  const Eigen::Isometry3d& pose() const { return wc_; }

 private:
  const CameraModel& c_;
  Eigen::Isometry3d wc_;
};

// OpenCV pixel indices -> renderer continuous coordinates.
cv::Point2d toRenderer(const cv::Point2d& p) { return {p.x + 0.5, p.y + 0.5}; }

// The largest outer contour of a binary mask (by enclosed area, ties by length), or empty.
std::vector<cv::Point> largestContour(const cv::Mat& mask, const cv::Point& offset = cv::Point()) {
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE, offset);
  std::vector<cv::Point>* best = nullptr;
  double best_score = -1;
  for (auto& c : contours) {
    const double score = cv::contourArea(c) + 0.5 * c.size();  // thin blobs still rank above nothing
    if (score > best_score) {
      best_score = score;
      best = &c;
    }
  }
  return best ? *best : std::vector<cv::Point>();
}

// A blob: one contour of a class mask, its filled pixels (within the ROI) and stats.
struct Blob {
  std::vector<cv::Point> contour;  // full-image OpenCV coordinates
  cv::Rect roi;                    // bounding box of the contour
  cv::Mat mask;                    // CV_8U, roi-sized: class pixels inside the contour
  int pixels = 0;
  cv::Point2d centroid;            // renderer convention, full image
  bool touches_border = false;
};

// A blob from one outer contour of @p class_mask; false if it has fewer than @p min_pixels class pixels.
bool blobFromContour(const cv::Mat& class_mask, std::vector<cv::Point> contour, double min_pixels, Blob& blob) {
  blob.contour = std::move(contour);
  if (blob.contour.empty()) return false;
  blob.roi = cv::boundingRect(blob.contour);
  cv::Mat filled = cv::Mat::zeros(blob.roi.size(), CV_8U);
  cv::drawContours(filled, std::vector<std::vector<cv::Point>>{blob.contour}, 0, cv::Scalar(255), cv::FILLED,
                   cv::LINE_8, cv::noArray(), 0, -blob.roi.tl());
  cv::bitwise_and(filled, class_mask(blob.roi), blob.mask);
  const cv::Moments m = cv::moments(blob.mask, true);
  blob.pixels = static_cast<int>(m.m00);
  if (blob.pixels < min_pixels || blob.pixels <= 0) return false;
  blob.centroid = toRenderer({m.m10 / m.m00 + blob.roi.x, m.m01 / m.m00 + blob.roi.y});
  blob.touches_border = blob.roi.x == 0 || blob.roi.y == 0 || blob.roi.br().x == class_mask.cols ||
                        blob.roi.br().y == class_mask.rows;
  return true;
}

/// The largest blob of @p class_mask, searching only @p where (which must hold every set pixel of the mask).
bool makeBlob(const cv::Mat& class_mask, const cv::Rect& where, double min_pixels, Blob& blob) {
  if (where.empty()) return false;
  return blobFromContour(class_mask, largestContour(class_mask(where), where.tl()), min_pixels, blob);
}

/// Every blob of @p class_mask within @p where, largest first, at most @p max_count of them.
std::vector<Blob> allBlobs(const cv::Mat& class_mask, const cv::Rect& where, double min_pixels, std::size_t max_count) {
  std::vector<Blob> blobs;
  if (where.empty()) return blobs;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(class_mask(where), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE, where.tl());
  for (auto& c : contours) {
    Blob b;
    if (blobFromContour(class_mask, std::move(c), min_pixels, b)) blobs.push_back(std::move(b));
  }
  std::sort(blobs.begin(), blobs.end(), [](const Blob& a, const Blob& b) { return a.pixels > b.pixels; });
  if (blobs.size() > max_count) blobs.resize(max_count);
  return blobs;
}

// The brightest shade of a blob (its top face, lit from above): pixels at least `fraction` as bright as the
// blob's bright level, its 90th-percentile brightness. A percentile, not the maximum: with sensor noise the
// maximum is an outlier, and a dark top face (the robot's body) would lose pixels to the threshold and break up.
// Returns a roi-sized mask.
cv::Mat brightestShade(const Blob& blob, const cv::Mat& brightness, double fraction) {
  std::array<int, 766> histogram{};
  int total = 0;
  for (int j = 0; j < blob.mask.rows; ++j) {
    const uchar* m = blob.mask.ptr<uchar>(j);
    const ushort* b = brightness.ptr<ushort>(j + blob.roi.y) + blob.roi.x;
    for (int i = 0; i < blob.mask.cols; ++i) {
      if (m[i]) {
        ++histogram[b[i]];
        ++total;
      }
    }
  }
  int level = 0;
  for (int seen = 0, rank = (9 * total + 9) / 10; level < 765; ++level) {
    seen += histogram[level];
    if (seen >= rank) break;
  }
  cv::Mat top;
  cv::compare(brightness(blob.roi), fraction * level, top, cv::CMP_GE);
  cv::bitwise_and(top, blob.mask, top);
  return top;
}

struct Line {
  cv::Point2d p, d;  // a point and a unit direction
};

bool intersect(const Line& a, const Line& b, cv::Point2d& out) {
  const double det = a.d.x * b.d.y - a.d.y * b.d.x;
  if (std::fabs(det) < 1e-3) return false;  // (nearly) parallel
  const cv::Point2d w = b.p - a.p;
  const double t = (w.x * b.d.y - w.y * b.d.x) / det;
  out = a.p + t * a.d;
  return true;
}

/**
 * The four corners (OpenCV coordinates, in order around) of the quadrilateral a contour outlines, with
 * sub-pixel edges: the contour is split into the four sides of its minimum-area rectangle, each side's points
 * (away from the corners) get a least-squares line, and adjacent lines are intersected. The contour runs
 * through the centres of the outermost pixels, which lie on average max(|nx|, |ny|) / 2 pixels inside the
 * true edge (n its normal), so each line is moved out by that much.
 */
std::array<cv::Point2d, 4> fitQuadrilateral(const std::vector<cv::Point>& contour) {
  const cv::RotatedRect rect = cv::minAreaRect(contour);
  cv::Point2f rp[4];
  rect.points(rp);
  std::array<cv::Point2d, 4> rect_corners;
  for (int k = 0; k < 4; ++k) rect_corners[k] = rp[k];
  std::array<std::vector<cv::Point2f>, 4> sides;
  for (const cv::Point& q : contour) {
    int best = -1;
    double best_dist = std::numeric_limits<double>::max(), best_t = 0, best_len = 0;
    for (int k = 0; k < 4; ++k) {
      const cv::Point2d a = rect_corners[k], b = rect_corners[(k + 1) % 4];
      const cv::Point2d ab = b - a;
      const double len = std::sqrt(ab.dot(ab));
      if (len < 1e-9) continue;
      const double t = (cv::Point2d(q) - a).dot(ab) / (len * len);
      const cv::Point2d closest = a + std::clamp(t, 0.0, 1.0) * ab;
      const cv::Point2d diff = cv::Point2d(q) - closest;
      const double dist = std::sqrt(diff.dot(diff));
      if (dist < best_dist) {
        best_dist = dist;
        best = k;
        best_t = t;
        best_len = len;
      }
    }
    if (best < 0) continue;
    const double margin = std::max(1.5, 0.15 * best_len);  // corners are rounded by the pixel grid
    if (best_t * best_len < margin || (1 - best_t) * best_len < margin) continue;
    sides[best].emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
  }
  const cv::Point2d centre = rect.center;
  std::array<Line, 4> lines;
  for (int k = 0; k < 4; ++k) {
    Line line;
    if (sides[k].size() >= 3) {
      cv::Vec4f f;
      cv::fitLine(sides[k], f, cv::DIST_L2, 0, 0.001, 0.001);
      line.d = {f[0], f[1]};
      line.p = {f[2], f[3]};
    } else {  // too few points: keep the rectangle's side
      line.p = rect_corners[k];
      const cv::Point2d ab = rect_corners[(k + 1) % 4] - rect_corners[k];
      line.d = ab * (1.0 / std::max(1e-9, std::sqrt(ab.dot(ab))));
    }
    cv::Point2d n(line.d.y, -line.d.x);
    if ((line.p - centre).dot(n) < 0) n = -n;  // outward
    line.p += n * (0.5 * std::max(std::fabs(n.x), std::fabs(n.y)));
    lines[k] = line;
  }
  std::array<cv::Point2d, 4> corners;
  for (int k = 0; k < 4; ++k) {
    // Corner k of the rectangle is where side k-1 ends and side k begins.
    if (!intersect(lines[(k + 3) % 4], lines[k], corners[k])) return rect_corners;
  }
  return corners;
}

// A box's footprint from a forward camera. For each column of the blob, the lowest covered pixel marks the
// box's near bottom edge (nothing of the box shows below it); back-projected onto the floor these points trace
// one edge (a face turned to the camera) or two edges meeting at the nearest corner. With two edges the centre
// is the corner plus half the size along both; with one, the edge's midpoint plus half the size away from the
// camera. When the edges are too short to fit, the plain ground-contact rule is used: the lowest point plus
// half the size along the viewing ray.
struct Footprint {
  bool ok = false;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d contact = Eigen::Vector2d::Zero();  // the nearest floor point of the box
};

Eigen::Vector2d toEigen(const cv::Point2f& p) { return Eigen::Vector2d(p.x, p.y); }

// For each column of the blob, its lowest covered pixel back-projected onto the floor (world x, y, left to right
// in the image). @p columns counts the blob's columns, @p cut those whose contact the image border hides.
std::vector<cv::Point2f> groundPoints(const Blob& blob, const Pinhole& cam, int image_rows, int& cut, int& columns) {
  std::vector<cv::Point2f> ground;
  cut = 0;
  columns = 0;
  for (int c = 0; c < blob.mask.cols; ++c) {
    int row = -1;
    for (int j = blob.mask.rows - 1; j >= 0; --j) {
      if (blob.mask.at<uchar>(j, c)) {
        row = j;
        break;
      }
    }
    if (row < 0) continue;
    ++columns;
    const int image_row = row + blob.roi.y;
    if (image_row >= image_rows - 1) {  // cut by the image border: its contact point is not seen
      ++cut;
      continue;
    }
    // The edge lies on average half a pixel below the lowest covered pixel's centre.
    Eigen::Vector3d g;
    if (cam.toPlane(c + blob.roi.x + 0.5, image_row + 1.0, 0.0, g)) {
      ground.emplace_back(static_cast<float>(g.x()), static_cast<float>(g.y()));
    }
  }
  return ground;
}

// A least-squares line through ground[from..to]: a point on it and its direction from `from` towards `to`.
void fitEdge(const std::vector<cv::Point2f>& ground, std::size_t from, std::size_t to, Eigen::Vector2d& point,
             Eigen::Vector2d& dir) {
  std::vector<cv::Point2f> pts(ground.begin() + from, ground.begin() + to + 1);
  cv::Vec4f f;
  cv::fitLine(pts, f, cv::DIST_L2, 0, 1e-4, 1e-4);
  point = Eigen::Vector2d(f[2], f[3]);
  dir = Eigen::Vector2d(f[0], f[1]);
  if (dir.dot(toEigen(ground[to]) - toEigen(ground[from])) < 0) dir = -dir;
}

// Two edges meeting at the nearest point ground[k]: the centre is their corner plus half the size along both.
// False when the fitted edges do not make a corner (one face split in two).
bool centreFromCorner(const std::vector<cv::Point2f>& ground, std::size_t k, double left_len, double right_len,
                      const Eigen::Vector2d& footprint, Eigen::Vector2d& centre) {
  Eigen::Vector2d p1, d1, p2, d2;
  fitEdge(ground, 0, k, p1, d1);                  // runs towards the corner
  fitEdge(ground, k, ground.size() - 1, p2, d2);  // runs away from it
  d1 = -d1;                                       // both away from the corner now
  const double cross = d1.x() * d2.y() - d1.y() * d2.x();
  if (!(std::fabs(cross) > std::sin(M_PI / 4))) return false;
  // Corner: p1 + t d1 = p2 + u d2.
  const Eigen::Vector2d w = p2 - p1;
  const double t = (w.x() * d2.y() - w.y() * d2.x()) / cross;
  const Eigen::Vector2d corner = p1 + t * d1;
  // The two edges are perpendicular: average their directions modulo pi/2, then rebuild both.
  const double a1 = std::atan2(d1.y(), d1.x()), a2 = std::atan2(d2.y(), d2.x());
  const double yaw = std::atan2(std::sin(4 * a1) + std::sin(4 * a2), std::cos(4 * a1) + std::cos(4 * a2)) / 4;
  auto snap = [&](const Eigen::Vector2d& d) {
    const double q = std::round((std::atan2(d.y(), d.x()) - yaw) / (M_PI / 2)) * (M_PI / 2) + yaw;
    return Eigen::Vector2d(std::cos(q), std::sin(q));
  };
  // The long side along the edge seen longer (a seen edge is never longer than its side).
  const double along1 = 0.5 * (left_len >= right_len ? footprint.x() : footprint.y());
  const double along2 = 0.5 * (left_len >= right_len ? footprint.y() : footprint.x());
  centre = corner + along1 * snap(d1) + along2 * snap(d2);
  return true;
}

// One face turned to the camera: the seen edge's midpoint plus half the size away from the camera.
Eigen::Vector2d centreFromFace(const std::vector<cv::Point2f>& ground, const Eigen::Vector2d& cam_xy,
                               const Eigen::Vector2d& footprint) {
  Eigen::Vector2d p, d;
  fitEdge(ground, 0, ground.size() - 1, p, d);
  double tmin = std::numeric_limits<double>::max(), tmax = -tmin;
  for (const auto& g : ground) {
    const double t = (toEigen(g) - p).dot(d);
    tmin = std::min(tmin, t);
    tmax = std::max(tmax, t);
  }
  const Eigen::Vector2d mid = p + 0.5 * (tmin + tmax) * d;
  Eigen::Vector2d n(-d.y(), d.x());
  if (n.dot(mid - cam_xy) < 0) n = -n;
  // A face of the long side turned to the camera when the seen edge is nearer its length than the short one.
  const double seen = tmax - tmin;
  const bool long_face = std::fabs(seen - footprint.x()) < std::fabs(seen - footprint.y());
  return mid + 0.5 * (long_face ? footprint.y() : footprint.x()) * n;
}

// @p footprint: the object's horizontal extents, long side first. A disc (@p disc) is the nearest contact point
// plus its radius (footprint / 2) along the viewing ray: the nearest point of a circle lies on the line to its centre.
Footprint groundFootprint(const Blob& blob, const Pinhole& cam, const Eigen::Vector3d& camera_position,
                          const Eigen::Vector2d& footprint, bool disc, int image_rows) {
  const double size = footprint.y();  // the short side bounds which outlines are long enough to fit
  Footprint fp;
  int cut = 0, columns = 0;
  const std::vector<cv::Point2f> ground = groundPoints(blob, cam, image_rows, cut, columns);
  if (ground.empty() || 2 * cut > columns) return fp;
  const Eigen::Vector2d cam_xy = camera_position.head<2>();
  std::size_t k = 0;  // the nearest point: the corner, or somewhere on a face turned to the camera
  for (std::size_t i = 1; i < ground.size(); ++i) {
    if ((toEigen(ground[i]) - cam_xy).norm() < (toEigen(ground[k]) - cam_xy).norm()) k = i;
  }
  fp.contact = toEigen(ground[k]);
  const double half = 0.25 * (footprint.x() + footprint.y());  // fallback, when the sides are not told apart
  const Eigen::Vector2d to_contact = fp.contact - cam_xy;
  if (disc) {
    // The nearest point's distance from the rows (the arc is flat there, so its column is poorly defined);
    // the bearing from the middle of the blob's columns: the outline is symmetric about the disc's centre.
    const Eigen::Vector3d ray = cam.rayWorld(blob.roi.x + 0.5 * blob.roi.width, blob.centroid.y);
    if (to_contact.norm() < 1e-9 || ray.head<2>().norm() < 1e-9) return fp;
    fp.centre = cam_xy + (to_contact.norm() + 0.5 * footprint.x()) * ray.head<2>().normalized();
    fp.ok = true;
    return fp;
  }
  const double left_len = (toEigen(ground.front()) - fp.contact).norm();
  const double right_len = (toEigen(ground.back()) - fp.contact).norm();
  const bool two = k >= 2 && k + 2 < ground.size() && left_len > 0.3 * size && right_len > 0.3 * size;
  if (two && centreFromCorner(ground, k, left_len, right_len, footprint, fp.centre)) {
    fp.ok = true;
    return fp;
  }
  if (ground.size() >= 4 && (toEigen(ground.front()) - toEigen(ground.back())).norm() > 0.5 * size) {
    fp.centre = centreFromFace(ground, cam_xy, footprint);
    fp.ok = true;
    return fp;
  }
  if (to_contact.norm() < 1e-9) return fp;
  fp.centre = fp.contact + half * to_contact.normalized();
  fp.ok = true;
  return fp;
}

// Above this mismatch (a sum of log size ratios and shape penalties) a blob is not taken for an object of its
// colour when several share the colour: it is something else, or the object is partly hidden.
constexpr double kMaxMatchCost = 0.6;
// A blob is ambiguous when two objects' costs for it differ by less than this.
constexpr double kAmbiguityMargin = 0.05;

// Fill of a contour's minimum-area rectangle: ~1 for a rectangle, ~0.78 for a disc.
double rectangleFill(const std::vector<cv::Point>& contour) {
  const cv::RotatedRect r = cv::minAreaRect(contour);
  const double area = r.size.area();
  return area > 0 ? cv::contourArea(contour) / area : 0;
}

double logRatio(double measured, double expected) {
  return measured > 0 && expected > 0 ? std::fabs(std::log(measured / expected)) : 10.0;
}

// Measures one blob as one catalogue object: its pose, measured size and confidence, and how badly the blob
// matches the object's shape and size (cost, 0 = perfect), so blobs of a shared colour can be assigned.
struct Measurer {
  const CameraModel& camera;
  const PerceptionOptions& options;
  const Pinhole& cam;
  const cv::Mat& brightness;
  cv::Size image;
  bool downward;

  // False when the blob cannot be measured as @p obj; then @p cut tells whether only because the image border
  // cuts it (it may still be that object: cost is then 0, "plausible").
  bool measure(const ObjectAppearance& obj, const Blob& blob, ObjectDetection& det, double& cost, bool& cut) const {
    cut = false;
    cost = 0;
    det = ObjectDetection();
    det.name = obj.name;
    det.centroid = blob.centroid;
    det.pixel_area = blob.pixels;
    det.contour = blob.contour;
    if (obj.rotationallySymmetric()) {
      det.yaw = 0;
      det.yaw_period = 2 * M_PI;
      det.yaw_known = false;
    }
    if (!downward) return groundContact(obj, blob, det, cost, cut);
    switch (obj.shape.type) {
      case Shape::Type::Box: return boxFromAbove(obj, blob, det, cost, cut);
      case Shape::Type::Cylinder: return cylinderFromAbove(obj, blob, det, cost, cut);
      case Shape::Type::Sphere: return sphereFromAbove(obj, blob, det, cost, cut);
    }
    return false;
  }

 private:
  bool insideImage(const std::vector<cv::Point>& contour) const {
    const cv::Rect r = cv::boundingRect(contour);
    return r.x > 0 && r.y > 0 && r.br().x < image.width && r.br().y < image.height;
  }
  // Floor area of one pixel at camera depth @p depth.
  double pixelArea(double depth) const { return depth * depth / (camera.fx * camera.fy); }

  bool boxFromAbove(const ObjectAppearance& obj, const Blob& blob, ObjectDetection& det, double& cost, bool& cut) const {
    const double sx = obj.shape.box_size.x(), sy = obj.shape.box_size.y(), sz = obj.shape.box_size.z();
    const cv::Mat top = brightestShade(blob, brightness, options.top_face_brightness);
    det.top_contour = largestContour(top, blob.roi.tl());
    if (det.top_contour.size() < 4) return false;
    if (!insideImage(det.top_contour)) return cut = true, false;  // cut: not measurable
    std::array<Eigen::Vector3d, 4> corners;
    const std::array<cv::Point2d, 4> quad = fitQuadrilateral(det.top_contour);
    for (int k = 0; k < 4; ++k) {
      const cv::Point2d p = toRenderer(quad[k]);
      if (!cam.toPlane(p.x, p.y, sz, corners[k])) return false;
    }
    det.top_corners.assign(corners.begin(), corners.end());
    const Eigen::Vector3d top_centre = 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
    // Pixels the top face should cover if whole: its area over one pixel's footprint at its depth.
    const double depth = cam.depth(top_centre);
    if (!(depth > 0) || cv::countNonZero(top) < options.min_top_fraction * sx * sy / pixelArea(depth)) {
      return false;  // occluded or cut
    }
    det.position = top_centre - Eigen::Vector3d(0, 0, 0.5 * sz);
    // Side lengths and directions: edges 0-1 and 2-3 are one pair, 1-2 and 3-0 the other.
    const Eigen::Vector3d e[4] = {corners[1] - corners[0], corners[2] - corners[1], corners[3] - corners[2],
                                  corners[0] - corners[3]};
    const double len_a = 0.5 * (e[0].head<2>().norm() + e[2].head<2>().norm());
    const double len_b = 0.5 * (e[1].head<2>().norm() + e[3].head<2>().norm());
    // Each edge's direction, turned onto the first pair's direction (modulo pi).
    double angles[4];
    for (int k = 0; k < 4; ++k) angles[k] = std::atan2(e[k].y(), e[k].x()) - (k % 2 ? M_PI / 2 : 0);
    const bool square = std::fabs(sx - sy) <= 1e-6 * std::max(sx, sy);
    det.yaw_period = square ? M_PI / 2 : M_PI;
    // The box's x side is its longer one (or the first if square): which measured pair is that?
    double offset = 0;
    if (!square && ((sx > sy) != (len_a >= len_b))) offset = M_PI / 2;
    const double factor = 2 * M_PI / det.yaw_period;
    double c = 0, s = 0;
    for (int k = 0; k < 4; ++k) {
      c += std::cos(factor * angles[k]);
      s += std::sin(factor * angles[k]);
    }
    det.yaw = foldAngle(std::atan2(s, c) / factor + offset, det.yaw_period);
    det.yaw_known = true;
    det.measured_length = std::max(len_a, len_b);
    det.measured_width = std::min(len_a, len_b);
    const double ratio = (len_a * len_b) / (sx * sy);
    det.confidence = std::min(ratio, 1 / ratio);
    const Eigen::Vector2d expected = obj.footprint();
    cost = logRatio(det.measured_length, expected.x()) + logRatio(det.measured_width, expected.y()) +
           4 * std::max(0.0, 0.9 - rectangleFill(det.top_contour));  // a disc's top is no rectangle
    return true;
  }

  bool cylinderFromAbove(const ObjectAppearance& obj, const Blob& blob, ObjectDetection& det, double& cost, bool& cut) const {
    const double r = obj.shape.radius, h = obj.shape.length;
    const cv::Mat top = brightestShade(blob, brightness, options.top_face_brightness);
    det.top_contour = largestContour(top, blob.roi.tl());
    if (det.top_contour.size() < 3) return false;
    if (!insideImage(det.top_contour)) return cut = true, false;
    // The top disc's pixels (its largest part only): their centroid is the disc centre's image to ~0.1 mm.
    cv::Mat disc = cv::Mat::zeros(top.size(), CV_8U);
    cv::drawContours(disc, std::vector<std::vector<cv::Point>>{det.top_contour}, 0, cv::Scalar(255), cv::FILLED,
                     cv::LINE_8, cv::noArray(), 0, -blob.roi.tl());
    cv::bitwise_and(disc, top, disc);
    const cv::Moments m = cv::moments(disc, true);
    if (m.m00 <= 0) return false;
    const cv::Point2d c = toRenderer({m.m10 / m.m00 + blob.roi.x, m.m01 / m.m00 + blob.roi.y});
    Eigen::Vector3d top_centre;
    if (!cam.toPlane(c.x, c.y, h, top_centre)) return false;
    const double depth = cam.depth(top_centre);
    const double area = m.m00 * pixelArea(depth);
    const double ratio = area / (M_PI * r * r);
    if (!(depth > 0) || ratio < options.min_top_fraction) return false;  // occluded or cut
    det.position = top_centre - Eigen::Vector3d(0, 0, 0.5 * h);
    det.measured_length = det.measured_width = 2 * std::sqrt(area / M_PI);
    det.confidence = std::min(ratio, 1 / ratio);
    cost = logRatio(det.measured_length, 2 * r) + 4 * std::max(0.0, rectangleFill(det.top_contour) - 0.88);
    return true;
  }

  bool sphereFromAbove(const ObjectAppearance& obj, const Blob& blob, ObjectDetection& det, double& cost, bool& cut) const {
    const double r = obj.shape.radius;
    if (blob.touches_border) return cut = true, false;  // a cut silhouette's centroid is off
    Eigen::Vector3d centre;
    if (!cam.toPlane(blob.centroid.x, blob.centroid.y, r, centre)) return false;
    const double depth = cam.depth(centre);
    const double area = blob.pixels * pixelArea(depth);
    const double ratio = area / (M_PI * r * r);
    if (!(depth > 0) || ratio < options.min_top_fraction) return false;  // occluded
    det.position = centre;
    det.measured_length = det.measured_width = 2 * std::sqrt(area / M_PI);
    det.confidence = std::min(ratio, 1 / ratio);
    // A ball is shaded across: its brightest shade is a cap, not most of it as a cylinder's top disc is.
    const double top_share = cv::countNonZero(brightestShade(blob, brightness, options.top_face_brightness)) /
                             static_cast<double>(blob.pixels);
    cost = logRatio(det.measured_length, 2 * r) + 2 * std::max(0.0, top_share - 0.75) +
           4 * std::max(0.0, rectangleFill(blob.contour) - 0.88);
    return true;
  }

  bool groundContact(const ObjectAppearance& obj, const Blob& blob, ObjectDetection& det, double& cost, bool& cut) const {
    const Eigen::Vector3d camera_position = cam.pose().translation();
    double depth = 0;
    if (obj.shape.type == Shape::Type::Sphere) {
      // Its contact point is hidden beneath it: the silhouette's centre lies on the ray to its centre.
      // Two distance estimates, weighted by their sensitivity to a pixel: the ray meets z = radius (grazing,
      // hence poor, for a camera little above the centre), and the silhouette's angular width (2 asin(r / D)).
      if (blob.touches_border) return cut = true, false;
      const double r = obj.shape.radius;
      const Eigen::Vector3d ray = cam.rayWorld(blob.centroid.x, blob.centroid.y).normalized();
      const Eigen::Vector3d left = cam.rayWorld(blob.roi.x, blob.centroid.y).normalized();
      const Eigen::Vector3d right = cam.rayWorld(blob.roi.x + blob.roi.width, blob.centroid.y).normalized();
      const double half_angle = 0.5 * std::acos(std::clamp(left.dot(right), -1.0, 1.0));
      const double above = camera_position.z() - r;  // camera height over the centre
      if (!(half_angle > 0) || ray.head<2>().norm() < 1e-9) return false;
      const double range = r / std::sin(half_angle);
      const double d_size = std::sqrt(std::max(0.0, range * range - above * above));
      double sum_w = 1 / std::pow(range * range / (2 * r * camera.fx), 2), d = sum_w * d_size;
      Eigen::Vector3d centre;
      if (above > 1e-6 && cam.toPlane(blob.centroid.x, blob.centroid.y, r, centre)) {
        const double d_ray = (centre - camera_position).head<2>().norm();
        const double w = 1 / std::pow(d_ray * d_ray / (above * camera.fy), 2);
        d += w * d_ray;
        sum_w += w;
      }
      d /= sum_w;
      det.position = camera_position + d * Eigen::Vector3d(ray.x(), ray.y(), 0).normalized();
      det.position.z() = r;
      depth = cam.depth(det.position);
    } else {
      const bool disc = obj.shape.type == Shape::Type::Cylinder;
      const Footprint fp = groundFootprint(blob, cam, camera_position, obj.footprint(), disc, image.height);
      if (!fp.ok) return cut = blob.touches_border, false;
      det.position = Eigen::Vector3d(fp.centre.x(), fp.centre.y(), 0.5 * obj.height());
      depth = cam.depth(Eigen::Vector3d(fp.contact.x(), fp.contact.y(), 0));
      if (!disc) {
        const Eigen::Vector3d& s = obj.shape.box_size;
        det.yaw_period = std::fabs(s.x() - s.y()) <= 1e-6 * std::max(s.x(), s.y()) ? M_PI / 2 : M_PI;
        det.yaw_known = false;  // a few pixels of edge: too coarse to report (see groundFootprint)
        det.yaw = 0;
      }
    }
    det.measured_length = blob.roi.width * depth / camera.fx;
    det.measured_width = blob.roi.height * depth / camera.fy;
    const double ratio = det.measured_width / obj.height();
    det.confidence = std::min(ratio, 1 / ratio) * (blob.touches_border ? 0.5 : 1.0);
    // The horizontal extent lies between the footprint's short side and its diagonal (any yaw).
    const Eigen::Vector2d f = obj.footprint();
    const double lo = 0.85 * f.y(), hi = 1.15 * (obj.rotationallySymmetric() ? f.x() : f.norm());
    // Seen from the side a ball's outline is a disc; a box's or an upright cylinder's is nearly a rectangle.
    const double fill = rectangleFill(blob.contour);
    const double shape_penalty = obj.shape.type == Shape::Type::Sphere ? std::max(0.0, fill - 0.86)
                                                                         : std::max(0.0, 0.86 - fill);
    // A blob cut by the image border is only a lower bound on the extent, and its outline is no guide to shape.
    const bool outline_cut = blob.touches_border;
    cost = logRatio(det.measured_width, obj.height()) + std::max(0.0, std::log(det.measured_length / hi)) +
           (outline_cut ? 0.0 : std::max(0.0, std::log(lo / std::max(det.measured_length, 1e-9))) + 4 * shape_penalty);
    return true;
  }
};

double wrapPi(double a) { return foldAngle(a, 2 * M_PI); }

std::string checkPose(const Eigen::Isometry3d& pose) {
  const Eigen::Matrix4d& m = pose.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (!std::isfinite(m(r, c))) {
        return "world_from_camera has a non-finite entry (" + describeNumber(m(r, c)) + " at row " +
               std::to_string(r) + ", column " + std::to_string(c) + "); it must be a finite rigid transform";
      }
    }
  }
  const Eigen::Matrix3d rot = pose.linear();
  const double err = (rot.transpose() * rot - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (err > 1e-6 || rot.determinant() < 0) {
    return "world_from_camera is not a rigid transform (its rotation part is not orthonormal with determinant "
           "+1)";
  }
  return "";
}

void checkImage(const cv::Mat& bgr, const CameraModel& camera) {
  if (bgr.empty()) throw ValidationError("the image is empty; expected a " + std::to_string(camera.width) + " x " +
                                         std::to_string(camera.height) + " BGR image (CV_8UC3)");
  if (bgr.type() != CV_8UC3) {
    throw ValidationError("the image has " + std::to_string(bgr.channels()) + " channel(s) of depth code " +
                          std::to_string(bgr.depth()) + "; expected 8-bit BGR (CV_8UC3)");
  }
  if (bgr.cols != camera.width || bgr.rows != camera.height) {
    throw ValidationError("the image is " + std::to_string(bgr.cols) + " x " + std::to_string(bgr.rows) +
                          " pixels; camera '" + camera.name + "' gives " + std::to_string(camera.width) + " x " +
                          std::to_string(camera.height));
  }
}

// The labelling pass's result: brightness (b + g + r) and the colour label of every pixel (0 = none, k + 1 =
// labels[k]), and each label's bounding box grown by a pixel (empty when no pixel has the label).
struct LabelledImage {
  cv::Mat brightness, label;
  std::vector<cv::Rect> where;
};

// Near-grey pixels (floor, walls, background) are in no class: a pixel whose chromaticity is closer to grey
// (1/3, 1/3, 1/3) than every class box is skipped without the division. Distance to grey, times 3 (b+g+r):
// max |3c - sum| / sum.
float greyMargin(const std::vector<FeatureExtractor::ColorClass>& labels) {
  float grey_margin = 3.0f;
  const cv::Vec3f grey(1.0f / 3, 1.0f / 3, 1.0f / 3);
  for (const auto& c : labels) grey_margin = std::min(grey_margin, 3 * (chebyshev(c.chroma, grey) - c.tolerance));
  return std::max(0.0f, grey_margin * 0.999f);
}

// One pass over the image: brightness and the colour label of every pixel, by chromaticity (and brightness, for a
// grey class). The boxes do not overlap (each is at most half the distance to the next colour), so the first
// match is the only one.
LabelledImage labelPixels(const cv::Mat& bgr, const std::vector<FeatureExtractor::ColorClass>& labels,
                          double min_brightness, const cv::Mat& background, int min_difference) {
  LabelledImage image{cv::Mat(bgr.size(), CV_16U), cv::Mat(bgr.size(), CV_8U), std::vector<cv::Rect>(labels.size())};
  const int n = static_cast<int>(labels.size());
  std::vector<int> x0(n, bgr.cols), y0(n, bgr.rows), x1(n, -1), y1(n, -1);
  std::array<float, 766> inverse;  // 1 / (b + g + r)
  inverse[0] = 0;
  for (int k = 1; k < 766; ++k) inverse[k] = 1.0f / k;
  // With a background, dark pixels are classified too (a black object differs from the floor); their
  // chromaticity is unreliable, so they count as neutral grey.
  const bool subtract = !background.empty();
  const int min_sum = subtract ? 0 : static_cast<int>(std::ceil(min_brightness));
  const int dark_sum = static_cast<int>(std::ceil(min_brightness));
  const float grey_margin = greyMargin(labels);
  for (int j = 0; j < bgr.rows; ++j) {
    const uchar* p = bgr.ptr<uchar>(j);
    const uchar* q = subtract ? background.ptr<uchar>(j) : nullptr;
    ushort* b = image.brightness.ptr<ushort>(j);
    uchar* l = image.label.ptr<uchar>(j);
    int last_b = -1, last_g = -1, last_r = -1, last_label = 0;
    for (int i = 0; i < bgr.cols; ++i, p += 3) {
      const int sum = p[0] + p[1] + p[2];
      b[i] = static_cast<ushort>(sum);
      if (subtract) {
        const uchar* bg = q + 3 * i;
        if (std::abs(p[0] - bg[0]) + std::abs(p[1] - bg[1]) + std::abs(p[2] - bg[2]) < min_difference) {
          l[i] = 0;  // the empty arena's own pixel: never an object
          last_b = -1;
          continue;
        }
      }
      // Flat shading paints large runs of identical pixels (the floor above all): reuse the last answer.
      if (p[0] == last_b && p[1] == last_g && p[2] == last_r) {
        l[i] = static_cast<uchar>(last_label);
        if (last_label) {
          const int k = last_label - 1;
          x1[k] = std::max(x1[k], i);
        }
        continue;
      }
      last_b = p[0];
      last_g = p[1];
      last_r = p[2];
      last_label = 0;
      l[i] = 0;
      if (sum < min_sum) continue;
      const bool dark = subtract && sum < dark_sum;
      const int off = dark ? 0 : std::max({std::abs(3 * p[0] - sum), std::abs(3 * p[1] - sum), std::abs(3 * p[2] - sum)});
      if (off < grey_margin * sum) continue;
      const float inv = inverse[sum];
      const float cb = dark ? 1.0f / 3 : p[0] * inv, cg = dark ? 1.0f / 3 : p[1] * inv, cr = dark ? 1.0f / 3 : p[2] * inv;
      for (int k = 0; k < n; ++k) {
        const FeatureExtractor::ColorClass& c = labels[k];
        if (std::fabs(cb - c.chroma[0]) <= c.tolerance && std::fabs(cg - c.chroma[1]) <= c.tolerance &&
            std::fabs(cr - c.chroma[2]) <= c.tolerance && sum >= c.min_brightness && sum <= c.max_brightness) {
          l[i] = static_cast<uchar>(k + 1);
          last_label = k + 1;
          x0[k] = std::min(x0[k], i);
          x1[k] = std::max(x1[k], i);
          y0[k] = std::min(y0[k], j);
          y1[k] = std::max(y1[k], j);
          break;
        }
      }
    }
  }
  // findContours needs a background pixel around a blob: grow the boxes by one, within the image.
  for (int k = 0; k < n; ++k) {
    if (x1[k] >= 0) {
      image.where[k] = cv::Rect(cv::Point(x0[k] - 1, y0[k] - 1), cv::Point(x1[k] + 2, y1[k] + 2)) &
                       cv::Rect(0, 0, bgr.cols, bgr.rows);
    }
  }
  return image;
}

// A blob measured as one of the objects sharing its colour.
struct Candidate {
  double cost;
  std::size_t object, blob;
  bool measured;  // false: cut by the border, plausibly this object but not measurable
  ObjectDetection det;
};

// One extract() call on one labelled image: the catalogue's objects, then the robot, into `out`.
struct Extraction {
  const PerceptionCatalogue& catalogue;
  const CameraModel& camera;
  const PerceptionOptions& options;
  const std::vector<int>& label_of;  // FeatureExtractor's: the label of each class
  const std::vector<FeatureExtractor::ColorClass>& classes;
  const Pinhole& cam;
  const LabelledImage& image;
  const cv::Mat& kernel;  // the morphological opening of each class mask; empty: none
  cv::Size size;
  Detections& out;

  // A full-size mask of label k, filled in only within where[k] (nothing of the label is outside it).
  cv::Mat classMask(std::size_t k) const {
    cv::Mat mask = cv::Mat::zeros(size, CV_8U);
    if (image.where[k].empty()) return mask;
    cv::Mat part = mask(image.where[k]);
    cv::compare(image.label(image.where[k]), static_cast<double>(k + 1), part, cv::CMP_EQ);
    if (!kernel.empty()) cv::morphologyEx(part, part, cv::MORPH_OPEN, kernel);
    return mask;
  }

  // Objects, colour class by colour class: with one object of a colour its largest blob; with several, every
  // blob is measured as each of them and the best-matching pairs are taken (assignBlobs).
  void findObjects() const {
    const Measurer measurer{camera, options, cam, image.brightness, size, out.downward};
    std::vector<ObjectDetection> found(catalogue.objects.size());
    std::vector<bool> seen(catalogue.objects.size(), false);
    for (std::size_t label = 0; label < image.where.size(); ++label) {
      std::vector<std::size_t> members;
      for (std::size_t i = 0; i < catalogue.objects.size(); ++i) {
        if (label_of[i] == static_cast<int>(label) + 1) members.push_back(i);
      }
      if (members.empty()) continue;
      const cv::Mat mask = classMask(label);
      if (members.size() == 1) {
        Blob blob;
        if (!makeBlob(mask, image.where[label], options.min_blob_pixels, blob)) continue;
        double cost = 0;
        bool cut = false;
        seen[members[0]] = measurer.measure(catalogue.objects[members[0]], blob, found[members[0]], cost, cut);
        continue;
      }
      const std::vector<Blob> blobs = allBlobs(mask, image.where[label], options.min_blob_pixels, 3 * members.size());
      assignBlobs(measurer, blobs, members, found, seen);
    }
    for (std::size_t i = 0; i < catalogue.objects.size(); ++i) {
      if (seen[i]) {
        out.objects.emplace(catalogue.objects[i].name, std::move(found[i]));
      } else {
        out.missing.push_back(catalogue.objects[i].name);
      }
    }
  }

  // Same-coloured objects' blobs: greedy on the mismatch cost, each blob and object taken once.
  void assignBlobs(const Measurer& measurer, const std::vector<Blob>& blobs, const std::vector<std::size_t>& members,
                   std::vector<ObjectDetection>& found, std::vector<bool>& seen) const {
    std::vector<Candidate> candidates;
    for (std::size_t b = 0; b < blobs.size(); ++b) {
      for (std::size_t i : members) {
        Candidate c{0, i, b, false, {}};
        bool cut = false;
        c.measured = measurer.measure(catalogue.objects[i], blobs[b], c.det, c.cost, cut);
        if ((c.measured || cut) && c.cost < kMaxMatchCost) candidates.push_back(std::move(c));
      }
    }
    std::sort(candidates.begin(), candidates.end(),
              [](const Candidate& x, const Candidate& y) { return x.cost < y.cost; });
    std::vector<bool> blob_taken(blobs.size(), false);
    for (Candidate& c : candidates) {
      if (seen[c.object] || blob_taken[c.blob]) continue;
      blob_taken[c.blob] = true;
      // A blob that another still-unplaced object of the colour fits about as well (a cut outline, a cylinder
      // and a ball of one size side-on) is ambiguous: better missing than reported as the wrong object.
      bool ambiguous = false;
      for (const Candidate& other : candidates) {
        ambiguous = ambiguous || (other.blob == c.blob && other.object != c.object && !seen[other.object] &&
                                  other.cost < c.cost + kAmbiguityMargin);
      }
      if (ambiguous || !c.measured) continue;
      seen[c.object] = true;
      found[c.object] = std::move(c.det);
    }
  }

  // The robot, from above: the centre of its body's top face, the heading from the marker.
  void findRobot() const {
    const RobotAppearance& robot = catalogue.robot;
    if (!robot.present || !out.downward) return;
    const std::size_t body_label = label_of[catalogue.objects.size()] - 1;
    const bool has_marker = classes.size() > catalogue.objects.size() + 1;
    const std::size_t marker_label = has_marker ? label_of[catalogue.objects.size() + 1] - 1 : 0;
    Blob body;
    if (!makeBlob(classMask(body_label), image.where[body_label], options.min_blob_pixels, body)) return;
    cv::Mat disc = brightestShade(body, image.brightness, options.top_face_brightness);
    cv::Mat marker_mask;
    if (has_marker) {
      marker_mask = classMask(marker_label);
      // The marker sits on the disc and hides part of it: count it in (grown a pixel to close the seam).
      cv::Mat grown;
      cv::dilate(marker_mask(body.roi), grown, cv::Mat());
      cv::bitwise_or(disc, grown, disc);
    }
    measureRobotBody(body, disc);
    if (out.robot.found && has_marker) headingFromMarker(marker_mask, image.where[marker_label]);
  }

  // The robot found where its body's top face (@p disc, the marker counted in) meets the plane of its top.
  void measureRobotBody(const Blob& body, const cv::Mat& disc) const {
    const RobotAppearance& robot = catalogue.robot;
    const std::vector<cv::Point> outline = largestContour(disc, body.roi.tl());
    if (outline.size() < 3) return;
    const cv::Moments m = cv::moments(outline);
    if (!(m.m00 > 0)) return;
    const cv::Point2d c = toRenderer({m.m10 / m.m00, m.m01 / m.m00});
    Eigen::Vector3d centre;
    if (!cam.toPlane(c.x, c.y, robot.body_top, centre)) return;
    RobotDetection& r = out.robot;
    r.found = true;
    r.x = centre.x();
    r.y = centre.y();
    r.centroid = body.centroid;
    r.pixel_area = body.pixels;
    r.contour = body.contour;
    const double depth = cam.depth(centre);
    const double top_area = m.m00 * depth * depth / (camera.fx * camera.fy);
    const double ratio = top_area / robot.body_area;
    r.confidence = std::min(ratio, 1 / ratio);
  }

  // The heading from the largest marker blob within reach of the body (stray pixels of a nearby thing of the
  // marker's colour are smaller): its top face's centre, on the plane of the marker's top.
  void headingFromMarker(const cv::Mat& marker_mask, const cv::Rect& where) const {
    const RobotAppearance& robot = catalogue.robot;
    const double reach = robot.body_radius + robot.marker_offset.head<2>().norm();
    std::vector<std::vector<cv::Point>> contours;
    if (!where.empty()) {
      cv::findContours(marker_mask(where), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE, where.tl());
    }
    int best = 0;
    Eigen::Vector3d marker_world;
    bool seen = false;
    for (const auto& c : contours) {
      Blob mb;
      mb.contour = c;
      mb.roi = cv::boundingRect(c);
      cv::Mat filled = cv::Mat::zeros(mb.roi.size(), CV_8U);
      cv::drawContours(filled, std::vector<std::vector<cv::Point>>{c}, 0, cv::Scalar(255), cv::FILLED, cv::LINE_8,
                       cv::noArray(), 0, -mb.roi.tl());
      cv::bitwise_and(filled, marker_mask(mb.roi), mb.mask);
      const int pixels = cv::countNonZero(mb.mask);
      if (pixels <= best) continue;
      const cv::Mat top = brightestShade(mb, image.brightness, options.top_face_brightness);
      const cv::Moments m = cv::moments(top, true);
      if (m.m00 <= 0) continue;
      const cv::Point2d p = toRenderer({m.m10 / m.m00 + mb.roi.x, m.m01 / m.m00 + mb.roi.y});
      Eigen::Vector3d w;
      if (!cam.toPlane(p.x, p.y, robot.marker_top, w)) continue;
      if (std::hypot(w.x() - out.robot.x, w.y() - out.robot.y) >= reach) continue;
      best = pixels;
      marker_world = w;
      seen = true;
    }
    if (seen && robot.marker_offset.head<2>().norm() > 1e-6) {
      const double seen_angle = std::atan2(marker_world.y() - out.robot.y, marker_world.x() - out.robot.x);
      out.robot.yaw = wrapPi(seen_angle - std::atan2(robot.marker_offset.y(), robot.marker_offset.x()));
      out.robot.yaw_known = true;
    }
  }
};

}  // namespace

double foldAngle(double yaw, double period) {
  double a = std::fmod(yaw, period);
  if (a > period / 2) a -= period;
  if (a <= -period / 2) a += period;
  return a;
}

// ---- catalogue --------------------------------------------------------------------------------------

const ObjectAppearance* PerceptionCatalogue::find(const std::string& name) const {
  for (const auto& o : objects) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

double ObjectAppearance::height() const {
  switch (shape.type) {
    case Shape::Type::Box: return shape.box_size.z();
    case Shape::Type::Cylinder: return shape.length;
    case Shape::Type::Sphere: return 2 * shape.radius;
  }
  return 0;
}

Eigen::Vector2d ObjectAppearance::footprint() const {
  if (shape.type != Shape::Type::Box) return Eigen::Vector2d::Constant(2 * shape.radius);
  const double x = shape.box_size.x(), y = shape.box_size.y();
  return {std::max(x, y), std::min(x, y)};
}

namespace {

// Footprint area seen from above of an upright visual (cylinders and boxes; spheres by their disc).
double areaFromAbove(const Shape& s) {
  if (s.type == Shape::Type::Box) return s.box_size.x() * s.box_size.y();
  return M_PI * s.radius * s.radius;
}

double halfHeight(const Shape& s) {
  switch (s.type) {
    case Shape::Type::Box: return 0.5 * s.box_size.z();
    case Shape::Type::Cylinder: return 0.5 * s.length;
    case Shape::Type::Sphere: return s.radius;
  }
  return 0;
}

// The visual of @p node with the largest footprint seen from above among the accepted types, or nullptr.
const Visual* largestFromAbove(const SceneNode& node, bool boxes, bool cylinders, bool spheres) {
  const Visual* best = nullptr;
  for (const Visual& v : node.visuals) {
    const bool accepted = (v.shape.type == Shape::Type::Box && boxes) ||
                          (v.shape.type == Shape::Type::Cylinder && cylinders) ||
                          (v.shape.type == Shape::Type::Sphere && spheres);
    if (accepted && (!best || areaFromAbove(v.shape) > areaFromAbove(best->shape))) best = &v;
  }
  return best;
}

// Same colour class: chromaticities this close share one pixel label (their shades overlap).
bool sameColourClass(const Rgba& a, const Rgba& b) { return chebyshev(chromaOf(a), chromaOf(b)) < 0.01f; }

const char* shapeWord(Shape::Type t, bool plural) {
  switch (t) {
    case Shape::Type::Box: return plural ? "boxes" : "box";
    case Shape::Type::Cylinder: return plural ? "cylinders" : "cylinder";
    case Shape::Type::Sphere: return plural ? "spheres" : "sphere";
  }
  return "";
}

std::string describeShape(const Shape& s) {
  auto mm = [](double m) { return describeNumber(m); };
  switch (s.type) {
    case Shape::Type::Box:
      return mm(s.box_size.x()) + " x " + mm(s.box_size.y()) + " x " + mm(s.box_size.z()) + " m";
    case Shape::Type::Cylinder: return "radius " + mm(s.radius) + " m, length " + mm(s.length) + " m";
    case Shape::Type::Sphere: return "radius " + mm(s.radius) + " m";
  }
  return "";
}

bool within(double a, double b, double tolerance) { return std::fabs(a - b) <= tolerance * std::max(a, b); }


// Every visual of the robot (the root and the nodes below it) in the root's frame, and the fiducial it carries.
void addRobotParts(const SceneDescription& scene, const FrameTransforms& world, const std::string& robot_root,
                   RobotAppearance& r) {
  const Eigen::Isometry3d root_from_world = world.at(robot_root).inverse();
  std::set<std::string> robot_nodes = {robot_root};
  for (const SceneNode& node : scene.nodes) {  // parents come before their children
    if (node.name != robot_root && !robot_nodes.count(node.parent)) continue;
    robot_nodes.insert(node.name);
    const Eigen::Isometry3d root_from_node = root_from_world * world.at(node.name);
    for (Visual v : node.visuals) {
      v.offset = root_from_node * v.offset;
      r.parts.push_back(v);
    }
  }
  r.root_height = world.at(robot_root).translation().z();
  const SceneFiducial& f = scene.robot_fiducial;
  if (f.node.empty()) return;
  if (!robot_nodes.count(f.node)) {
    throw ValidationError("robot fiducial '" + f.node + "' is not a node on the robot '" + robot_root + "'");
  }
  r.fiducial.dictionary = arucoDictionaryCode(f.dictionary);
  if (r.fiducial.dictionary < 0) throw ValidationError("robot fiducial's dictionary '" + f.dictionary + "' is unknown");
  requirePositive("robot fiducial's size", f.size);
  r.fiducial.id = f.id;
  r.fiducial.size = f.size;
  r.fiducial.root_from_marker = root_from_world * world.at(f.node);
}

// The robot's body (the root's visual with the largest footprint from above) and heading marker; @p used collects
// the visuals looked for. A robot with a fiducial needs neither.
void addRobotLooks(const SceneDescription& scene, const FrameTransforms& world, const std::string& robot_root,
                   RobotAppearance& r, std::set<const Visual*>& used) {
  const Visual* body = largestFromAbove(*scene.findNode(robot_root), true, true, false);
  r.present = true;
  r.name = robot_root;
  r.marker_size = Eigen::Vector3d::Zero();  // no marker: the heading comes from the fiducial, or stays unknown
  if (r.fiducial.dictionary >= 0) return;
  if (!body) {
    throw ValidationError("robot root '" + robot_root +
                          "' has no cylinder or box visual; the perception catalogue needs the robot's body (or give "
                          "the robot a fiducial in the world file)");
  }
  r.body_color = body->color;
  r.body_shape = body->shape;
  r.body_radius = body->shape.type == Shape::Type::Box ? 0.5 * body->shape.box_size.head<2>().norm()
                                                       : body->shape.radius;
  r.body_area = areaFromAbove(body->shape);
  const Eigen::Isometry3d world_root = world.at(robot_root);
  r.body_top = (world_root * body->offset).translation().z() + halfHeight(body->shape);
  used.insert(body);
  if (scene.robot_marker.empty()) return;
  const SceneNode* node = scene.findNode(scene.robot_marker);
  if (!node) throw ValidationError("robot marker '" + scene.robot_marker + "' names no node of the scene");
  const Visual* marker = largestFromAbove(*node, true, true, true);
  if (!marker) throw ValidationError("robot marker '" + scene.robot_marker + "' has no visual to see");
  const Eigen::Isometry3d world_marker = world.at(node->name) * marker->offset;
  r.marker_color = marker->color;
  const Shape& m = marker->shape;
  r.marker_size = m.type == Shape::Type::Box ? m.box_size
                                             : Eigen::Vector3d(2 * m.radius, 2 * m.radius, 2 * halfHeight(m));
  r.marker_offset = world_root.inverse() * world_marker.translation();
  r.marker_top = world_marker.translation().z() + halfHeight(m);
  used.insert(marker);
}

}  // namespace

PerceptionCatalogue PerceptionCatalogue::fromScene(const SceneDescription& scene, const std::string& robot_root_override) {
  const std::string& robot_root = robot_root_override.empty() ? scene.robot_root : robot_root_override;
  PerceptionCatalogue cat;
  const FrameTransforms world = worldTransforms(scene);
  std::set<const Visual*> used;
  for (const std::string& name : scene.objects) {
    const SceneNode* node = scene.findNode(name);
    if (!node) throw ValidationError("scene object '" + name + "' names no node of the scene");
    const Visual* v = largestFromAbove(*node, true, true, true);
    if (!v) throw ValidationError("scene object '" + name + "' has no visual; the camera cannot see it");
    cat.objects.push_back({node->name, v->color, v->shape});
    used.insert(v);
  }
  std::set<const Visual*> robot_visuals;
  if (!robot_root.empty()) {
    if (!scene.findNode(robot_root)) throw ValidationError("robot root '" + robot_root + "' names no node of the scene");
    addRobotParts(scene, world, robot_root, cat.robot);
    addRobotLooks(scene, world, robot_root, cat.robot, used);
    std::set<std::string> robot_nodes = {robot_root};
    for (const SceneNode& node : scene.nodes) {
      if (node.name != robot_root && !robot_nodes.count(node.parent)) continue;
      robot_nodes.insert(node.name);
      for (const Visual& v : node.visuals) robot_visuals.insert(&v);
    }
  }
  for (const SceneNode& node : scene.nodes) {
    for (const Visual& v : node.visuals) {
      if (used.count(&v)) continue;
      cat.other_colors.push_back(v.color);
      if (robot_visuals.count(&v)) cat.robot_part_colors.push_back(v.color);
    }
  }
  return cat;
}

std::string checkDistinguishable(const PerceptionCatalogue& catalogue) {
  constexpr double kSizeTolerance = 0.15;
  const auto& objs = catalogue.objects;
  for (std::size_t i = 0; i < objs.size(); ++i) {
    for (std::size_t j = i + 1; j < objs.size(); ++j) {
      const ObjectAppearance &a = objs[i], &b = objs[j];
      if (!sameColourClass(a.color, b.color) || a.shape.type != b.shape.type) continue;
      bool alike = false;
      switch (a.shape.type) {
        case Shape::Type::Box:
          alike = within(a.footprint().x(), b.footprint().x(), kSizeTolerance) &&
                  within(a.footprint().y(), b.footprint().y(), kSizeTolerance) &&
                  within(a.height(), b.height(), kSizeTolerance);
          break;
        case Shape::Type::Cylinder:
          alike = within(a.shape.radius, b.shape.radius, kSizeTolerance) &&
                  within(a.shape.length, b.shape.length, kSizeTolerance);
          break;
        case Shape::Type::Sphere: alike = within(a.shape.radius, b.shape.radius, kSizeTolerance); break;
      }
      if (!alike) continue;
      const std::string colour = describeColor(a.color) +
                                 (describeColor(a.color) == describeColor(b.color) ? "" : " and " + describeColor(b.color));
      const std::string sizes = describeShape(a.shape) == describeShape(b.shape)
                                    ? describeShape(a.shape)
                                    : describeShape(a.shape) + " and " + describeShape(b.shape);
      return "objects '" + a.name + "' and '" + b.name + "' look alike (same colour " + colour + ", both " +
             shapeWord(a.shape.type, true) + " of " + sizes + ", sizes within " +
             describeNumber(100 * kSizeTolerance) +
             " %): the camera cannot tell them apart; give one another colour, shape or size";
    }
  }
  return "";
}

// ---- extractor --------------------------------------------------------------------------------------

namespace {

void checkCameraAndOptions(const CameraModel& camera, const PerceptionOptions& options) {
  if (camera.width <= 0 || camera.height <= 0) {
    throw ValidationError("camera '" + camera.name + "' has size " + std::to_string(camera.width) + " x " +
                          std::to_string(camera.height) + "; width and height must be positive");
  }
  requirePositive("camera.fx", camera.fx);
  requirePositive("camera.fy", camera.fy);
  requireFinite("camera.cx", camera.cx);
  requireFinite("camera.cy", camera.cy);
  requireInRange("options.max_downward_tilt", options.max_downward_tilt, 0, M_PI / 2);
  requireInRange("options.min_brightness", options.min_brightness, 0, 765);
  requireInRange("options.max_chroma_tolerance", options.max_chroma_tolerance, 0.005, 0.5);
  requireInRange("options.min_blob_pixels", options.min_blob_pixels, 1, 1e9);
  requireInRange("options.top_face_brightness", options.top_face_brightness, 0.5, 1.5);
  requireInRange("options.min_top_fraction", options.min_top_fraction, 0, 1);
  if (options.morphology_kernel < 1 || options.morphology_kernel % 2 == 0 || options.morphology_kernel > 15) {
    throw ValidationError("options.morphology_kernel is " + std::to_string(options.morphology_kernel) +
                          "; it must be an odd number from 1 to 15");
  }
}

void checkCatalogue(const PerceptionCatalogue& catalogue) {
  std::set<std::string> names;
  requireMaxSize("catalogue.objects", catalogue.objects.size(), 250);  // class labels are 8-bit
  for (const auto& o : catalogue.objects) {
    requireIdentifier("catalogue object name", o.name);
    if (!names.insert(o.name).second) {
      throw ValidationError("catalogue object '" + o.name + "' appears twice; names must be unique");
    }
    const std::string what = "size of catalogue object '" + o.name + "'";
    if (o.shape.type == Shape::Type::Box) {
      for (int i = 0; i < 3; ++i) requirePositive(what, o.shape.box_size[i]);
    } else {
      requirePositive(what, o.shape.radius);
      if (o.shape.type == Shape::Type::Cylinder) requirePositive(what, o.shape.length);
    }
  }
  throwIfInvalid(checkDistinguishable(catalogue));
  const RobotAppearance& r = catalogue.robot;
  if (r.present) {
    requirePositive("robot.body_radius", r.body_radius);
    requirePositive("robot.body_area", r.body_area);
    requireFinite("robot.body_top", r.body_top);
  }
}

// A colour in view with a name for error messages. shade_lo/hi: the pixel brightness range its faces can take
// under the renderer's light (any orientation).
struct KnownColour {
  std::string name;
  Rgba color;
  float shade_lo = 0, shade_hi = 765;
};

// Every colour in view: the first @p looked_for are the ones looked for (the objects', the robot's body and
// marker), then the scene's other visuals' and the background's.
// With a background model the floor, the walls and the renderer's background are subtracted: only what moves in
// the foreground competes, the objects and (unless a fiducial finds the robot and its silhouette is cut out) the
// robot's visuals.
std::vector<KnownColour> knownColours(const PerceptionCatalogue& catalogue, bool background, std::size_t& looked_for) {
  const RenderOptions render;
  auto shades = [&](const Rgba& c) {
    const double sum = 255.0 * (static_cast<double>(c.r) + c.g + c.b);
    // Margins for sensor noise and the renderer's rounding.
    return std::make_pair(static_cast<float>(std::max(0.0, 0.9 * sum * render.ambient - 6)),
                          static_cast<float>(std::min(765.0, 1.04 * sum * (render.ambient + render.diffuse) + 6)));
  };
  std::vector<KnownColour> known;
  auto addKnown = [&](const std::string& name, const Rgba& c) {
    const auto range = shades(c);
    known.push_back({name, c, range.first, range.second});
  };
  for (const auto& o : catalogue.objects) addKnown("object '" + o.name + "'", o.color);
  const RobotAppearance& r = catalogue.robot;
  const bool by_fiducial = r.fiducial.dictionary >= 0;
  if (r.present && !by_fiducial) {
    addKnown("the robot's body", r.body_color);
    if (r.marker_size.minCoeff() > 0) addKnown("the robot's marker", r.marker_color);
  }
  looked_for = known.size();
  if (background) {
    if (r.present && !by_fiducial) {
      for (const Rgba& c : catalogue.robot_part_colors) addKnown("another visual of the robot", c);
    }
    return known;
  }
  for (const Rgba& c : catalogue.other_colors) addKnown("another visual of the scene", c);
  const cv::Vec3b bg = render.background_bgr;
  const float bg_sum = static_cast<float>(bg[0] + bg[1] + bg[2]);
  known.push_back({"the background", Rgba{bg[2] / 255.0f, bg[1] / 255.0f, bg[0] / 255.0f, 1}, bg_sum - 6, bg_sum + 6});
  return known;
}

bool robotColour(const KnownColour& c) {
  return c.name.rfind("the robot", 0) == 0 || c.name.rfind("another visual of the robot", 0) == 0;
}

// Colours of the same class (same-coloured objects, the first @p objects of @p known) share the label and do not
// bound each other.
bool sharesClass(const std::vector<KnownColour>& known, std::size_t objects, std::size_t i, std::size_t j) {
  return j < objects && i < objects && sameColourClass(known[i].color, known[j].color);
}

// known[i]'s chromaticity box: half as wide as its distance to the nearest other colour, at most
// max_chroma_tolerance. A colour too close to another in chromaticity is told apart by brightness as well.
// @throws ValidationError when it cannot be told apart from another colour either way
FeatureExtractor::ColorClass colourClassOf(const std::vector<KnownColour>& known, std::size_t i, std::size_t objects,
                                           double max_chroma_tolerance) {
  constexpr float kMinTolerance = 0.01f;
  const cv::Vec3f ci = chromaOf(known[i].color);
  float nearest = std::numeric_limits<float>::max();
  for (std::size_t j = 0; j < known.size(); ++j) {
    if (j == i || sharesClass(known, objects, i, j)) continue;
    nearest = std::min(nearest, chebyshev(ci, chromaOf(known[j].color)));
  }
  FeatureExtractor::ColorClass cls;
  cls.chroma = ci;
  cls.tolerance = std::min(static_cast<float>(max_chroma_tolerance), nearest / 2);
  if (cls.tolerance >= kMinTolerance) return cls;
  // Too close in chromaticity (a grey object on a grey floor): tell them apart by brightness as well, if
  // none of the close colours can take any of this colour's shades.
  cls.min_brightness = known[i].shade_lo;
  cls.max_brightness = known[i].shade_hi;
  float rest = std::numeric_limits<float>::max();
  for (std::size_t j = 0; j < known.size(); ++j) {
    if (j == i || sharesClass(known, objects, i, j)) continue;
    const float d = chebyshev(ci, chromaOf(known[j].color));
    if (d >= 4 * kMinTolerance) {
      rest = std::min(rest, d);
      continue;
    }
    if (known[j].shade_hi >= cls.min_brightness && known[j].shade_lo <= cls.max_brightness) {
      throw ValidationError(
          "the colour of " + known[i].name + " " + describeColor(known[i].color) + " is too close to that of " +
          known[j].name + " " + describeColor(known[j].color) +
          " to tell them apart: their chromaticities differ by " + describeNumber(d) +
          " and their shades overlap in brightness (" + describeNumber(cls.min_brightness) + "-" +
          describeNumber(cls.max_brightness) + " against " + describeNumber(known[j].shade_lo) + "-" +
          describeNumber(known[j].shade_hi) + " of 765); give it another colour, or a clearly darker or lighter one" +
          (robotColour(known[i]) || robotColour(known[j])
               ? ", or give the robot an ArUco fiducial (robot.fiducial in the world file) to be found by instead"
               : ""));
    }
  }
  cls.tolerance = std::min(static_cast<float>(max_chroma_tolerance), rest / 2);
  return cls;
}

}  // namespace

FeatureExtractor::FeatureExtractor(PerceptionCatalogue catalogue, CameraModel camera, PerceptionOptions options,
                                   std::shared_ptr<const BackgroundModel> background)
    : catalogue_(std::move(catalogue)), camera_(std::move(camera)), options_(options), background_(std::move(background)) {
  checkCameraAndOptions(camera_, options_);
  checkCatalogue(catalogue_);
  if (catalogue_.robot.present && catalogue_.robot.fiducial.dictionary >= 0) {
    tracker_ = std::make_shared<const RobotTracker>(catalogue_.robot, camera_);
  }
  std::size_t looked_for = 0;
  const std::vector<KnownColour> known = knownColours(catalogue_, background_ != nullptr, looked_for);
  const std::size_t objects = catalogue_.objects.size();
  for (std::size_t i = 0; i < looked_for; ++i) {
    ColorClass cls = colourClassOf(known, i, objects, options_.max_chroma_tolerance);
    cls.name = i < objects ? catalogue_.objects[i].name
               : (i == objects ? std::string("robot_body") : std::string("robot_marker"));
    classes_.push_back(cls);
    // One pixel label per colour class: same-coloured objects share the first one's.
    int label = 0;
    for (std::size_t j = 0; j < i && !label; ++j) {
      if (sharesClass(known, objects, i, j)) label = label_of_[j];
    }
    if (!label) {
      labels_.push_back(cls);
      label = static_cast<int>(labels_.size());
    } else {
      ColorClass& shared = labels_[label - 1];  // every member's shades, within the tightest chromaticity box
      shared.tolerance = std::min(shared.tolerance, cls.tolerance);
      shared.min_brightness = std::min(shared.min_brightness, cls.min_brightness);
      shared.max_brightness = std::max(shared.max_brightness, cls.max_brightness);
    }
    label_of_.push_back(label);
  }
}

bool isDownwardCamera(const Eigen::Isometry3d& world_from_camera, double max_tilt) {
  const Eigen::Vector3d axis = world_from_camera.linear().col(2).normalized();
  return std::acos(std::clamp(-axis.z(), -1.0, 1.0)) <= max_tilt;
}

bool FeatureExtractor::isDownward(const Eigen::Isometry3d& world_from_camera) const {
  return isDownwardCamera(world_from_camera, options_.max_downward_tilt);
}

Detections FeatureExtractor::extract(const cv::Mat& bgr, const Eigen::Isometry3d& world_from_camera) const {
  checkImage(bgr, camera_);
  throwIfInvalid(checkPose(world_from_camera));

  Detections out;
  out.world_from_camera = world_from_camera;
  out.downward = isDownward(world_from_camera);
  const Pinhole cam(camera_, world_from_camera);
  cv::Mat background;
  if (background_) {
    background = background_->imageFor(camera_, world_from_camera);
    if (background.size() != bgr.size() || background.type() != bgr.type()) {
      throw ValidationError("the background model's image for camera '" + camera_.name + "' is " +
                            std::to_string(background.cols) + " x " + std::to_string(background.rows) +
                            "; the camera gives " + std::to_string(bgr.cols) + " x " + std::to_string(bgr.rows));
    }
  }
  LabelledImage image = labelPixels(bgr, labels_, options_.min_brightness, background,
                                    static_cast<int>(std::ceil(options_.background_difference)));
  if (tracker_ && out.downward) {
    // Found by its fiducial; its silhouette is cut out so no part of it is taken for an object.
    out.robot = tracker_->find(bgr, world_from_camera);
    if (out.robot.found) {
      image.label.setTo(0, tracker_->silhouette(out.robot, world_from_camera, options_.robot_margin_pixels));
    }
  }
  const cv::Mat kernel = options_.morphology_kernel > 1
                             ? cv::getStructuringElement(cv::MORPH_ELLIPSE,
                                                         {options_.morphology_kernel, options_.morphology_kernel})
                             : cv::Mat();
  const Extraction extraction{catalogue_, camera_, options_, label_of_, classes_, cam, image, kernel, bgr.size(), out};
  extraction.findObjects();
  if (!tracker_) extraction.findRobot();
  return out;
}

}  // namespace xpersif::core
