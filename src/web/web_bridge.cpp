#include "xpersif/web/web_bridge.h"

#include "xpersif/component/parameter_reader.h"

#include <ros/package.h>
#include <std_srvs/Trigger.h>
#include <tf2_msgs/TFMessage.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <deque>
#include <map>
#include <mutex>
#include <set>

#include "xpersif/ExperimentProgress.h"
#include "xpersif/ExperimentRecord.h"
#include "xpersif/Motivation.h"
#include "xpersif/Notions.h"
#include "xpersif/RunLoopActionGoal.h"
#include "xpersif/RunLoopFeedback.h"
#include "xpersif/Scene.h"
#include "xpersif/core/web/foxglove_protocol.h"
#include "xpersif/core/web/web_page.h"
#include "xpersif/core/web/web_server.h"
#include "xpersif/core/web/web_stream_protocol.h"
#include "xpersif/ros/conversions.h"
#include "xpersif/web/foxglove_topics.h"

namespace xpersif {

namespace {

using json = nlohmann::json;

core::WebPayload textPayload(const std::string& s) { return {std::make_shared<const std::string>(s), false}; }

/// @p name under @p ns unless it is global.
std::string underNamespace(const std::string& ns, const std::string& name) {
  return !name.empty() && name.front() == '/' ? name : ns + "/" + name;
}

}  // namespace

// The topics become the page's messages here; the core's WebServer and WebStreamProtocol carry them to the
// clients, and hand a client's command back here (runCommand) to become a LOOPMODEL service call.
struct WebBridge::Impl {
  explicit Impl(WebBridge& owner)
      : owner(owner),
        server([this](core::WebLogLevel level, const std::string& text) { log(level, text); }),
        protocol(server, [this](const std::string& command) { return runCommand(command); }),
        foxglove(server, "xpersif WEBBRIDGE",
                 [this](std::uint32_t channel, bool wanted) { foxglove_topics.interestChanged(channel, wanted); }),
        foxglove_topics(foxglove, owner.name()) {
    server.addProtocol(protocol);
    server.addProtocol(foxglove, core::kFoxgloveSubprotocol);
  }

  WebBridge& owner;

  // ---- configuration (set on configure, read-only while active) ----
  core::WebServerOptions options;
  std::string ns;
  std::size_t curve_points = 2000;
  bool allow_commands = false;
  std::string token;
  std::string web_root;
  std::string experiment_progress_topic = "/experiment/progress";
  core::WebSite site;
  FoxgloveTopics::Options foxglove_options;

  // ---- the scene and the loop's state (ROS callbacks; state_mutex) ----
  std::mutex state_mutex;
  std::uint32_t generation = 0;
  std::map<std::string, std::size_t> frame_index;  // dynamic node -> its slot in a frame
  std::vector<float> poses;                        // 7 per dynamic node
  std::uint64_t frame_seq = 0;
  json loop = json::object();
  std::deque<json> curve;
  std::set<std::pair<std::uint64_t, std::uint32_t>> curve_seen;

  std::vector<ros::Subscriber> subscribers;

  // Last: the protocol's worker and the server's network thread stop before anything they call goes.
  core::WebServer server;
  core::WebStreamProtocol protocol;
  core::FoxgloveProtocol foxglove;
  FoxgloveTopics foxglove_topics;

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

    const std::string address_problem = core::ipAddressProblem(new_address);
    if (!address_problem.empty()) {
      throw core::ValidationError("~address '" + new_address + "' is not an IP address (" + address_problem + ")");
    }
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

    options.address = new_address;
    options.port = new_port;
    options.limits = l;
    options.socket_send_buffer = static_cast<std::size_t>(sndbuf);
    options.max_clients = new_max_clients;
    ns = new_ns;
    curve_points = static_cast<std::size_t>(new_curve);
    allow_commands = new_allow;
    token = new_token;
    web_root = root;
    experiment_progress_topic = progress_topic;
    foxglove_options = readFoxglove(parameters);
    loadSite();
  }

  /// The Foxglove protocol's topics and cameras, under ~ns unless global (ns is read already).
  FoxgloveTopics::Options readFoxglove(const ParameterReader& parameters) const {
    FoxgloveTopics::Options o;
    for (const auto& t : parameters.get<std::vector<std::string>>("foxglove_topics")) {
      o.topics.push_back(underNamespace(ns, t));
    }
    for (const auto& c : parameters.get<std::vector<std::string>>("foxglove_cameras")) {
      o.cameras.push_back(underNamespace(ns, c));
    }
    o.image_rate = parameters.get<double>("foxglove_image_rate");
    o.jpeg_quality = parameters.get<int>("foxglove_jpeg_quality");
    core::requireInRange("~foxglove_image_rate", o.image_rate, 0.1, 100);
    core::requireInRange("~foxglove_jpeg_quality", o.jpeg_quality, 1, 100);
    return o;
  }

  void loadSite() {
    std::vector<std::string> missing;
    site = core::viewerSite(web_root, missing);
    if (!missing.empty()) {
      ROS_ERROR("%s: the page cannot be served whole; missing: %s (run `npm ci` in %s; bash scripts/setup.sh does it). "
                "The WebSocket stream works without it.",
                owner.name().c_str(), missing.front().c_str(), web_root.c_str());
    }
  }

  void log(core::WebLogLevel level, const std::string& text) {
    switch (level) {
      case core::WebLogLevel::Info:
        ROS_INFO("%s: %s", owner.name().c_str(), text.c_str());
        break;
      case core::WebLogLevel::Warn:
        ROS_WARN("%s: %s", owner.name().c_str(), text.c_str());
        break;
      case core::WebLogLevel::Error:
        ROS_ERROR("%s: %s", owner.name().c_str(), text.c_str());
        break;
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
    foxglove_topics.start(nh, foxglove_options);
  }

  void unsubscribe() {
    for (auto& s : subscribers) s.shutdown();
    subscribers.clear();
    foxglove_topics.stop();
  }

  void publishState(const std::string& key, const std::string& text) { server.publish(key, textPayload(text)); }

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
    server.publish("scene", textPayload(text));
    ROS_INFO("%s: scene of %s: %zu nodes, %zu cameras", owner.name().c_str(), message.world_file.c_str(),
             message.nodes.size(), message.cameras.size());
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
    server.publishFrame({std::make_shared<const std::string>(core::encodeFrame(frame)), true});
  }

  void publishLoopLocked() { publishState("loop", core::dumpJson(loop)); }

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
    publishState("curve", core::dumpJson(j));
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
    publishState("motivation", core::dumpJson(j));
  }

  void onNotions(const Notions& n) {
    json list = json::array();
    for (std::size_t i = 0; i < n.notions.size() && i < 500; ++i) {
      const auto& x = n.notions[i];
      list.push_back({{"subject", x.subject},       {"predicate", x.predicate}, {"value", x.value},
                      {"confidence", x.confidence}, {"support", x.support},     {"text", x.text}});
    }
    publishState("notions", core::dumpJson({{"type", "notions"}, {"samples", n.samples}, {"notions", list}}));
  }

  void onExperiment(const ExperimentProgress& p) {
    json j = {{"type", "experiment"},  {"experiment", p.experiment},     {"state", p.state},
              {"phase", p.phase},      {"kind", p.kind},                 {"phase_number", p.phase_number},
              {"phases", p.phases},    {"experiments_done", p.experiments_done}, {"experiments", p.experiments},
              {"goals", p.goals},      {"elapsed", p.elapsed},           {"seconds_left", p.seconds_left},
              {"text", p.text}};
    publishState("experiment", core::dumpJson(j));
  }

  // ---- a client's command, on the protocol's worker thread ---------------------------------------------
  core::WebCommandResult runCommand(const std::string& command) {
    const std::string service = ns + "/loop_model/" + command;
    std_srvs::Trigger call;
    const bool called = ros::service::exists(service, false) && ros::service::call(service, call);
    const core::WebCommandResult result{called && call.response.success,
                                        called ? call.response.message
                                               : service + " is not offered (is LOOPMODEL running?)"};
    ROS_INFO("%s: a web client's %s: %s", owner.name().c_str(), command.c_str(), result.message.c_str());
    return result;
  }

  void start() {
    protocol.start(allow_commands, token);
    foxglove.start();
    try {
      server.start(options, site);
    } catch (...) {
      protocol.stop();
      throw;
    }
    ROS_INFO("%s: serving http://%s:%d/ (commands %s); Foxglove and Lichtblick connect to ws://%s:%d (%s, read-only)",
             owner.name().c_str(), options.address.c_str(), server.boundPort(),
             allow_commands ? "on, with a token" : "off: read-only", options.address.c_str(), server.boundPort(),
             core::kFoxgloveSubprotocol);
  }

  void stop() {
    protocol.stop();
    server.stop();
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
       core::textParameter("experiment_progress_topic", "/experiment/progress", "the experiment runner's progress"),
       core::namesParameter("foxglove_topics",
                            {"/clock", "/tf", "/tf_static", "xpersim/markers", "xpersim/ground_truth",
                             "loop_model/progress", "machine_learning/notions"},
                            64, "topics offered to Foxglove clients as they are (relative ones under ~ns)"),
       core::namesParameter("foxglove_cameras", {"observation/image_raw", "perception/image_raw"}, 16,
                            "raw image topics offered to Foxglove clients as <topic>/compressed JPEG"),
       core::numberParameter("foxglove_image_rate", 5.0, 0.1, 100.0, "Hz of wall time: JPEGs per camera at most"),
       core::intParameter("foxglove_jpeg_quality", 80, 1, 100, "the JPEGs' quality")});
  return table;
}

void WebBridge::onConfigure() { impl_->configure(privateNodeHandle(), nodeHandle()); }

void WebBridge::onActivate() {
  impl_->start();
  privateNodeHandle().setParam("bound_port", impl_->server.boundPort());
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
  part.message = impl_->server.summary();
  status.parts.push_back(part);
}

}  // namespace xpersif
