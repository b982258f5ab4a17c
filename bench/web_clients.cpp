// N headless WebSocket clients of WEBBRIDGE in one process (one asio thread), for bench/run_web.sh:
//   web_clients URL N RATE SECONDS WARMUP [page|foxglove]
// RATE is frames per second or "full". Every client connects, asks for RATE, and counts the frames that arrive
// within the SECONDS-long window after WARMUP s; the latency of a frame is its receipt time minus the wall time
// the bridge stamped on it when /tf delivered it (same machine, same clock). Prints one JSON line:
// clients connected, frames per client (min, mean, max), latency p50/p95/p99/max in ms, the process's CPU.
//
// With "foxglove" (issue 40) the N clients speak foxglove.websocket.v1 and subscribe to /tf (every message; RATE is
// not used). Foxglove's frames carry simulated time only, so one more client, of the page's protocol at the full
// rate, is the reference: its frames say when the bridge received the /tf message of each stamp, and a Foxglove
// frame's latency is its receipt time minus that (frames whose stamp the reference missed are not counted).
#include <nlohmann/json.hpp>
#include <websocketpp/client.hpp>
#include <websocketpp/config/asio_no_tls_client.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
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
/// A /tf message's stamp in microseconds: the key both protocols' frames are matched on.
long long stampKey(double seconds) { return static_cast<long long>(seconds * 1e6 + 0.5); }

/// The first transform's stamp of a Foxglove Message Data frame carrying a tf2_msgs/TFMessage (ROS 1 encoding:
/// opcode, u32 subscription, u64 receive time; then u32 transform count, and the first header: u32 seq, u32 sec,
/// u32 nsec); negative when it is not one.
double foxgloveTfStamp(const std::string& p) {
  if (p.size() < 13 + 4 + 12 || p[0] != 0x01) return -1;
  std::uint32_t count, sec, nsec;
  std::memcpy(&count, p.data() + 13, 4);
  std::memcpy(&sec, p.data() + 21, 4);
  std::memcpy(&nsec, p.data() + 25, 4);
  return count ? sec + 1e-9 * nsec : -1;
}

double quantile(std::vector<double>& v, double q) {
  if (v.empty()) return -1;
  std::size_t i = std::min(v.size() - 1, static_cast<std::size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + i, v.end());
  return v[i];
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 6 && argc != 7) {
    std::fprintf(stderr, "usage: web_clients URL N RATE SECONDS WARMUP [page|foxglove]\n");
    return 2;
  }
  const bool foxglove = argc == 7 && std::string(argv[6]) == "foxglove";
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
  // Foxglove: (receipt wall time, stamp) per frame; the reference client's bridge receipt time per stamp.
  std::vector<std::pair<double, long long>> foxglove_frames;
  std::map<long long, double> bridge_received;
  const auto connectFoxglove = [&](int i) {
    websocketpp::lib::error_code ec;
    auto con = client.get_connection(url, ec);
    if (ec) return ec;
    con->add_subprotocol("foxglove.websocket.v1");
    con->set_open_handler([&](websocketpp::connection_hdl) { ++connected; });
    con->set_fail_handler([&](websocketpp::connection_hdl) { ++failed; });
    con->set_message_handler([&, i](websocketpp::connection_hdl h, Client::message_ptr m) {
      const std::string& p = m->get_payload();
      if (m->get_opcode() == websocketpp::frame::opcode::text) {
        const auto j = nlohmann::json::parse(p, nullptr, false);
        if (j.is_discarded() || j.value("op", "") != "advertise") return;
        for (const auto& c : j["channels"]) {
          if (c.value("topic", "") != "/tf") continue;
          const nlohmann::json sub = {{"op", "subscribe"}, {"subscriptions", {{{"id", 1}, {"channelId", c["id"]}}}}};
          client.send(h, sub.dump(), websocketpp::frame::opcode::text);
        }
        return;
      }
      const double now = wallNow(), stamp = foxgloveTfStamp(p);
      if (now < open_at || now > close_at || stamp < 0) return;
      ++frames[i];
      foxglove_frames.emplace_back(now, stampKey(stamp));
    });
    client.connect(con);
    return ec;
  };
  // The page's protocol at the full rate: when the bridge received each stamp's /tf message.
  if (foxglove) {
    websocketpp::lib::error_code ec;
    auto con = client.get_connection(url, ec);
    if (ec) return 1;
    con->set_open_handler([&](websocketpp::connection_hdl h) {
      client.send(h, R"({"type":"config","rate":"full"})", websocketpp::frame::opcode::text);
    });
    con->set_message_handler([&](websocketpp::connection_hdl, Client::message_ptr m) {
      const std::string& p = m->get_payload();
      if (p.size() < 36 || std::memcmp(p.data(), "XPF1", 4) != 0) return;
      double sim_time, stamped;
      std::memcpy(&sim_time, p.data() + 16, 8);
      std::memcpy(&stamped, p.data() + 24, 8);
      bridge_received[stampKey(sim_time)] = stamped;
    });
    client.connect(con);
  }
  for (int i = 0; foxglove && i < n; ++i) {
    if (auto ec = connectFoxglove(i)) {
      std::fprintf(stderr, "web_clients: %s\n", ec.message().c_str());
      return 1;
    }
  }
  for (int i = 0; !foxglove && i < n; ++i) {
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
  std::size_t unmatched = 0;
  for (const auto& [received, key] : foxglove_frames) {
    auto it = bridge_received.find(key);
    if (it == bridge_received.end()) {
      ++unmatched;
    } else {
      latencies.push_back(received - it->second);
    }
  }
  std::vector<long> f = frames;
  std::sort(f.begin(), f.end());
  double mean = 0;
  for (long x : f) mean += x;
  mean = n ? mean / n : 0;
  std::vector<double> l = latencies;
  std::printf("{\"clients\": %d, \"rate\": \"%s\", \"connected\": %d, \"failed\": %d, \"seconds\": %.1f, "
              "\"frames_min\": %ld, \"frames_mean\": %.1f, \"frames_max\": %ld, \"frames_total\": %zu, "
              "\"latency_ms\": {\"p50\": %.3f, \"p95\": %.3f, \"p99\": %.3f, \"max\": %.3f}, \"client_cpu_s\": %.2f, "
              "\"window_done\": %s, \"protocol\": \"%s\", \"latency_unmatched\": %zu}\n",
              n, rate.c_str(), connected, failed, seconds, f.empty() ? 0 : f.front(), mean, f.empty() ? 0 : f.back(),
              latencies.size(), 1000 * quantile(l, 0.5), 1000 * quantile(l, 0.95), 1000 * quantile(l, 0.99),
              1000 * quantile(l, 1.0), cpu, timer_done ? "true" : "false", foxglove ? "foxglove" : "page", unmatched);
  return 0;
}
