/**
 * @file feature_extractor.h
 * @brief FEATUREEXTRACTION, ROS-free: finds the known objects and the robot in a camera image and measures
 *        their world poses from the image alone (OpenCV segmentation + the pinhole model), never from the
 *        simulator's ground truth.
 *
 * What to look for comes from a PerceptionCatalogue (objects: name, colour, shape; the robot: body colour and
 * shape, heading-marker colour and offset), normally built from XPERSim's scene description and its roles.
 * Identity is by colour and then by what the camera sees: pixels are labelled by colour class (one per distinct
 * colour, shared by same-coloured objects); every blob of a class is measured and the blobs are assigned to
 * that colour's objects by best shape and size match (with one object per colour: its largest blob). Blobs of
 * colours not in the catalogue are ignored. Objects the camera cannot tell apart are refused
 * (checkDistinguishable()). A grey object (chromaticity near the floor's, walls' or background's) is labelled
 * by chromaticity and brightness together when its possible shades cannot be confused with theirs.
 *
 * Segmentation works on chromaticity (r, g, b) / (r + g + b): XPERSim's renderer shades a face by scaling its
 * base colour (renderer.h), so every face of one object has the same chromaticity whatever its shade. Each
 * catalogue colour gets a box in chromaticity space half as wide as its distance to the nearest other known
 * colour (other catalogue colours, the scene's other visuals such as floor and walls, the grey background).
 *
 * Two measuring methods, chosen per image from the camera pose:
 *  - Downward camera (optical axis within PerceptionOptions::max_downward_tilt of straight down), e.g. the
 *    overhead camera: the brightest shade of a cube's blob is its top face (the light comes mostly from above);
 *    its four edges are fitted (cv::fitLine on the contour sides, corners intersected), the corners are
 *    back-projected onto the plane z = box height, and the centre is the top centre minus half the height.
 *    Yaw is reported modulo the box's symmetry (pi/2 for a square top), folded into (-period/2, period/2].
 *    A cylinder: the centroid of its top disc (brightest shade) back-projected onto z = length. A sphere: the
 *    centroid of its silhouette back-projected onto z = radius (the outline of a sphere is centred on its
 *    centre's image to second order in radius / distance: ~0.1 mm here). Rotationally symmetric shapes report
 *    yaw = 0, yaw_period = 2 pi and yaw_known = false.
 *    The robot: centre of its body's top face, heading from the marker relative to it.
 *  - Forward camera (e.g. the robot camera): ground contact. Nothing of a box shows below its near bottom
 *    edges, so the lowest blob pixel of each image column, back-projected onto the floor (z = 0), lies on them:
 *    these points trace one edge (a face turned to the camera: centre = edge midpoint + half the size away from
 *    the camera) or two meeting at the nearest corner (centre = corner + half the size along both edges). Too
 *    short an outline falls back to the lowest point plus half the size along the viewing ray. A cylinder: its
 *    nearest contact point plus its radius along the viewing ray. A sphere touches the floor out of sight: the
 *    ray through its silhouette's centroid meets the plane z = radius. A blob cut by the
 *    bottom image border hides its contact and is reported missing. Orientation is reported unknown there
 *    (yaw_known = false: a few pixels of edge are too coarse); the robot is not looked for.
 *
 * Image conventions are the renderer's: continuous image point (u, v) = (fx x/z + cx, fy y/z + cy), and pixel
 * (column i, row j) has its centre at (i + 0.5, j + 0.5); OpenCV's cv:: geometry puts pixel centres at
 * integers, so contours (OpenCV pixel indices) are shifted by half a pixel before back-projection.
 * Objects are assumed to rest on the floor (z = 0) upright, as XPERSim's objects do.
 *
 * Thread safety: FeatureExtractor::extract() is const and keeps no state; several threads may share one.
 */
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "xpersif/core/common/scene.h"

namespace xpersif::core {

/// A thing to look for: a box, an upright cylinder (axis along z) or a sphere of one colour, resting on the floor.
struct ObjectAppearance {
  std::string name;  ///< e.g. "red_cube" (the scene node's name)
  Rgba color;        ///< base colour (alpha ignored)
  Shape shape;       ///< its one visual's shape (box size, or radius and length)

  /// Height of its top above the floor, m (box: size z; cylinder: length; sphere: diameter).
  double height() const;
  /// Horizontal extents seen from above, long side first, m (a disc's are its diameter twice).
  Eigen::Vector2d footprint() const;
  /// True for shapes that look the same at every yaw (cylinder, sphere).
  bool rotationallySymmetric() const { return shape.type != Shape::Type::Box; }
};

/// How the robot looks from above: a body (cylinder or box) and a small visual marking its heading.
struct RobotAppearance {
  bool present = false;           ///< false: no robot is looked for
  std::string name;               ///< the root link (SceneDescription::robot_root)
  Rgba body_color;
  Shape body_shape;               ///< the body visual's shape (a cylinder or a box, upright)
  double body_radius = 0.035;     ///< reach of the body's footprint from its centre (box: half diagonal), m
  double body_area = M_PI * 0.035 * 0.035;  ///< the body's footprint seen from above, m^2
  double body_top = 0.033;        ///< height of the body's top face above the floor, m
  Rgba marker_color;
  Eigen::Vector3d marker_offset{0.03, 0, 0.018};  ///< marker centre in the root link's frame, m
  Eigen::Vector3d marker_size{0.006, 0.01, 0.006};  ///< marker's bounding box; zero when there is no marker
  double marker_top = 0.039;      ///< height of the marker's top above the floor, m
  /// An ArUco fiducial on its top (SceneFiducial). With one, the robot is found by it alone: its body and marker
  /// colours are not looked for, and its silhouette is cut out of the image before the objects are looked for.
  struct Fiducial {
    int dictionary = -1;  ///< cv::aruco::PREDEFINED_DICTIONARY_NAME; -1 = none
    int id = 0;
    double size = 0;      ///< the black square's side, m
    Eigen::Isometry3d root_from_marker = Eigen::Isometry3d::Identity();  ///< the marker's top centre
  } fiducial;
  double root_height = 0;         ///< height of the root link's origin above the floor, m
  /// Every visual of the robot (its links at zero joint angles, the fiducial) in the root link's frame: the
  /// silhouette cut out of the image once the robot is found.
  std::vector<Visual> parts;
};

/// What to look for.
struct PerceptionCatalogue {
  std::vector<ObjectAppearance> objects;
  RobotAppearance robot;
  /// Colours of everything else in view (floor, walls, wheels...): never reported, but they bound how loose
  /// each catalogue colour's threshold may be. The renderer's grey background is always added by the extractor.
  std::vector<Rgba> other_colors;
  /// The robot's visuals' colours besides its body and marker (wheels, housings): with a background model and no
  /// fiducial these move in the foreground beside the objects, so the objects' colours are told apart from them.
  std::vector<Rgba> robot_part_colors;

  /**
   * @brief From XPERSim's scene and its roles: the objects are the nodes named in scene.objects (each with one
   *        visual: box, upright cylinder or sphere); the robot is @p robot_root (default scene.robot_root, none
   *        when empty): its body is the root's visual with the largest footprint seen from above (cylinder or
   *        box), its heading marker scene.robot_marker's visual (none when empty: the heading stays unknown).
   *        All other visuals' colours go to other_colors.
   * @throws ValidationError if an object or the marker names no node or a node without a visual, or the robot
   *         root has no cylinder or box visual
   */
  static PerceptionCatalogue fromScene(const SceneDescription& scene, const std::string& robot_root = "");

  /// The object called @p name, or nullptr.
  const ObjectAppearance* find(const std::string& name) const;
};

/**
 * @brief Whether the camera can tell every pair of catalogue objects apart: two objects look alike when they
 *        have the same colour class (chromaticities within 0.01 on every channel: they share one pixel label,
 *        whatever their brightness), the same shape and sizes within 15 % (box: footprint extents and height;
 *        cylinder: radius and length; sphere: radius).
 * @return "" when all can be told apart, else a sentence naming both objects of the first look-alike pair
 */
std::string checkDistinguishable(const PerceptionCatalogue& catalogue);

struct PerceptionOptions {
  /// A camera whose optical axis is within this angle of straight down uses the top-face method, else the
  /// ground-contact method (rad).
  double max_downward_tilt = M_PI / 4;
  /// Pixels darker than this (r + g + b, 0..765) are not classified (chromaticity is noise there).
  double min_brightness = 45;
  /// Upper bound on a colour's chromaticity half-width (its box is also at most half the distance to the
  /// nearest other known colour).
  double max_chroma_tolerance = 0.06;
  /// Blobs smaller than this many pixels are ignored (noise, slivers).
  double min_blob_pixels = 6;
  /// A top face is the part of a blob at least this fraction as bright as the blob's 90th-percentile
  /// brightness (robust to noise). XPERSim's light makes a top face 0.95 of its base colour and sides at most
  /// 0.69, so the default sits between them with room for noise.
  double top_face_brightness = 0.83;
  /// Downward camera: a detection whose top face covers less than this fraction of the expected area is
  /// treated as occluded and reported missing rather than guessed.
  double min_top_fraction = 0.5;
  /// Morphological opening kernel (pixels, odd; 1 = none) applied to each colour mask.
  int morphology_kernel = 1;
  /// With a background model: a pixel is foreground when |b - b0| + |g - g0| + |r - r0| against the empty
  /// arena's pixel reaches this (0..765). Everything else (floor, walls) is never looked at.
  double background_difference = 24;
  /// Pixels added around the robot's silhouette when it is cut out (for the error of its measured pose).
  int robot_margin_pixels = 2;
};

/**
 * @brief What a camera sees of the empty arena: the background that FEATUREEXTRACTION subtracts, so that an
 *        object is found by differing from what lies behind it, whatever its colour. A real set-up learns it
 *        from frames of the empty arena; XPERSim knows its scene and renders it (RenderedBackground).
 */
class BackgroundModel {
 public:
  virtual ~BackgroundModel() = default;
  /// The empty arena as @p camera sees it from @p world_from_camera (CV_8UC3, camera.height x camera.width).
  virtual cv::Mat imageFor(const CameraModel& camera, const Eigen::Isometry3d& world_from_camera) const = 0;
};

/// One object found in the image.
struct ObjectDetection {
  std::string name;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< box centre in the world, m
  double yaw = 0;                 ///< rad, folded into (-yaw_period/2, yaw_period/2]; valid if yaw_known
  /// The shape's symmetry: pi/2 for a square top, pi for a rectangle, 2 pi for a cylinder or sphere (yaw 0).
  double yaw_period = M_PI / 2;
  bool yaw_known = true;          ///< false with the ground-contact method and for cylinders and spheres
  cv::Point2d centroid;           ///< blob centroid, renderer convention (pixel centres at i + 0.5)
  double pixel_area = 0;          ///< pixels in the blob (all visible faces)
  double confidence = 0;          ///< 0..1: how well the measured top (or blob) matches the expected size
  std::vector<cv::Point> contour;      ///< the blob's outer contour, OpenCV pixel indices
  std::vector<cv::Point> top_contour;  ///< the top face's outer contour (downward camera; else empty)
  /// The top face's corners back-projected to z = box height, in order around the face (downward camera;
  /// else empty). Their edges give the measured size.
  std::vector<Eigen::Vector3d> top_corners;
  /// Downward camera: the top face's mean edge lengths in m, long side first (a cylinder's top disc or a
  /// sphere's silhouette: its equivalent diameter, twice). Forward camera: the blob's horizontal (length) and
  /// vertical (width, ~ the object's height) extent scaled to the contact point's depth.
  double measured_length = 0, measured_width = 0;
};

/// The robot found in the image (downward camera only).
struct RobotDetection {
  bool found = false;
  double x = 0, y = 0;        ///< body centre in the world, m
  double yaw = 0;             ///< heading, rad in (-pi, pi]; valid if yaw_known
  bool yaw_known = false;     ///< false when the marker was not seen
  cv::Point2d centroid;       ///< body centroid in the image, renderer convention
  double pixel_area = 0;
  double confidence = 0;
  std::vector<cv::Point> contour;
};

struct Detections {
  std::map<std::string, ObjectDetection> objects;  ///< by catalogue name; only what was seen
  std::vector<std::string> missing;                ///< catalogue objects not found, in catalogue order
  RobotDetection robot;
  bool downward = true;                            ///< which method was used
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
};

/// FEATUREEXTRACTION for one camera.
class FeatureExtractor {
 public:
  /**
   * @throws ValidationError for an unusable camera (non-positive size or focal length, non-finite centre),
   *         a catalogue object with a non-positive size, two objects the camera cannot tell apart
   *         (checkDistinguishable()), a colour too close to another known colour in both chromaticity and
   *         possible brightness to tell apart (the sentence names both), or bad options
   */
  FeatureExtractor(PerceptionCatalogue catalogue, CameraModel camera,
                   PerceptionOptions options = PerceptionOptions(),
                   std::shared_ptr<const BackgroundModel> background = nullptr);

  /**
   * @brief Finds the catalogue's objects (and, with a downward camera, the robot) in @p bgr.
   * @param bgr CV_8UC3 image of camera().height rows x camera().width columns
   * @param world_from_camera pose of the camera's optical frame in the world
   * @throws ValidationError for an empty image, a wrong type or size, or a non-finite or non-rigid pose
   */
  Detections extract(const cv::Mat& bgr, const Eigen::Isometry3d& world_from_camera) const;

  /// True when extract() would use the top-face method for this camera pose.
  bool isDownward(const Eigen::Isometry3d& world_from_camera) const;

  const PerceptionCatalogue& catalogue() const { return catalogue_; }
  const CameraModel& camera() const { return camera_; }
  const PerceptionOptions& options() const { return options_; }
  /// The background subtracted before looking for colours, or nullptr (colours alone, told from everything in view).
  const BackgroundModel* background() const { return background_.get(); }

  /// The chromaticity box used for each catalogue object (by name), for diagnostics: centre and half-width.
  /// Objects of one colour have equal boxes and share one pixel label.
  struct ColorClass {
    std::string name;
    cv::Vec3f chroma;     ///< (b, g, r) / (b + g + r), OpenCV channel order
    float tolerance = 0;  ///< half-width of the box on every channel
    /// Pixel brightness (b + g + r, 0..765) accepted; narrower than 0..765 only for a colour told apart from
    /// a similar chromaticity (a grey object on a grey floor) by its possible shades.
    float min_brightness = 0, max_brightness = 765;
  };
  const std::vector<ColorClass>& colorClasses() const { return classes_; }

 private:
  PerceptionCatalogue catalogue_;
  CameraModel camera_;
  PerceptionOptions options_;
  std::vector<ColorClass> classes_;  // objects in catalogue order, then robot body, then marker
  // Pixel labels: label_of_[k] is the label (1-based index into labels_) of classes_[k]; same-coloured objects
  // share one. labels_[l - 1] is the ColorClass that label l stands for.
  std::vector<int> label_of_;
  std::vector<ColorClass> labels_;
  std::shared_ptr<const BackgroundModel> background_;
  std::shared_ptr<const class RobotTracker> tracker_;  // with a fiducial: finds the robot and its silhouette
};

/// True when a camera at @p world_from_camera looks within @p max_tilt of straight down (the top-face method).
bool isDownwardCamera(const Eigen::Isometry3d& world_from_camera, double max_tilt);

/// @p yaw folded into (-period/2, period/2].
double foldAngle(double yaw, double period);

}  // namespace xpersif::core
