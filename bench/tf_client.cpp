// tf fan-out client: subscribes /tf (TCP_NODELAY), records for every TFMessage its wall-clock receipt
// time and stamp, over a fixed wall-clock window, then prints ONE line of JSON and exits.
//
//   tf_client _mode:=seq|stamp [_period:=0.001] [_duration:=5] [_start_wall:=<epoch s>] [_label:=x]
//             [_topic:=/tf] [_timeout:=30]
//
// Window: from ~start_wall (absolute wall-clock epoch seconds; 0 = from the first frame received) for
// ~duration seconds. Frames arriving before the window are ignored, so clients started one after the
// other all measure the same interval, once every one of them is connected.
//
// Frame numbers (to count lost frames):
//  - mode seq   (tf_raw_publisher): transforms[0].header.seq, a counter
//  - mode stamp (xpersim): round(stamp / ~period); xpersim's stamps are simulated time and advance by
//    exactly 1/tf_rate per frame.
// expected = last - first + 1 over the frames received in the window; lost = expected - distinct received.
//
// Latency: abs = receipt wall time - stamp. For the raw publisher the stamp is wall time, so abs is the
// real one-way latency (same machine, same clock). For xpersim the stamp is SIMULATED time, so abs is
// meaningless by itself; both are therefore also reported relative to the best sample of the run:
// rel = abs - min(abs). rel is what is compared between publishers: the extra delay of a frame over the
// fastest delivery seen (for a realtime-paced publisher, min(abs) includes the fixed sim/wall offset).
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <set>
#include <vector>

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double rank = p / 100.0 * (v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(rank)), hi = static_cast<std::size_t>(std::ceil(rank));
  return v[lo] + (v[hi] - v[lo]) * (rank - lo);
}

double mean(const std::vector<double>& v) {
  if (v.empty()) return std::nan("");
  double s = 0;
  for (double x : v) s += x;
  return s / v.size();
}

std::string num(double x) {
  if (!std::isfinite(x)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.4f", x);
  return buf;
}

struct Sample {
  std::int64_t receipt_ns;
  std::int64_t stamp_ns;
  std::int64_t frame;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "tf_client", ros::init_options::AnonymousName | ros::init_options::NoSigintHandler);
  ros::NodeHandle nh, pnh("~");
  std::string mode = "seq", label = "", topic = "/tf";
  double period = 0.001, duration = 5.0, start_wall = 0.0, timeout = 30.0;
  pnh.param("mode", mode, mode);
  pnh.param("period", period, period);
  pnh.param("duration", duration, duration);
  pnh.param("start_wall", start_wall, start_wall);
  pnh.param("label", label, label);
  pnh.param("topic", topic, topic);
  pnh.param("timeout", timeout, timeout);
  const bool by_seq = mode == "seq";

  std::vector<Sample> samples;
  samples.reserve(static_cast<std::size_t>(duration * 2.0 / period) + 1000);
  std::int64_t window_start = static_cast<std::int64_t>(start_wall * 1e9), window_end = 0;
  const std::int64_t duration_ns = static_cast<std::int64_t>(duration * 1e9);
  if (window_start > 0) window_end = window_start + duration_ns;
  std::uint64_t before_window = 0;
  std::size_t transforms = 0;
  bool done = false;

  auto callback = [&](const tf2_msgs::TFMessage::ConstPtr& msg) {
    const ros::WallTime now = ros::WallTime::now();
    const std::int64_t t = static_cast<std::int64_t>(now.sec) * 1000000000LL + now.nsec;
    if (done || msg->transforms.empty()) return;
    if (window_start == 0) {
      window_start = t;
      window_end = t + duration_ns;
    }
    if (t < window_start) {
      ++before_window;
      return;
    }
    if (t >= window_end) {
      done = true;
      return;
    }
    const auto& h = msg->transforms[0].header;
    const std::int64_t stamp = static_cast<std::int64_t>(h.stamp.sec) * 1000000000LL + h.stamp.nsec;
    const std::int64_t frame = by_seq ? static_cast<std::int64_t>(h.seq) : std::llround(h.stamp.toSec() / period);
    transforms = msg->transforms.size();
    samples.push_back({t, stamp, frame});
  };
  ros::Subscriber sub = nh.subscribe<tf2_msgs::TFMessage>(topic, 10000, callback, ros::VoidConstPtr(),
                                                          ros::TransportHints().tcpNoDelay());

  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::ok() && !done) {
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.05));
    const ros::WallTime now = ros::WallTime::now();
    const std::int64_t t = static_cast<std::int64_t>(now.sec) * 1000000000LL + now.nsec;
    if (window_end > 0 && t >= window_end + 500000000LL) done = true;  // publisher went silent
    if (now > give_up) break;
  }

  // Statistics.
  std::vector<double> inter, lat_abs, lat_rel;
  std::set<std::int64_t> frames;
  std::uint64_t out_of_order = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (i > 0) {
      inter.push_back((samples[i].receipt_ns - samples[i - 1].receipt_ns) / 1e6);
      if (samples[i].frame <= samples[i - 1].frame) ++out_of_order;
    }
    lat_abs.push_back((samples[i].receipt_ns - samples[i].stamp_ns) / 1e6);
    frames.insert(samples[i].frame);
  }
  const double offset = lat_abs.empty() ? 0 : *std::min_element(lat_abs.begin(), lat_abs.end());
  for (double a : lat_abs) lat_rel.push_back(a - offset);
  std::int64_t expected = frames.empty() ? 0 : *frames.rbegin() - *frames.begin() + 1;
  const std::int64_t lost = expected - static_cast<std::int64_t>(frames.size());
  const double span_s = samples.size() > 1 ? (samples.back().receipt_ns - samples.front().receipt_ns) / 1e9 : 0;
  const double rate = span_s > 0 ? (samples.size() - 1) / span_s : 0;

  std::printf(
      "{\"label\":\"%s\",\"mode\":\"%s\",\"transforms\":%zu,\"window_s\":%s,\"received\":%zu,\"expected\":%" PRId64
      ",\"lost\":%" PRId64 ",\"out_of_order\":%" PRIu64 ",\"before_window\":%" PRIu64
      ",\"rate_hz\":%s,\"inter_mean_ms\":%s,\"inter_p50_ms\":%s,\"inter_p99_ms\":%s,\"inter_max_ms\":%s"
      ",\"lat_abs_p50_ms\":%s,\"lat_abs_p99_ms\":%s,\"lat_abs_max_ms\":%s,\"lat_offset_ms\":%s"
      ",\"lat_rel_p50_ms\":%s,\"lat_rel_p99_ms\":%s,\"lat_rel_max_ms\":%s}\n",
      label.c_str(), mode.c_str(), transforms, num(duration).c_str(), samples.size(), expected, lost, out_of_order,
      before_window, num(rate).c_str(), num(mean(inter)).c_str(), num(percentile(inter, 50)).c_str(),
      num(percentile(inter, 99)).c_str(), num(inter.empty() ? std::nan("") : *std::max_element(inter.begin(), inter.end())).c_str(),
      num(percentile(lat_abs, 50)).c_str(), num(percentile(lat_abs, 99)).c_str(),
      num(lat_abs.empty() ? std::nan("") : *std::max_element(lat_abs.begin(), lat_abs.end())).c_str(), num(offset).c_str(),
      num(percentile(lat_rel, 50)).c_str(), num(percentile(lat_rel, 99)).c_str(),
      num(lat_rel.empty() ? std::nan("") : *std::max_element(lat_rel.begin(), lat_rel.end())).c_str());
  std::fflush(stdout);
  sub.shutdown();
  ros::shutdown();
  return samples.empty() ? 2 : 0;
}
