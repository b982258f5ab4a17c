#include "xpersif/web/web_bridge.h"

#include "xpersif/component/parameter_reader.h"

#include <ros/package.h>
#include <std_srvs/Trigger.h>
#include <tf2_msgs/TFMessage.h>

#include <boost/asio/steady_timer.hpp>
#include <nlohmann/json.hpp>
#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <atomic>
#include <cmath>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "xpersif/ExperimentProgress.h"
#include "xpersif/ExperimentRecord.h"
#include "xpersif/Motivation.h"
#include "xpersif/Notions.h"
#include "xpersif/RunLoopActionGoal.h"
#include "xpersif/RunLoopFeedback.h"
#include "xpersif/Scene.h"
#include "xpersif/core/web/web_stream.h"
#include "xpersif/ros/conversions.h"

namespace xpersif {

namespace {

using Server = websocketpp::server<websocketpp::config::asio>;
using Hdl = websocketpp::connection_hdl;
using json = nlohmann::json;

double steadyNow() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

core::WebPayload textPayload(const std::string& s) { return {std::make_shared<const std::string>(s), false}; }

bool readFile(const std::string& path, std::string& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream s;
  s << in.rdbuf();
  out = s.str();
  return static_cast<bool>(in) || in.eof();
}

}  // namespace

struct WebBridge::Impl {
  explicit Impl(WebBridge& owner) : owner(owner) {}

  WebBridge& owner;

  // ---- configuration (set on configure, read-only while active) ----
  std::string address = "127.0.0.1";
  int port = 8765;
  std::string ns;
  core::WebClientLimits limits;
  std::size_t socket_send_buffer = 65536;
  int max_clients = 128;
  std::size_t curve_points = 2000;
  bool allow_commands = false;
  std::string token;
  std::string web_root;
  std::string experiment_progress_topic = "/experiment/progress";
  struct Asset {
    int status = 200;
    std::string type;
    std::string body;
  };
  std::map<std::string, Asset> assets;

  // ---- the newest of everything, written by ROS callbacks, read by the network thread ----
  std::mutex latest_mutex;
  std::map<std::string, core::WebPayload> latest;  // by key, "scene" included
  std::set<std::string> dirty;
  core::WebPayload latest_frame;
  bool frame_dirty = false;
  std::atomic<bool> pump_posted{false};
  std::mutex post_mutex;  // accepting and posting: no ROS callback posts to a server that is going away
  bool accepting = false;
  std::atomic<std::uint64_t> frames_in{0};

  // ---- the scene and the loop's state (ROS callbacks; state_mutex) ----
  std::mutex state_mutex;
  std::uint32_t generation = 0;
  std::map<std::string, std::size_t> frame_index;  // dynamic node -> its slot in a frame
  std::vector<float> poses;                        // 7 per dynamic node
  std::uint64_t frame_seq = 0;
  json loop = json::object();
  std::deque<json> curve;
  std::set<std::pair<std::uint64_t, std::uint32_t>> curve_seen;

  // ---- the network thread's own ----
  struct Client {
    core::WebClientQueue queue;
    std::string remote;
    std::uint64_t id = 0;
    double connected = 0;
    explicit Client(const core::WebClientLimits& l) : queue(l) {}
  };
  std::unique_ptr<Server> server;
  std::map<Hdl, std::shared_ptr<Client>, std::owner_less<Hdl>> clients;
  std::uint64_t next_client_id = 1;
  std::unique_ptr<boost::asio::steady_timer> housekeeping;
  std::unique_ptr<boost::asio::steady_timer> due_timer;
  double due_at = -1;
  std::thread network;
  std::uint64_t disconnected_stalled = 0, closed_bad_messages = 0, refused_full = 0;

  // ---- summary for ~status (network thread writes, status reads) ----
  std::mutex summary_mutex;
  std::string summary = "not listening";

  // ---- commands: one worker thread calls LOOPMODEL's operations ----
  struct CommandJob {
    Hdl hdl;
    std::string command, id;
  };
  std::mutex jobs_mutex;
  std::condition_variable jobs_cv;
  std::deque<CommandJob> jobs;
  bool jobs_stop = false;
  std::thread worker;

  std::vector<ros::Subscriber> subscribers;

  // =====================================================================================================
  void configure(ros::NodeHandle& pnh, ros::NodeHandle& nh) {
    const ParameterReader parameters(pnh, WebBridge::parameters());
    const std::string new_address = parameters.get<std::string>("address");
    const int new_port = parameters.get<int>("port");
    std::string new_ns = parameters.get<std::string>("ns", nh.getNamespace());
    core::WebClientLimits l;
    l.default_rate = parameters.get<double>("rate");
    l.max_rate = parameters.get<double>("max_rate");
    const double window = parameters.get<double>("send_window");
    const double sndbuf = parameters.get<double>("socket_send_buffer");
    l.stall_timeout = parameters.get<double>("stall_timeout");
    const int new_max_clients = parameters.get<int>("max_clients");
    const double max_message = parameters.get<double>("max_client_message");
    l.client_messages_per_second = parameters.get<double>("client_messages_per_second");
    const int new_curve = parameters.get<int>("curve_points");
    const bool new_allow = parameters.get<bool>("allow_commands");
    const std::string new_token = parameters.get<std::string>("token");
    const std::string root = parameters.get<std::string>("web_root", ros::package::getPath("xpersif") + "/web");
    const std::string progress_topic = parameters.get<std::string>("experiment_progress_topic");

    boost::system::error_code ec;
    boost::asio::ip::make_address(new_address, ec);
    if (ec) throw core::ValidationError("~address '" + new_address + "' is not an IP address (" + ec.message() + ")");
    core::requireInRange("~port", new_port, 0, 65535);
    core::requireInRange("~max_rate", l.max_rate, 1, 10000);
    core::requireInRange("~rate", l.default_rate, 0, l.max_rate);
    core::requireInRange("~send_window", window, 1024, 256.0 * 1024 * 1024);
    core::requireInRange("~socket_send_buffer", sndbuf, 4096, 64.0 * 1024 * 1024);
    core::requireInRange("~stall_timeout", l.stall_timeout, 0.1, 3600);
    core::requireInRange("~max_clients", new_max_clients, 1, 10000);
    core::requireInRange("~max_client_message", max_message, 64, 1024 * 1024);
    core::requireInRange("~client_messages_per_second", l.client_messages_per_second, 0.1, 10000);
    core::requireInRange("~curve_points", new_curve, 1, 1000000);
    if (new_allow && new_token.size() < 8) {
      throw core::ValidationError("~allow_commands needs a ~token of at least 8 characters, so that only people who "
                                  "know it can pause, resume or confirm the loop");
    }
    if (!new_ns.empty() && new_ns.back() == '/') new_ns.pop_back();
    l.send_window = static_cast<std::size_t>(window);
    l.max_client_message = static_cast<std::size_t>(max_message);

    address = new_address;
    port = new_port;
    ns = new_ns;
    limits = l;
    socket_send_buffer = static_cast<std::size_t>(sndbuf);
    max_clients = new_max_clients;
    curve_points = static_cast<std::size_t>(new_curve);
    allow_commands = new_allow;
    token = new_token;
    web_root = root;
    experiment_progress_topic = progress_topic;
    loadAssets();
  }

  void loadAssets() {
    assets.clear();
    const std::string modules = web_root + "/node_modules/three";
    const std::vector<std::tuple<std::string, std::string, std::string>> files = {
        {"/", web_root + "/index.html", "text/html; charset=utf-8"},
        {"/index.html", web_root + "/index.html", "text/html; charset=utf-8"},
        {"/app.js", web_root + "/app.js", "text/javascript; charset=utf-8"},
        {"/style.css", web_root + "/style.css", "text/css; charset=utf-8"},
        {"/three/three.module.js", modules + "/build/three.module.js", "text/javascript; charset=utf-8"},
        {"/three/three.core.js", modules + "/build/three.core.js", "text/javascript; charset=utf-8"},
        {"/three/addons/controls/OrbitControls.js", modules + "/examples/jsm/controls/OrbitControls.js",
         "text/javascript; charset=utf-8"}};
    std::vector<std::string> missing;
    for (const auto& [path, file, type] : files) {
      Asset a;
      a.type = type;
      if (!readFile(file, a.body)) {
        missing.push_back(file);
        a.status = 503;
        a.type = "text/plain; charset=utf-8";
        a.body = "The web bridge cannot serve " + path + ": " + file + " is missing. " +
                 (file.find("node_modules") != std::string::npos
                      ? "Run `npm ci` in " + web_root + " (bash scripts/setup.sh does it).\n"
                      : "Is ~web_root right?\n");
      }
      assets[path] = std::move(a);
    }
    assets["/favicon.ico"] = Asset{204, "image/x-icon", ""};  // none: no 404 in the browser's console
    if (!missing.empty()) {
      ROS_ERROR("%s: the page cannot be served whole; missing: %s (run `npm ci` in %s; bash scripts/setup.sh does it). "
                "The WebSocket stream works without it.",
                owner.name().c_str(), missing.front().c_str(), web_root.c_str());
    }
  }

  // ---- ROS side ---------------------------------------------------------------------------------------
  void subscribe(ros::NodeHandle& nh) {
    auto hints = ros::TransportHints().tcpNoDelay();
    subscribers.push_back(nh.subscribe<xpersif::Scene>(ns + "/xpersim/scene", 1,
                                                      [this](const xpersif::Scene::ConstPtr& m) { onScene(*m); }));
    subscribers.push_back(nh.subscribe<tf2_msgs::TFMessage>(
        "/tf", 100, [this](const tf2_msgs::TFMessage::ConstPtr& m) { onTf(*m); }, ros::VoidConstPtr(), hints));
    subscribers.push_back(nh.subscribe<RunLoopFeedback>(ns + "/loop_model/progress", 10,
                                                       [this](const RunLoopFeedback::ConstPtr& m) { onProgress(*m); }));
    subscribers.push_back(nh.subscribe<RunLoopActionGoal>(ns + "/loop_model/run/goal", 10,
                                                         [this](const RunLoopActionGoal::ConstPtr& m) { onGoal(*m); }));
    subscribers.push_back(nh.subscribe<ExperimentRecord>(
        ns + "/knowledge_base/experiments", 100, [this](const ExperimentRecord::ConstPtr& m) { onRecord(*m); }));
    subscribers.push_back(nh.subscribe<Motivation>(ns + "/motivation/motivation", 10,
                                                  [this](const Motivation::ConstPtr& m) { onMotivation(*m); }));
    subscribers.push_back(nh.subscribe<Notions>(ns + "/machine_learning/notions", 10,
                                               [this](const Notions::ConstPtr& m) { onNotions(*m); }));
    subscribers.push_back(nh.subscribe<ExperimentProgress>(
        experiment_progress_topic, 10, [this](const ExperimentProgress::ConstPtr& m) { onExperiment(*m); }));
  }

  void unsubscribe() {
    for (auto& s : subscribers) s.shutdown();
    subscribers.clear();
  }

  void publishState(const std::string& key, const std::string& text) {
    {
      std::lock_guard<std::mutex> lock(latest_mutex);
      latest[key] = textPayload(text);
      dirty.insert(key);
    }
    postPump();
  }

  void onScene(const xpersif::Scene& message) {
    core::SceneDescription scene;
    try {
      scene = fromSceneMsg(message);
      core::worldTransforms(scene);  // throws for a broken node tree
    } catch (const std::exception& e) {
      ROS_ERROR("%s: scene from %s/xpersim/scene ignored: %s", owner.name().c_str(), ns.c_str(), e.what());
      return;
    }
    std::string text;
    {
      std::lock_guard<std::mutex> lock(state_mutex);
      ++generation;
      frame_index.clear();
      poses.clear();
      for (const auto& node : scene.nodes) {
        if (!node.dynamic) continue;
        const std::size_t slot = frame_index.size();
        frame_index[node.name] = slot;
        const Eigen::Vector3d p = node.parent_from_node.translation();
        const Eigen::Quaterniond q(node.parent_from_node.rotation());
        for (double v : {p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w()}) poses.push_back(static_cast<float>(v));
      }
      text = core::sceneToJson(scene, generation);
    }
    {
      std::lock_guard<std::mutex> lock(latest_mutex);
      latest["scene"] = textPayload(text);
      dirty.insert("scene");
      latest_frame = core::WebPayload();
      frame_dirty = false;
    }
    ROS_INFO("%s: scene of %s: %zu nodes, %zu cameras", owner.name().c_str(), message.world_file.c_str(),
             message.nodes.size(), message.cameras.size());
    postPump();
  }

  void onTf(const tf2_msgs::TFMessage& message) {
    core::WebFrame frame;
    {
      std::lock_guard<std::mutex> lock(state_mutex);
      if (frame_index.empty()) return;
      bool any = false;
      double stamp = 0;
      for (const auto& t : message.transforms) {
        auto it = frame_index.find(t.child_frame_id);
        if (it == frame_index.end()) continue;
        float* p = &poses[7 * it->second];
        const auto& tr = t.transform;
        const double values[7] = {tr.translation.x, tr.translation.y, tr.translation.z, tr.rotation.x,
                                  tr.rotation.y,    tr.rotation.z,    tr.rotation.w};
        bool finite = true;
        for (double v : values) finite = finite && std::isfinite(v);
        if (!finite) continue;  // XPERSim never publishes one; another publisher might
        for (int i = 0; i < 7; ++i) p[i] = static_cast<float>(values[i]);
        stamp = std::max(stamp, t.header.stamp.toSec());
        any = true;
      }
      if (!any) return;
      frame.generation = generation;
      frame.seq = ++frame_seq;
      frame.sim_time = stamp;
      frame.wall_time = ros::WallTime::now().toSec();
      frame.poses = poses;
    }
    ++frames_in;
    core::WebPayload payload{std::make_shared<const std::string>(core::encodeFrame(frame)), true};
    {
      std::lock_guard<std::mutex> lock(latest_mutex);
      latest_frame = std::move(payload);
      frame_dirty = true;
    }
    postPump();
  }

  void publishLoopLocked() { publishState("loop", dump(loop)); }

  void onProgress(const RunLoopFeedback& p) {
    std::lock_guard<std::mutex> lock(state_mutex);
    loop["type"] = "loop";
    loop["state"] = p.state;
    loop["experiment"] = p.experiment;
    loop["surprise"] = p.surprise;
    loop["last"] = p.last;
    publishLoopLocked();
  }

  void onGoal(const RunLoopActionGoal& g) {
    std::lock_guard<std::mutex> lock(state_mutex);
    loop["type"] = "loop";
    loop["run"] = g.goal.name;
    loop["design"] = g.goal.design;
    loop["experiments_planned"] = g.goal.experiments;
    loop["goals_planned"] = g.goal.goals;
    publishLoopLocked();
  }

  void onRecord(const ExperimentRecord& r) {
    std::lock_guard<std::mutex> lock(state_mutex);
    loop["type"] = "loop";
    loop["design"] = r.design;
    publishLoopLocked();
    if (r.status != "done" || !std::isfinite(r.surprise)) return;
    if (!curve_seen.insert({r.run_id, r.seq}).second) return;  // a latched record heard again
    curve.push_back({r.run_id, r.seq, r.design, r.surprise});
    while (curve.size() > curve_points) {
      curve_seen.erase({curve.front()[0].get<std::uint64_t>(), curve.front()[1].get<std::uint32_t>()});
      curve.pop_front();
    }
    json j = {{"type", "curve"}, {"columns", {"run", "seq", "design", "surprise"}}, {"points", curve}};
    publishState("curve", dump(j));
  }

  void onMotivation(const Motivation& m) {
    json regions = json::array();
    for (std::size_t i = 0; i < m.regions.size() && i < 500; ++i) {
      regions.push_back({{"region", m.regions[i]},
                         {"curiosity", i < m.curiosity.size() ? m.curiosity[i] : 0.0},
                         {"visits", i < m.visits.size() ? m.visits[i] : 0u}});
    }
    json j = {{"type", "motivation"},       {"experiments", m.experiments},
              {"surprise", m.surprise},     {"normalized_surprise", m.normalized_surprise},
              {"most_curious", m.most_curious}, {"regions", regions}};
    publishState("motivation", dump(j));
  }

  void onNotions(const Notions& n) {
    json list = json::array();
    for (std::size_t i = 0; i < n.notions.size() && i < 500; ++i) {
      const auto& x = n.notions[i];
      list.push_back({{"subject", x.subject},       {"predicate", x.predicate}, {"value", x.value},
                      {"confidence", x.confidence}, {"support", x.support},     {"text", x.text}});
    }
    publishState("notions", dump({{"type", "notions"}, {"samples", n.samples}, {"notions", list}}));
  }

  void onExperiment(const ExperimentProgress& p) {
    json j = {{"type", "experiment"},  {"experiment", p.experiment},     {"state", p.state},
              {"phase", p.phase},      {"kind", p.kind},                 {"phase_number", p.phase_number},
              {"phases", p.phases},    {"experiments_done", p.experiments_done}, {"experiments", p.experiments},
              {"goals", p.goals},      {"elapsed", p.elapsed},           {"seconds_left", p.seconds_left},
              {"text", p.text}};
    publishState("experiment", dump(j));
  }

  // ---- network side ------------------------------------------------------------------------------------
  void postPump() {
    std::lock_guard<std::mutex> lock(post_mutex);
    if (!accepting || pump_posted.exchange(true)) return;
    boost::asio::post(server->get_io_service(), [this] { pump(); });
  }

  /// Network thread: hand the newest messages to every client's queue, then send what may go.
  void pump() {
    pump_posted = false;
    std::vector<std::pair<std::string, core::WebPayload>> state;
    core::WebPayload frame;
    {
      std::lock_guard<std::mutex> lock(latest_mutex);
      for (const auto& key : dirty) state.emplace_back(key, latest[key]);
      dirty.clear();
      if (frame_dirty) frame = latest_frame;
      frame_dirty = false;
    }
    for (auto& [hdl, client] : clients) {
      for (const auto& [key, payload] : state) client->queue.offer(key, payload);
      if (frame.data) client->queue.offerFrame(frame);
    }
    flush();
  }

  void flush() {
    const double now = steadyNow();
    double next = -1;
    for (auto& [hdl, client] : clients) {
      websocketpp::lib::error_code ec;
      auto con = server->get_con_from_hdl(hdl, ec);
      if (ec || con->get_state() != websocketpp::session::state::open) continue;
      for (auto& payload : client->queue.take(now, con->get_buffered_amount())) {
        ec = con->send(*payload.data, payload.binary ? websocketpp::frame::opcode::binary
                                                     : websocketpp::frame::opcode::text);
        if (ec) break;
      }
      const double due = client->queue.nextDue(now);
      if (due >= 0 && (next < 0 || due < next)) next = due;
    }
    if (next >= 0) armDue(now + next);
  }

  void armDue(double at) {
    if (due_at >= 0 && due_at <= at) return;  // an earlier wake-up is armed already
    due_at = at;
    due_timer->expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(std::max(0.0, at - steadyNow()))));
    due_timer->async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;
      due_at = -1;
      flush();
    });
  }

  void armHousekeeping() {
    housekeeping->expires_after(std::chrono::milliseconds(20));
    housekeeping->async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;
      houseKeep();
      armHousekeeping();
    });
  }

  /// Every 20 ms: send what waited for a socket to drain, drop clients that stopped reading, refresh ~status.
  void houseKeep() {
    const double now = steadyNow();
    std::vector<std::pair<Hdl, std::string>> stalled;
    std::size_t queued_total = 0;
    for (auto& [hdl, client] : clients) {
      websocketpp::lib::error_code ec;
      auto con = server->get_con_from_hdl(hdl, ec);
      if (ec || con->get_state() != websocketpp::session::state::open) continue;
      const std::size_t queued = con->get_buffered_amount();
      queued_total += queued;
      std::string why = client->queue.stalled(now, queued);
      if (!why.empty()) stalled.emplace_back(hdl, why);
    }
    for (const auto& [hdl, why] : stalled) {
      auto it = clients.find(hdl);
      if (it == clients.end()) continue;
      ROS_WARN("%s: disconnecting web client %llu (%s): %s", owner.name().c_str(),
               static_cast<unsigned long long>(it->second->id), it->second->remote.c_str(), why.c_str());
      ++disconnected_stalled;
      websocketpp::lib::error_code ec;
      auto con = server->get_con_from_hdl(hdl, ec);
      clients.erase(it);  // its queue goes now; the socket after the close handshake times out
      if (!ec) con->close(core::web_close::kPolicy, "not reading", ec);
    }
    flush();
    char text[256];
    std::snprintf(text, sizeof text, "listening on %s:%d; %zu clients, %zu bytes waiting in their sockets; %llu frames in; "
                  "%llu dropped for not reading, %llu closed for bad messages, %llu refused (full)",
                  address.c_str(), boundPort(), clients.size(), queued_total,
                  static_cast<unsigned long long>(frames_in.load()), static_cast<unsigned long long>(disconnected_stalled),
                  static_cast<unsigned long long>(closed_bad_messages), static_cast<unsigned long long>(refused_full));
    std::lock_guard<std::mutex> lock(summary_mutex);
    summary = text;
  }

  int bound = 0;
  int boundPort() const { return bound; }

  void refuse(Hdl hdl, std::uint16_t code, const std::string& why) {
    auto it = clients.find(hdl);
    const std::string who = it == clients.end() ? "?" : std::to_string(it->second->id) + " (" + it->second->remote + ")";
    ROS_WARN_THROTTLE(1.0, "%s: web client %s: %s; closing with code %u", owner.name().c_str(), who.c_str(),
                      why.c_str(), code);
    ++closed_bad_messages;
    if (it != clients.end()) clients.erase(it);
    websocketpp::lib::error_code ec;
    // A close reason is at most 123 bytes (RFC 6455).
    server->close(hdl, code, why.substr(0, 120), ec);
  }

  void onMessage(Hdl hdl, Server::message_ptr msg) {
    auto it = clients.find(hdl);
    if (it == clients.end()) return;
    auto client = it->second;
    if (!client->queue.allowIncoming(steadyNow())) {
      refuse(hdl, core::web_close::kPolicy,
             "too many messages (more than " + core::describeNumber(limits.client_messages_per_second) + " a second)");
      return;
    }
    core::WebClientRequest request;
    core::WebClientError error = core::parseClientMessage(
        msg->get_payload(), msg->get_opcode() != websocketpp::frame::opcode::text, limits, request);
    if (!error.code) error = core::checkCommandAllowed(request, allow_commands, token);
    if (error.code) {
      refuse(hdl, error.code, error.reason);
      return;
    }
    websocketpp::lib::error_code ec;
    switch (request.kind) {
      case core::WebClientRequest::Kind::Config:
        if (request.has_rate) client->queue.setRate(request.rate);  // checked by the parser
        server->send(hdl, dump({{"type", "config"}, {"id", request.id}, {"rate", client->queue.rate()}}),
                     websocketpp::frame::opcode::text, ec);
        break;
      case core::WebClientRequest::Kind::Ping:
        server->send(hdl, dump({{"type", "pong"}, {"id", request.id}, {"wall_time", ros::WallTime::now().toSec()}}),
                     websocketpp::frame::opcode::text, ec);
        break;
      case core::WebClientRequest::Kind::Command: {
        std::lock_guard<std::mutex> lock(jobs_mutex);
        if (jobs.size() >= 8) {
          server->send(hdl, dump({{"type", "command_result"}, {"id", request.id}, {"command", request.command},
                                  {"success", false}, {"message", "the bridge is busy with earlier commands; try again"}}),
                       websocketpp::frame::opcode::text, ec);
        } else {
          jobs.push_back({hdl, request.command, request.id});
          jobs_cv.notify_one();
        }
        break;
      }
    }
  }

  void work() {
    for (;;) {
      CommandJob job;
      {
        std::unique_lock<std::mutex> lock(jobs_mutex);
        jobs_cv.wait(lock, [this] { return jobs_stop || !jobs.empty(); });
        if (jobs_stop) return;
        job = jobs.front();
        jobs.pop_front();
      }
      const std::string service = ns + "/loop_model/" + job.command;
      std_srvs::Trigger call;
      bool called = ros::service::exists(service, false) && ros::service::call(service, call);
      json answer = {{"type", "command_result"},
                     {"id", job.id},
                     {"command", job.command},
                     {"success", called && call.response.success},
                     {"message", called ? call.response.message : service + " is not offered (is LOOPMODEL running?)"}};
      ROS_INFO("%s: a web client's %s: %s", owner.name().c_str(), job.command.c_str(),
               answer["message"].get<std::string>().c_str());
      std::string text = dump(answer);
      std::lock_guard<std::mutex> lock(post_mutex);
      if (!accepting) continue;
      boost::asio::post(server->get_io_service(), [this, hdl = job.hdl, text] {
        if (clients.count(hdl) == 0) return;
        websocketpp::lib::error_code ec;
        server->send(hdl, text, websocketpp::frame::opcode::text, ec);
      });
    }
  }

  void onHttp(Hdl hdl) {
    auto con = server->get_con_from_hdl(hdl);
    std::string path = con->get_resource();
    const auto query = path.find('?');
    if (query != std::string::npos) path = path.substr(0, query);
    if (con->get_request().get_method() != "GET" && con->get_request().get_method() != "HEAD") {
      con->set_status(websocketpp::http::status_code::method_not_allowed);
      con->set_body("only GET\n");
      return;
    }
    if (path == "/stats") {
      con->set_status(websocketpp::http::status_code::ok);
      con->append_header("Content-Type", "application/json");
      con->append_header("Cache-Control", "no-store");
      con->set_body(stats());
      return;
    }
    auto it = assets.find(path);
    if (it == assets.end()) {
      con->set_status(websocketpp::http::status_code::not_found);
      con->append_header("Content-Type", "text/plain; charset=utf-8");
      con->set_body("not found: the bridge serves /, /app.js, /style.css, /three/... and /stats\n");
      return;
    }
    con->set_status(static_cast<websocketpp::http::status_code::value>(it->second.status));
    con->append_header("Content-Type", it->second.type);
    con->append_header("Cache-Control", "no-cache");
    con->set_body(it->second.body);
  }

  std::string stats() {
    json list = json::array();
    for (auto& [hdl, client] : clients) {
      websocketpp::lib::error_code ec;
      auto con = server->get_con_from_hdl(hdl, ec);
      const auto& s = client->queue.stats();
      list.push_back({{"id", client->id},
                      {"remote", client->remote},
                      {"rate", client->queue.rate()},
                      {"frames_offered", s.frames_offered},
                      {"frames_sent", s.frames_sent},
                      {"frames_dropped", s.frames_dropped},
                      {"messages_sent", s.messages_sent},
                      {"bytes_sent", s.bytes_sent},
                      {"socket_queued_bytes", ec ? 0 : con->get_buffered_amount()},
                      {"pending_bytes", client->queue.pendingBytes()}});
    }
    return dump({{"frames_in", frames_in.load()},
                 {"clients", list},
                 {"send_window", limits.send_window},
                 {"disconnected_not_reading", disconnected_stalled},
                 {"closed_bad_messages", closed_bad_messages},
                 {"refused_full", refused_full}});
  }

  void start() {
    server = std::make_unique<Server>();
    server->clear_access_channels(websocketpp::log::alevel::all);
    server->clear_error_channels(websocketpp::log::elevel::all);  // its failures reach our handlers, logged there
    websocketpp::lib::error_code ec;
    server->init_asio(ec);
    if (ec) throw std::runtime_error("cannot start the web server: " + ec.message());
    server->set_reuse_addr(true);
    server->set_max_message_size(limits.max_client_message);
    server->set_max_http_body_size(1024);
    server->set_open_handshake_timeout(5000);
    server->set_close_handshake_timeout(2000);
    server->set_listen_backlog(64);
    server->set_tcp_init_handler([this](Hdl hdl) {
      websocketpp::lib::error_code e;
      auto con = server->get_con_from_hdl(hdl, e);
      if (e) return;
      boost::system::error_code be;
      con->get_socket().set_option(boost::asio::ip::tcp::no_delay(true), be);
      con->get_socket().set_option(
          boost::asio::socket_base::send_buffer_size(static_cast<int>(socket_send_buffer)), be);
    });
    server->set_validate_handler([this](Hdl hdl) {
      if (static_cast<int>(clients.size()) < max_clients) return true;
      ++refused_full;
      ROS_WARN_THROTTLE(1.0, "%s: refusing a web client: %d clients already (~max_clients)", owner.name().c_str(),
                        max_clients);
      auto con = server->get_con_from_hdl(hdl);
      con->set_status(websocketpp::http::status_code::service_unavailable);
      con->set_body("too many clients (~max_clients)\n");
      return false;
    });
    server->set_open_handler([this](Hdl hdl) {
      auto client = std::make_shared<Client>(limits);
      client->id = next_client_id++;
      client->connected = steadyNow();
      websocketpp::lib::error_code e;
      auto con = server->get_con_from_hdl(hdl, e);
      if (!e) client->remote = con->get_remote_endpoint();
      {
        std::lock_guard<std::mutex> lock(latest_mutex);
        for (const auto& [key, payload] : latest) client->queue.offer(key, payload);
        if (latest_frame.data) client->queue.offerFrame(latest_frame);
      }
      clients[hdl] = client;
      ROS_INFO("%s: web client %llu connected from %s (%zu now)", owner.name().c_str(),
               static_cast<unsigned long long>(client->id), client->remote.c_str(), clients.size());
      flush();
    });
    auto gone = [this](Hdl hdl, const char* how) {
      websocketpp::lib::error_code e;
      auto con = server->get_con_from_hdl(hdl, e);
      auto it = clients.find(hdl);
      if (it == clients.end()) return;  // refused or dropped already, and logged then
      std::string detail;
      if (!e) {
        detail = "local code " + std::to_string(con->get_local_close_code());
        if (!con->get_local_close_reason().empty()) detail += " '" + con->get_local_close_reason() + "'";
        detail += ", remote code " + std::to_string(con->get_remote_close_code());
        if (con->get_ec()) detail += ", " + con->get_ec().message();
      }
      // The library closes an oversized message itself (1009): that is a bad message too, and logged as one.
      if (!e && con->get_local_close_code() == websocketpp::close::status::message_too_big) {
        ++closed_bad_messages;
        ROS_WARN_THROTTLE(1.0, "%s: web client %llu (%s) sent a message over ~max_client_message (%zu bytes): %s",
                          owner.name().c_str(), static_cast<unsigned long long>(it->second->id),
                          it->second->remote.c_str(), limits.max_client_message, detail.c_str());
      } else {
        ROS_INFO("%s: web client %llu (%s) %s (%s)", owner.name().c_str(),
                 static_cast<unsigned long long>(it->second->id), it->second->remote.c_str(), how, detail.c_str());
      }
      clients.erase(it);
    };
    server->set_close_handler([gone](Hdl hdl) { gone(hdl, "closed"); });
    server->set_fail_handler([gone](Hdl hdl) { gone(hdl, "failed"); });
    server->set_message_handler([this](Hdl hdl, Server::message_ptr msg) {
      try {
        onMessage(hdl, msg);
      } catch (const std::exception& e) {  // never out of the network thread
        refuse(hdl, core::web_close::kInvalidPayload, e.what());
      }
    });
    server->set_http_handler([this](Hdl hdl) { onHttp(hdl); });

    boost::system::error_code be;
    const boost::asio::ip::tcp::endpoint endpoint(boost::asio::ip::make_address(address, be),
                                                  static_cast<unsigned short>(port));
    server->listen(endpoint, ec);
    if (ec) {
      server.reset();
      throw std::runtime_error("cannot listen on " + address + ":" + std::to_string(port) + ": " + ec.message());
    }
    bound = server->get_local_endpoint(be).port();
    server->start_accept(ec);
    if (ec) {
      server.reset();
      throw std::runtime_error("cannot accept on " + address + ":" + std::to_string(port) + ": " + ec.message());
    }
    housekeeping = std::make_unique<boost::asio::steady_timer>(server->get_io_service());
    due_timer = std::make_unique<boost::asio::steady_timer>(server->get_io_service());
    due_at = -1;
    armHousekeeping();
    network = std::thread([this] {
      for (;;) {
        try {
          server->run();
          return;
        } catch (const std::exception& e) {  // a handler that threw: log it, keep serving
          ROS_ERROR("%s: network thread: %s", owner.name().c_str(), e.what());
        }
      }
    });
    {
      std::lock_guard<std::mutex> lock(jobs_mutex);
      jobs_stop = false;
    }
    worker = std::thread([this] { work(); });
    {
      std::lock_guard<std::mutex> lock(post_mutex);
      accepting = true;
      pump_posted = false;
    }
    ROS_INFO("%s: serving http://%s:%d/ (commands %s)", owner.name().c_str(), address.c_str(), bound,
             allow_commands ? "on, with a token" : "off: read-only");
  }

  void stop() {
    {
      std::lock_guard<std::mutex> lock(post_mutex);
      accepting = false;
    }
    {
      std::lock_guard<std::mutex> lock(jobs_mutex);
      jobs_stop = true;
    }
    jobs_cv.notify_all();
    if (worker.joinable()) worker.join();
    jobs.clear();
    if (!server) return;
    boost::asio::post(server->get_io_service(), [this] {
      websocketpp::lib::error_code ec;
      server->stop_listening(ec);
      housekeeping->cancel();
      due_timer->cancel();
      for (auto& [hdl, client] : clients) server->close(hdl, core::web_close::kGoingAway, "the bridge stops", ec);
      clients.clear();
    });
    // The close handshakes get a moment; then the loop stops whatever is left.
    for (int i = 0; i < 20 && !server->stopped(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    server->stop();
    if (network.joinable()) network.join();
    housekeeping.reset();
    due_timer.reset();
    clients.clear();
    server.reset();
    bound = 0;
    std::lock_guard<std::mutex> lock(summary_mutex);
    summary = "not listening";
  }
};

WebBridge::WebBridge(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/WebBridgeNodelet"), impl_(std::make_unique<Impl>(*this)) {}

WebBridge::~WebBridge() {
  impl_->unsubscribe();
  impl_->stop();
}

const core::ParameterTable& WebBridge::parameters() {
  using core::ParameterSpec;
  static const core::ParameterTable table(
      "web_bridge",
      {core::textParameter("address", "127.0.0.1", "the IP address the WebSocket and HTTP server binds"),
       core::intParameter("port", 8765, 0, 65535, "its port (0: any free one)"),
       core::derivedParameter(ParameterSpec::Type::String, "ns", "the component's namespace", 0, INFINITY,
                              "the namespace of the system it shows (its XPERSim, LOOPMODEL, ...)"),
       core::numberParameter("rate", 30.0, 0.0, 10000.0, "Hz: a client's default frame rate (at most ~max_rate)"),
       core::numberParameter("max_rate", 1000.0, 1.0, 10000.0, "Hz: the highest frame rate a client may ask for"),
       core::numberParameter("send_window", 262144.0, 1024.0, 256.0 * 1024 * 1024,
                             "bytes queued per client before frames are dropped for it"),
       core::numberParameter("socket_send_buffer", 65536.0, 4096.0, 64.0 * 1024 * 1024, "bytes of each socket's send buffer"),
       core::numberParameter("stall_timeout", 10.0, 0.1, 3600.0, "s of wall time a client may not read before it is closed"),
       core::intParameter("max_clients", 128, 1, 10000, "clients at once"),
       core::numberParameter("max_client_message", 4096.0, 64.0, 1024.0 * 1024, "bytes of a client's message at most"),
       core::numberParameter("client_messages_per_second", 20.0, 0.1, 10000.0, "a client's messages per second at most"),
       core::intParameter("curve_points", 2000, 1, 1000000, "points of the learning curve kept for new clients"),
       core::flagParameter("allow_commands", false, "let clients that know ~token pause, resume and confirm the loop"),
       core::textParameter("token", "", "the secret ~allow_commands asks for (at least 8 characters)"),
       core::derivedParameter(ParameterSpec::Type::String, "web_root", "the package's web/", 0, INFINITY,
                              "the directory of the page and its npm modules"),
       core::textParameter("experiment_progress_topic", "/experiment/progress", "the experiment runner's progress")});
  return table;
}

void WebBridge::onConfigure() { impl_->configure(privateNodeHandle(), nodeHandle()); }

void WebBridge::onActivate() {
  impl_->start();
  privateNodeHandle().setParam("bound_port", impl_->bound);
  impl_->subscribe(nodeHandle());
}

void WebBridge::onDeactivate() {
  impl_->unsubscribe();
  impl_->stop();
}

void WebBridge::onShutdown() { onDeactivate(); }

void WebBridge::fillStatus(ComponentStatus& status) {
  PartStatus part;
  part.name = "server";
  part.state = status.state;
  part.state_name = status.state_name;
  part.health = ComponentStatus::HEALTH_OK;
  {
    std::lock_guard<std::mutex> lock(impl_->summary_mutex);
    part.message = impl_->summary;
  }
  status.parts.push_back(part);
}

}  // namespace xpersif
