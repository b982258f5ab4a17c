// telesim_view: the paper's TeleSimView client. It fetches the scene once, subscribes to /tf, and
// renders every frame itself from a chosen camera, so watching costs the simulator only tf messages.
// Headless it writes images (and optionally a video) plus inter-frame statistics; with ~display it
// shows a window. ~xpersim names the simulator to watch [/xpersif/xpersim, the main job's].
#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <ros/names.h>
#include <ros/ros.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <vector>

#include "xpersif/core/render/renderer.h"
#include "xpersif/ros/scene_tracker.h"

namespace {

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1, static_cast<std::size_t>(p * (values.size() - 1) + 0.5))];
}

double mean(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return values.empty() ? 0 : sum / values.size();
}

/// What the viewer is asked to do (its private parameters).
struct Options {
  std::string camera_name = xpersif::core::kFixedCamera, xpersim = "/xpersif/xpersim", service, output_dir, video_path;
  double max_fps = 30, duration = 0;
  int save_every = 0;
  bool display = false;
};

Options readOptions(const ros::NodeHandle& pnh) {
  // The scene comes from ~get_scene, by default ~xpersim's get_scene: the main job's XPERSim (/xpersif/xpersim);
  // _xpersim:=/xpersim for the bare simulator of launch/xpersim.launch.
  Options o;
  pnh.param("camera", o.camera_name, o.camera_name);
  pnh.param("xpersim", o.xpersim, o.xpersim);
  pnh.param("get_scene", o.service, ros::names::append(o.xpersim, "get_scene"));
  pnh.param("output_dir", o.output_dir, o.output_dir);
  pnh.param("video", o.video_path, o.video_path);
  pnh.param("max_fps", o.max_fps, o.max_fps);
  pnh.param("duration", o.duration, o.duration);
  pnh.param("save_every", o.save_every, o.save_every);
  pnh.param("display", o.display, o.display);
  return o;
}

/// Inter-frame statistics of the tf stream, measured at receipt (the paper's Table I metric).
class FrameStats {
 public:
  /// A tf frame arrived (the tracker's callback thread).
  void onFrame() {
    const ros::WallTime now = ros::WallTime::now();
    std::lock_guard<std::mutex> lock(mutex_);
    if (!last_frame_.isZero()) inter_frame_ms_.push_back((now - last_frame_).toSec() * 1e3);
    last_frame_ = now;
    ++frames_;
  }
  std::uint64_t frames() const { return frames_; }
  std::vector<double> intervals() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return inter_frame_ms_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<double> inter_frame_ms_;
  ros::WallTime last_frame_;
  std::atomic<std::uint64_t> frames_{0};
};

/// What the render loop did.
struct RenderStats {
  std::vector<double> render_ms;
  std::uint64_t rendered = 0;
};

/// Render the camera's view whenever a new tf frame came, at most ~max_fps times a second, for ~duration s (0:
/// until shut down); each image goes to the video, every ~save_every-th (and the first) to ~output_dir, and to
/// the window. Returns the last image.
cv::Mat renderLoop(const Options& options, const xpersif::SceneTracker& tracker, xpersif::core::Renderer& renderer,
                   const xpersif::core::CameraModel& camera, const FrameStats& stats, cv::VideoWriter& video,
                   RenderStats& out) {
  cv::Mat image;
  std::uint64_t last_rendered_frame = 0;
  const ros::WallTime start = ros::WallTime::now();
  ros::WallRate rate(options.max_fps);
  while (ros::ok() && (options.duration <= 0 || (ros::WallTime::now() - start).toSec() < options.duration)) {
    rate.sleep();
    const std::uint64_t frame = stats.frames();
    if (frame == last_rendered_frame) continue;  // nothing moved
    last_rendered_frame = frame;
    const auto world = tracker.worldTransforms();
    const ros::WallTime t0 = ros::WallTime::now();
    renderer.render(camera, world.at(camera.frame), world, image);
    out.render_ms.push_back((ros::WallTime::now() - t0).toSec() * 1e3);
    ++out.rendered;
    if (video.isOpened()) video.write(image);
    const bool save = out.rendered == 1 || (options.save_every > 0 && out.rendered % options.save_every == 0);
    if (!options.output_dir.empty() && save) {
      char name[64];
      std::snprintf(name, sizeof name, "/%s_%06lu.png", options.camera_name.c_str(),
                    static_cast<unsigned long>(out.rendered));
      cv::imwrite(options.output_dir + name, image);
    }
    if (options.display) {
      cv::imshow("TeleSimView: " + options.camera_name, image);
      cv::waitKey(1);
    }
  }
  return image;
}

/// The summary line on stdout and, with ~output_dir, the inter-frame times as CSV.
void report(const Options& options, const FrameStats& stats, const RenderStats& rendered) {
  const std::vector<double> intervals = stats.intervals();
  std::printf("telesim_view: camera %s, %lu tf frames, inter-frame mean %.3f ms p50 %.3f p99 %.3f max %.3f; "
              "%lu images rendered, render mean %.2f ms p99 %.2f\n",
              options.camera_name.c_str(), static_cast<unsigned long>(stats.frames()), mean(intervals),
              percentile(intervals, 0.5), percentile(intervals, 0.99),
              intervals.empty() ? 0.0 : *std::max_element(intervals.begin(), intervals.end()),
              static_cast<unsigned long>(rendered.rendered), mean(rendered.render_ms),
              percentile(rendered.render_ms, 0.99));
  if (!options.output_dir.empty()) {
    std::ofstream csv(options.output_dir + "/telesim_view_inter_frame_ms.csv");
    csv << "inter_frame_ms\n";
    for (double v : intervals) csv << v << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "telesim_view", ros::init_options::AnonymousName);
  ros::NodeHandle nh, pnh("~");
  Options options = readOptions(pnh);
  if (!(options.max_fps > 0 && options.max_fps <= 1000)) {
    ROS_FATAL("~max_fps must lie in (0, 1000]");
    return 2;
  }

  std::unique_ptr<xpersif::SceneTracker> tracker;
  try {
    tracker = std::make_unique<xpersif::SceneTracker>(nh);
    tracker->fetch(options.service, 30.0);  // the paper's two-way invocation that fetches the scene
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("telesim_view: " << e.what());
    return 1;
  }
  const xpersif::core::SceneDescription scene = tracker->scene();
  std::string problem;
  const xpersif::core::CameraModel* camera = xpersif::core::chooseCamera(scene, options.camera_name, problem);
  if (!camera) {
    ROS_FATAL_STREAM("telesim_view: " << problem);
    return 1;
  }
  options.camera_name = camera->name;  // the files it writes carry the camera's own name
  xpersif::core::Renderer renderer(scene);
  FrameStats stats;
  tracker->onFrame([&stats] { stats.onFrame(); });

  cv::VideoWriter video;
  if (!options.video_path.empty()) {
    video.open(options.video_path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), options.max_fps,
               cv::Size(camera->width, camera->height));
    if (!video.isOpened()) {
      ROS_WARN_STREAM("telesim_view: cannot write video " << options.video_path << "; images only");
    }
  }

  ros::AsyncSpinner spinner(1);
  spinner.start();
  RenderStats rendered;
  const cv::Mat image = renderLoop(options, *tracker, renderer, *camera, stats, video, rendered);
  if (!options.output_dir.empty() && !image.empty()) {
    cv::imwrite(options.output_dir + "/" + options.camera_name + "_last.png", image);
  }
  report(options, stats, rendered);
  return 0;
}
