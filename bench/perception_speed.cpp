// Speed of FEATUREEXTRACTION + VISION on overhead frames of the default world (600 x 416), beside the raw
// OpenCV cost of the basic steps on the same images in the same run: cvtColor(BGR -> HSV) + one inRange per
// cube colour + findContours + minAreaRect of the largest contour.
// Images are rendered beforehand (100 random scenes, cycled); only the image -> features path is timed.
// Usage: perception_speed [frames=2000] [out_dir=(none)] [noise_sigma=0]
// Writes out_dir/perception_speed.md (or perception_speed_noise<sigma>.md). With noise_sigma > 0, Gaussian noise
// of that standard deviation (grey levels, seeded) is added to every image: no more runs of identical pixels.
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "perception_scenes.h"
#include "xpersif/core/perception/feature_extractor.h"
#include "xpersif/core/perception/vision.h"

using namespace perception_bench;
using Clock = std::chrono::steady_clock;

namespace {

struct Timing {
  std::vector<double> ms;
  std::string row() const {
    std::vector<double> s = ms;
    std::sort(s.begin(), s.end());
    double sum = 0;
    for (double x : s) sum += x;
    auto q = [&](double p) { return s[std::min(s.size() - 1, static_cast<std::size_t>(p * (s.size() - 1) + 0.5))]; };
    char buf[200];
    std::snprintf(buf, sizeof buf, "%.3f | %.3f | %.3f | %.3f | %.3f | %.0f", sum / s.size(), q(0.5), q(0.95), q(0.99),
                  s.back(), 1000.0 * s.size() / sum);
    return buf;
  }
};

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 2000;
  const std::string out_dir = argc > 2 ? argv[2] : "";
  const double noise = argc > 3 ? std::atof(argv[3]) : 0.0;
  const DefaultWorld w(std::string(XPERSIF_SOURCE_DIR) + "/worlds/default.yaml");
  const Renderer renderer(w.scene);
  const CameraModel& overhead = *w.scene.findCamera("overhead");
  const PerceptionCatalogue catalogue = PerceptionCatalogue::fromScene(w.scene);
  const FeatureExtractor extractor(catalogue, overhead);
  const Vision vision;
  const FeatureSelection selection;  // the defaults
  std::vector<std::string> all;
  for (const auto& f : availableFeatures()) all.push_back(f.name);
  const FeatureSelection everything(all);
  const ArenaExtents arena{w.spec.arena.size_x, w.spec.arena.size_y};

  std::mt19937 rng(1);
  std::vector<Frame> images;
  Timing render_t;
  for (int i = 0; i < 100; ++i) {
    const FrameTransforms current = randomScene(w, rng);
    const auto t0 = Clock::now();
    images.push_back(render(renderer, w.scene, current, overhead));
    render_t.ms.push_back(msSince(t0));
    if (noise > 0) {
      cv::Mat n(images.back().image.size(), CV_16SC3), img16;
      cv::theRNG().state = 1000 + i;
      cv::randn(n, 0, noise);
      images.back().image.convertTo(img16, CV_16SC3);
      img16 += n;
      img16.convertTo(images.back().image, CV_8UC3);  // saturating
    }
  }
  // HSV boxes around the catalogue colours for the baseline (OpenCV's 8-bit hue is 0..180).
  std::vector<std::pair<cv::Scalar, cv::Scalar>> hsv_ranges;
  for (const auto& o : catalogue.objects) {
    cv::Mat px(1, 1, CV_8UC3, cv::Scalar(o.color.b * 255, o.color.g * 255, o.color.r * 255)), hsv;
    cv::cvtColor(px, hsv, cv::COLOR_BGR2HSV);
    const cv::Vec3b h = hsv.at<cv::Vec3b>(0, 0);
    hsv_ranges.push_back({cv::Scalar(std::max(0, h[0] - 6), 80, 40), cv::Scalar(std::min(180, h[0] + 6), 255, 255)});
  }

  Timing extract_t, vision_t, total_t, vision_all_t, baseline_t;
  std::size_t found = 0, baseline_rects = 0;
  const int warmup = 20;
  for (int i = 0; i < frames + warmup; ++i) {
    const Frame& f = images[i % images.size()];
    auto t0 = Clock::now();
    const Detections d = extractor.extract(f.image, f.world_from_camera);
    const double te = msSince(t0);
    auto t1 = Clock::now();
    const auto features = vision.compute(f.image, d, selection, arena);
    const double tv = msSince(t1);
    auto t2 = Clock::now();
    const auto features_all = vision.compute(f.image, d, everything, arena);
    const double tva = msSince(t2);

    auto t3 = Clock::now();
    cv::Mat hsv, mask;
    cv::cvtColor(f.image, hsv, cv::COLOR_BGR2HSV);
    for (const auto& [lo, hi] : hsv_ranges) {
      cv::inRange(hsv, lo, hi, mask);
      std::vector<std::vector<cv::Point>> contours;
      cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
      if (contours.empty()) continue;
      const auto largest = std::max_element(contours.begin(), contours.end(), [](const auto& a, const auto& b) {
        return cv::contourArea(a) < cv::contourArea(b);
      });
      const cv::RotatedRect r = cv::minAreaRect(*largest);
      baseline_rects += r.size.area() > 0;
    }
    const double tb = msSince(t3);
    if (i < warmup) continue;
    found += d.objects.size() + features.size() + features_all.size();
    extract_t.ms.push_back(te);
    vision_t.ms.push_back(tv);
    vision_all_t.ms.push_back(tva);
    total_t.ms.push_back(te + tv);
    baseline_t.ms.push_back(tb);
  }

  std::ostringstream md;
  md << "perception_speed: " << frames << " overhead frames (600 x 416) of 100 random default-world scenes, one "
     << "thread, image noise sigma " << noise << "\n(checksum: " << found << " detections+feature vectors, " << baseline_rects << " baseline rects)\n\n";
  md << "| step | mean ms | p50 | p95 | p99 | max | per second |\n| --- | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  md << "| extract() | " << extract_t.row() << " |\n";
  md << "| Vision::compute(), default selection | " << vision_t.row() << " |\n";
  md << "| image -> feature vectors (extract + Vision, default) | " << total_t.row() << " |\n";
  md << "| Vision::compute(), all " << all.size() << " features | " << vision_all_t.row() << " |\n";
  md << "| raw OpenCV: cvtColor HSV + 4 x (inRange + findContours + minAreaRect) | " << baseline_t.row() << " |\n";
  md << "| (for scale) Renderer::render(), 100 frames | " << render_t.row() << " |\n";
  std::fputs(md.str().c_str(), stdout);
  if (!out_dir.empty()) {
    const std::string suffix = noise > 0 ? "_noise" + std::to_string(static_cast<int>(noise)) : "";
    std::ofstream(out_dir + "/perception_speed" + suffix + ".md") << md.str();
  }
  return 0;
}
