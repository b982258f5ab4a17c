#include "xpersif/perception/feature_extraction_part.h"

#include "xpersif/component/parameter_reader.h"

#include "xpersif/core/common/validation.h"
#include "xpersif/core/perception/background.h"

namespace xpersif {

namespace {
geometry_msgs::Point point(double x, double y, double z) {
  geometry_msgs::Point p;
  p.x = x;
  p.y = y;
  p.z = z;
  return p;
}
std::vector<std::int32_t> flatten(const std::vector<cv::Point>& contour) {
  std::vector<std::int32_t> flat;
  flat.reserve(2 * contour.size());
  for (const auto& p : contour) {
    flat.push_back(p.x);
    flat.push_back(p.y);
  }
  return flat;
}
std::vector<cv::Point> unflatten(const std::vector<std::int32_t>& flat) {
  std::vector<cv::Point> contour;
  for (std::size_t i = 0; i + 1 < flat.size(); i += 2) contour.emplace_back(flat[i], flat[i + 1]);
  return contour;
}
}  // namespace

cv::Mat viewOf(const sensor_msgs::Image& image) {
  if (image.encoding != "bgr8") {
    throw core::ValidationError("image encoding is '" + image.encoding + "'; feature extraction needs bgr8");
  }
  if (image.step < image.width * 3 || image.data.size() < static_cast<std::size_t>(image.step) * image.height) {
    throw core::ValidationError("image buffer of " + std::to_string(image.data.size()) + " bytes is too small for " +
                                std::to_string(image.width) + " x " + std::to_string(image.height) + " bgr8");
  }
  // Read-only use: the extractor takes a const cv::Mat.
  return cv::Mat(static_cast<int>(image.height), static_cast<int>(image.width), CV_8UC3,
                 const_cast<std::uint8_t*>(image.data.data()), image.step);
}

FeatureVector toFeatureVector(const core::Detections& detections, const std_msgs::Header& header,
                              const std::string& world_frame, const std::string& source) {
  FeatureVector out;
  out.header = header;
  out.header.frame_id = world_frame;
  out.source = source;
  for (const auto& [name, d] : detections.objects) {
    ObjectFeatures o;
    o.name = name;
    o.position = point(d.position.x(), d.position.y(), d.position.z());
    o.yaw = d.yaw;
    o.yaw_period = d.yaw_period;
    o.orientation_known = d.yaw_known;
    o.confidence = d.confidence;
    o.pixel_area = d.pixel_area;
    o.centroid_px = point(d.centroid.x, d.centroid.y, 0);
    o.measured_length = d.measured_length;
    o.measured_width = d.measured_width;
    for (const auto& c : d.top_corners) o.top_corners.push_back(point(c.x(), c.y(), c.z()));
    o.contour = flatten(d.contour);
    o.top_contour = flatten(d.top_contour);
    out.objects.push_back(std::move(o));
  }
  out.missing = detections.missing;
  out.robot_found = detections.robot.found && detections.robot.yaw_known;
  out.robot.x = detections.robot.x;
  out.robot.y = detections.robot.y;
  out.robot.theta = detections.robot.yaw;
  return out;
}

core::Detections fromFeatureVector(const FeatureVector& features) {
  core::Detections d;
  for (const auto& o : features.objects) {
    core::ObjectDetection od;
    od.name = o.name;
    od.position = Eigen::Vector3d(o.position.x, o.position.y, o.position.z);
    od.yaw = o.yaw;
    od.yaw_period = o.yaw_period;
    od.yaw_known = o.orientation_known;
    od.confidence = o.confidence;
    od.pixel_area = o.pixel_area;
    od.centroid = cv::Point2d(o.centroid_px.x, o.centroid_px.y);
    od.measured_length = o.measured_length;
    od.measured_width = o.measured_width;
    for (const auto& c : o.top_corners) od.top_corners.emplace_back(c.x, c.y, c.z);
    od.contour = unflatten(o.contour);
    od.top_contour = unflatten(o.top_contour);
    d.objects[o.name] = std::move(od);
  }
  d.missing = features.missing;
  d.robot.found = features.robot_found;
  d.robot.yaw_known = features.robot_found;
  d.robot.x = features.robot.x;
  d.robot.y = features.robot.y;
  d.robot.yaw = features.robot.theta;
  return d;
}

const core::ParameterTable& FeatureExtractionPart::parameters() {
  static const core::ParameterTable table = [] {
    const core::PerceptionOptions d;
    return core::ParameterTable(
        "feature extraction part",
        {core::numberParameter("min_blob_pixels", d.min_blob_pixels, 1e-6, 1e9,
                               "part feature_extraction: the smallest blob of an object's colour that counts"),
         core::numberParameter("max_chroma_tolerance", d.max_chroma_tolerance, 1e-3, 0.5,
                               "part feature_extraction: how far a pixel's chroma may be from an object's colour")});
  }();
  return table;
}

void FeatureExtractionPart::configure(const ros::NodeHandle& parameters) {
  const ParameterReader reader(parameters, FeatureExtractionPart::parameters(), "~" + name() + "/");
  core::PerceptionOptions options;
  options.min_blob_pixels = reader.get<double>("min_blob_pixels");
  options.max_chroma_tolerance = reader.get<double>("max_chroma_tolerance");
  std::lock_guard<std::mutex> lock(mutex_);
  options_ = options;
  extractor_.reset();
  problem_ = "waiting for the scene";
  refused_ = false;
}

void FeatureExtractionPart::shutdown() {
  std::lock_guard<std::mutex> lock(mutex_);
  extractor_.reset();
}

std::string FeatureExtractionPart::problem() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return problem_;
}

std::pair<std::uint8_t, std::string> FeatureExtractionPart::diagnose() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::uint8_t health = refused_            ? ComponentStatus::HEALTH_ERROR
                              : problem_.empty() ? ComponentStatus::HEALTH_OK
                                                 : ComponentStatus::HEALTH_WARN;
  return {health, problem_};
}

void FeatureExtractionPart::setCamera(const core::SceneDescription& scene, const core::CameraModel& camera) {
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    // The empty arena, rendered from the scene, is subtracted: objects of any colour stand out from it.
    extractor_ = std::make_shared<const core::FeatureExtractor>(core::PerceptionCatalogue::fromScene(scene), camera,
                                                                options_,
                                                                std::make_shared<core::RenderedBackground>(scene));
    world_frame_ = scene.world_frame;
    problem_.clear();
    refused_ = false;
  } catch (const std::exception& e) {
    extractor_.reset();
    problem_ = std::string("cannot extract features from camera '") + camera.name + "': " + e.what();
    refused_ = true;
  }
}

bool FeatureExtractionPart::ready() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return extractor_ != nullptr;
}

FeatureVector FeatureExtractionPart::extract(const sensor_msgs::Image& image, const Eigen::Isometry3d& world_from_camera,
                                             const std::string& source) const {
  std::shared_ptr<const core::FeatureExtractor> extractor;
  std::string world_frame;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    extractor = extractor_;
    world_frame = world_frame_;
  }
  if (!extractor) throw std::runtime_error("feature extraction is not ready: " + problem());
  const core::Detections detections = extractor->extract(viewOf(image), world_from_camera);
  ++processed_;
  return toFeatureVector(detections, image.header, world_frame, source);
}

}  // namespace xpersif
