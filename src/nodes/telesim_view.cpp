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

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "telesim_view", ros::init_options::AnonymousName);
  ros::NodeHandle nh, pnh("~");
  // The scene comes from ~get_scene, by default ~xpersim's get_scene: the main job's XPERSim (/xpersif/xpersim);
  // _xpersim:=/xpersim for the bare simulator of launch/xpersim.launch.
  std::string camera_name = "overhead", xpersim = "/xpersif/xpersim", service, output_dir, video_path;
  double max_fps = 30, duration = 0;
  int save_every = 0;
  bool display = false;
  pnh.param("camera", camera_name, camera_name);
  pnh.param("xpersim", xpersim, xpersim);
  pnh.param("get_scene", service, ros::names::append(xpersim, "get_scene"));
  pnh.param("output_dir", output_dir, output_dir);
  pnh.param("video", video_path, video_path);
  pnh.param("max_fps", max_fps, max_fps);
  pnh.param("duration", duration, duration);
  pnh.param("save_every", save_every, save_every);
  pnh.param("display", display, display);
  if (!(max_fps > 0 && max_fps <= 1000)) {
    ROS_FATAL("~max_fps must lie in (0, 1000]");
    return 2;
  }

  std::unique_ptr<xpersif::SceneTracker> tracker;
  try {
    tracker = std::make_unique<xpersif::SceneTracker>(nh);
    tracker->fetch(service, 30.0);  // the paper's two-way invocation that fetches the scene
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("telesim_view: " << e.what());
    return 1;
  }
  const xpersif::core::SceneDescription scene = tracker->scene();
  const xpersif::core::CameraModel* camera = scene.findCamera(camera_name);
  if (!camera) {
    ROS_FATAL_STREAM("telesim_view: the scene has no camera '" << camera_name << "'");
    return 1;
  }
  xpersif::core::Renderer renderer(scene);

  // Inter-frame statistics of the tf stream, measured at receipt (the paper's Table I metric).
  std::mutex stats_mutex;
  std::vector<double> inter_frame_ms;
  ros::WallTime last_frame;
  std::atomic<std::uint64_t> frames{0};
  tracker->onFrame([&] {
    const ros::WallTime now = ros::WallTime::now();
    std::lock_guard<std::mutex> lock(stats_mutex);
    if (!last_frame.isZero()) inter_frame_ms.push_back((now - last_frame).toSec() * 1e3);
    last_frame = now;
    ++frames;
  });

  cv::VideoWriter video;
  if (!video_path.empty()) {
    video.open(video_path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), max_fps, cv::Size(camera->width, camera->height));
    if (!video.isOpened()) ROS_WARN_STREAM("telesim_view: cannot write video " << video_path << "; images only");
  }

  ros::AsyncSpinner spinner(1);
  spinner.start();
  cv::Mat image;
  std::vector<double> render_ms;
  std::uint64_t rendered = 0, last_rendered_frame = 0;
  const ros::WallTime start = ros::WallTime::now();
  ros::WallRate rate(max_fps);
  while (ros::ok() && (duration <= 0 || (ros::WallTime::now() - start).toSec() < duration)) {
    rate.sleep();
    const std::uint64_t frame = frames;
    if (frame == last_rendered_frame) continue;  // nothing moved
    last_rendered_frame = frame;
    const auto world = tracker->worldTransforms();
    const ros::WallTime t0 = ros::WallTime::now();
    renderer.render(*camera, world.at(camera->frame), world, image);
    render_ms.push_back((ros::WallTime::now() - t0).toSec() * 1e3);
    ++rendered;
    if (video.isOpened()) video.write(image);
    if (!output_dir.empty() && (rendered == 1 || (save_every > 0 && rendered % save_every == 0))) {
      char name[64];
      std::snprintf(name, sizeof name, "/%s_%06lu.png", camera_name.c_str(), static_cast<unsigned long>(rendered));
      cv::imwrite(output_dir + name, image);
    }
    if (display) {
      cv::imshow("TeleSimView: " + camera_name, image);
      cv::waitKey(1);
    }
  }
  if (!output_dir.empty() && !image.empty()) cv::imwrite(output_dir + "/" + camera_name + "_last.png", image);

  std::vector<double> intervals;
  {
    std::lock_guard<std::mutex> lock(stats_mutex);
    intervals = inter_frame_ms;
  }
  std::printf("telesim_view: camera %s, %lu tf frames, inter-frame mean %.3f ms p50 %.3f p99 %.3f max %.3f; "
              "%lu images rendered, render mean %.2f ms p99 %.2f\n",
              camera_name.c_str(), static_cast<unsigned long>(frames.load()), mean(intervals),
              percentile(intervals, 0.5), percentile(intervals, 0.99),
              intervals.empty() ? 0.0 : *std::max_element(intervals.begin(), intervals.end()),
              static_cast<unsigned long>(rendered), mean(render_ms), percentile(render_ms, 0.99));
  if (!output_dir.empty()) {
    std::ofstream csv(output_dir + "/telesim_view_inter_frame_ms.csv");
    csv << "inter_frame_ms\n";
    for (double v : intervals) csv << v << "\n";
  }
  return 0;
}
