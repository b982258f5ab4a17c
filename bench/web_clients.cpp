// N headless WebSocket clients of WEBBRIDGE in one process (one asio thread), for bench/run_web.sh:
//   web_clients URL N RATE SECONDS WARMUP
// RATE is frames per second or "full". Every client connects, asks for RATE, and counts the frames that arrive
// within the SECONDS-long window after WARMUP s; the latency of a frame is its receipt time minus the wall time
// the bridge stamped on it when /tf delivered it (same machine, same clock). Prints one JSON line:
// clients connected, frames per client (min, mean, max), latency p50/p95/p99/max in ms, the process's CPU.
#include <websocketpp/client.hpp>
#include <websocketpp/config/asio_no_tls_client.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>
#include <sys/resource.h>
#include <vector>

using Client = websocketpp::client<websocketpp::config::asio_client>;

namespace {
double wallNow() {
  timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
double cpuSeconds() {
  rusage u;
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}
double quantile(std::vector<double>& v, double q) {
  if (v.empty()) return -1;
  std::size_t i = std::min(v.size() - 1, static_cast<std::size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + i, v.end());
  return v[i];
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: web_clients URL N RATE SECONDS WARMUP\n");
    return 2;
  }
  const std::string url = argv[1];
  const int n = std::atoi(argv[2]);
  const std::string rate = argv[3];
  const double seconds = std::atof(argv[4]), warmup = std::atof(argv[5]);
  const std::string config = rate == "full" ? R"({"type":"config","rate":"full"})"
                                            : std::string(R"({"type":"config","rate":)") + rate + "}";
  Client client;
  client.clear_access_channels(websocketpp::log::alevel::all);
  client.clear_error_channels(websocketpp::log::elevel::all);
  client.init_asio();
  const double start = wallNow();
  const double open_at = start + warmup, close_at = open_at + seconds;
  std::vector<long> frames(n, 0);
  std::vector<double> latencies;
  latencies.reserve(2000000);
  int connected = 0, failed = 0;
  double cpu0 = -1;
  for (int i = 0; i < n; ++i) {
    websocketpp::lib::error_code ec;
    auto con = client.get_connection(url, ec);
    if (ec) {
      std::fprintf(stderr, "web_clients: %s\n", ec.message().c_str());
      return 1;
    }
    con->set_open_handler([&, i](websocketpp::connection_hdl h) {
      ++connected;
      client.send(h, config, websocketpp::frame::opcode::text);
    });
    con->set_fail_handler([&](websocketpp::connection_hdl) { ++failed; });
    con->set_message_handler([&, i](websocketpp::connection_hdl, Client::message_ptr m) {
      if (m->get_opcode() != websocketpp::frame::opcode::binary) return;
      const double now = wallNow();
      if (now < open_at || now > close_at) return;
      const std::string& p = m->get_payload();
      if (p.size() < 36 || std::memcmp(p.data(), "XPF1", 4) != 0) return;
      double stamped;
      std::memcpy(&stamped, p.data() + 24, 8);
      ++frames[i];
      latencies.push_back(now - stamped);
    });
    client.connect(con);
  }
  auto timer_done = false;
  client.set_timer(static_cast<long>(1000 * warmup), [&](const websocketpp::lib::error_code&) { cpu0 = cpuSeconds(); });
  client.set_timer(static_cast<long>(1000 * (warmup + seconds)), [&](const websocketpp::lib::error_code&) {
    timer_done = true;
    client.stop();
  });
  client.run();
  const double cpu = cpuSeconds() - (cpu0 < 0 ? 0 : cpu0);
  std::vector<long> f = frames;
  std::sort(f.begin(), f.end());
  double mean = 0;
  for (long x : f) mean += x;
  mean = n ? mean / n : 0;
  std::vector<double> l = latencies;
  std::printf("{\"clients\": %d, \"rate\": \"%s\", \"connected\": %d, \"failed\": %d, \"seconds\": %.1f, "
              "\"frames_min\": %ld, \"frames_mean\": %.1f, \"frames_max\": %ld, \"frames_total\": %zu, "
              "\"latency_ms\": {\"p50\": %.3f, \"p95\": %.3f, \"p99\": %.3f, \"max\": %.3f}, \"client_cpu_s\": %.2f, "
              "\"window_done\": %s}\n",
              n, rate.c_str(), connected, failed, seconds, f.empty() ? 0 : f.front(), mean, f.empty() ? 0 : f.back(),
              latencies.size(), 1000 * quantile(l, 0.5), 1000 * quantile(l, 0.95), 1000 * quantile(l, 0.99),
              1000 * quantile(l, 1.0), cpu, timer_done ? "true" : "false");
  return 0;
}
