// N clients that call two operations at a fixed rate each, for the reliability battery's load figure (issue 19,
// item 5; see reliability.md). Each client is a thread with persistent connections to both services (as a
// dashboard or a second experimenter would hold them) and calls them back to back once per period, on a wall
// clock that never catches up on missed periods. At the end: calls made and wanted, failures (no answer or a
// refusal), and the round trip's p50/p99/max.
//   service_load --clients 100 --rate 50 --duration 60
//                [--features /xpersif/observation/get_features] [--state /xpersif/robot_model/get_robot_state]
// SIGINT ends it early, with the figures.
#include <ros/ros.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "xpersif/GetFeatures.h"
#include "xpersif/GetRobotState.h"

namespace {

std::atomic<bool> g_interrupted{false};  // SIGINT: stop calling and print the figures

struct Totals {
  std::mutex mutex;
  std::vector<double> latencies_ms;
  long calls = 0, refused = 0, unanswered = 0, wanted = 0;
};

template <class Service>
void callOnce(ros::ServiceClient& client, const std::string& name, Totals& local) {
  if (!client.isValid()) {
    ros::NodeHandle nh;
    client = nh.serviceClient<Service>(name, true);
  }
  Service call;
  const auto start = std::chrono::steady_clock::now();
  const bool answered = client.call(call);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  ++local.calls;
  if (!answered) {
    ++local.unanswered;
    return;
  }
  if (!call.response.success) ++local.refused;
  local.latencies_ms.push_back(ms);
}

double percentile(std::vector<double>& v, double p) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "service_load", ros::init_options::AnonymousName | ros::init_options::NoSigintHandler);
  int clients = 100;
  double rate = 50, duration = 60;
  std::string features = "/xpersif/observation/get_features", state = "/xpersif/robot_model/get_robot_state";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--clients") clients = std::atoi(value.c_str());
    else if (key == "--rate") rate = std::atof(value.c_str());
    else if (key == "--duration") duration = std::atof(value.c_str());
    else if (key == "--features") features = value;
    else if (key == "--state") state = value;
    else {
      std::fprintf(stderr, "service_load: unknown option %s\n", key.c_str());
      return 2;
    }
  }
  if (clients < 1 || !(rate > 0) || !(duration > 0)) {
    std::fprintf(stderr, "service_load: --clients, --rate and --duration must be positive\n");
    return 2;
  }
  std::signal(SIGINT, [](int) { g_interrupted = true; });
  ros::NodeHandle nh;
  if (!ros::service::waitForService(features, ros::Duration(60)) || !ros::service::waitForService(state, ros::Duration(60))) {
    std::fprintf(stderr, "service_load: %s or %s did not appear within 60 s\n", features.c_str(), state.c_str());
    return 1;
  }
  Totals totals;
  std::atomic<bool> stop{false};
  const auto period = std::chrono::duration<double>(1.0 / rate);
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      Totals local;
      ros::ServiceClient f = nh.serviceClient<xpersif::GetFeatures>(features, true);
      ros::ServiceClient s = nh.serviceClient<xpersif::GetRobotState>(state, true);
      // Spread the clients over the period, as independent users would be.
      auto next = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                         period * (static_cast<double>(c) / clients));
      while (!stop && ros::ok()) {
        std::this_thread::sleep_until(next);
        ++local.wanted;
        callOnce<xpersif::GetFeatures>(f, features, local);
        callOnce<xpersif::GetRobotState>(s, state, local);
        next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
        const auto now = std::chrono::steady_clock::now();
        if (next < now) next = now;  // late: skip the missed periods rather than burst
      }
      std::lock_guard<std::mutex> lock(totals.mutex);
      totals.calls += local.calls;
      totals.refused += local.refused;
      totals.unanswered += local.unanswered;
      totals.wanted += local.wanted;
      totals.latencies_ms.insert(totals.latencies_ms.end(), local.latencies_ms.begin(), local.latencies_ms.end());
    });
  }
  const auto start = std::chrono::steady_clock::now();
  while (ros::ok() && !g_interrupted && std::chrono::steady_clock::now() - start < std::chrono::duration<double>(duration)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  stop = true;
  for (auto& t : threads) t.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  auto& l = totals.latencies_ms;
  const double p50 = percentile(l, 0.5), p99 = percentile(l, 0.99);
  const double max = l.empty() ? 0 : *std::max_element(l.begin(), l.end());
  std::printf(
      "service_load: %d clients x 2 operations at %.0f Hz for %.1f s: %ld calls (%.0f/s; %.0f/s wanted), %ld refused, "
      "%ld unanswered; round trip p50 %.2f ms, p99 %.2f ms, max %.1f ms\n",
      clients, rate, seconds, totals.calls, totals.calls / seconds, 2.0 * clients * rate, totals.refused,
      totals.unanswered, p50, p99, max);
  return totals.unanswered > 0 ? 1 : 0;
}
