#include "xpersif/core/web/web_stream.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

constexpr char kFrameMagic[4] = {'X', 'P', 'F', '1'};
constexpr std::size_t kFrameHeader = 4 + 4 + 8 + 8 + 8 + 4;

template <class T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // x86-64 and ARM (the machines ROS runs on here) are little-endian
  out.append(bytes, sizeof(T));
}

template <class T>
T get(const std::string& in, std::size_t& at) {
  T value;
  std::memcpy(&value, in.data() + at, sizeof(T));
  at += sizeof(T);
  return value;
}

double periodOf(double rate, double max_rate) { return 1.0 / (rate > 0 ? rate : max_rate); }

}  // namespace

// ---- WebClientQueue ----------------------------------------------------------------------------------

WebClientQueue::WebClientQueue(WebClientLimits limits)
    : limits_(limits), rate_(limits.default_rate), tokens_(2 * limits.client_messages_per_second) {}

void WebClientQueue::setRate(double hz) {
  if (!std::isfinite(hz) || hz < 0 || hz > limits_.max_rate) {
    throw ValidationError("rate " + describeNumber(hz) + " is out of range; it must be a number of frames per second in 0.1.." +
                          describeNumber(limits_.max_rate) + ", or \"full\" for every frame");
  }
  if (hz > 0 && hz < 0.1) hz = 0.1;
  rate_ = hz;
  next_frame_ = -1e300;
}

void WebClientQueue::offer(const std::string& key, WebPayload payload) {
  if (key == "scene") {
    scene_ = std::move(payload);
    scene_sent_ = false;
    if (frame_.data) {
      frame_ = WebPayload();
      ++stats_.frames_dropped;
    }
    return;
  }
  auto& slot = state_[key];
  if (slot.data) ++stats_.state_replaced;
  slot = std::move(payload);
}

void WebClientQueue::offerFrame(WebPayload payload) {
  ++stats_.frames_offered;
  if (frame_.data) ++stats_.frames_dropped;
  frame_ = std::move(payload);
}

std::vector<WebPayload> WebClientQueue::take(double now, std::size_t queued_bytes) {
  std::vector<WebPayload> out;
  std::size_t queued = queued_bytes;
  auto fits = [&](std::size_t size) { return queued == 0 || queued + size <= limits_.send_window; };
  auto send = [&](WebPayload& p) {
    queued += p.size();
    ++stats_.messages_sent;
    stats_.bytes_sent += p.size();
    out.push_back(std::move(p));
    p = WebPayload();
  };
  if (scene_.data) {
    if (!fits(scene_.size())) return out;  // nothing goes before the scene
    send(scene_);
    scene_sent_ = true;
  }
  for (auto it = state_.begin(); it != state_.end();) {
    if (!fits(it->second.size())) return out;  // keep the order: later keys wait too
    send(it->second);
    it = state_.erase(it);
  }
  if (frame_.data && scene_sent_) {
    const double period = periodOf(rate_, limits_.max_rate);
    // A quarter period of slack: frames that come exactly at the client's rate, with jitter, all go.
    if (now + 0.25 * period >= next_frame_ && fits(frame_.size())) {
      // On schedule: the next slot one period on (the average rate holds); after a gap: one period from now.
      next_frame_ = next_frame_ + period < now ? now + period : next_frame_ + period;
      ++stats_.frames_sent;
      send(frame_);
    }
  }
  return out;
}

double WebClientQueue::nextDue(double now) const {
  if (scene_.data || !state_.empty()) return 0;
  if (!frame_.data || !scene_sent_) return -1;
  const double period = periodOf(rate_, limits_.max_rate);
  return std::max(0.0, next_frame_ - 0.25 * period - now);
}

std::string WebClientQueue::stalled(double now, std::size_t queued_bytes) {
  if (progress_time_ < 0 || queued_bytes == 0 || queued_bytes < last_queued_) progress_time_ = now;
  last_queued_ = queued_bytes;
  if (queued_bytes > 0 && now - progress_time_ > limits_.stall_timeout) {
    return "the client stopped reading: " + std::to_string(queued_bytes) + " bytes have waited in its socket for " +
           describeNumber(std::round(now - progress_time_)) + " s (~stall_timeout " +
           describeNumber(limits_.stall_timeout) + " s)";
  }
  return "";
}

bool WebClientQueue::allowIncoming(double now) {
  const double rate = limits_.client_messages_per_second;
  const double capacity = 2 * rate;
  if (tokens_time_ >= 0) tokens_ = std::min(capacity, tokens_ + (now - tokens_time_) * rate);
  tokens_time_ = now;
  if (tokens_ < 1) return false;
  tokens_ -= 1;
  return true;
}

std::size_t WebClientQueue::pendingBytes() const {
  std::size_t bytes = scene_.size() + frame_.size();
  for (const auto& [key, p] : state_) bytes += p.size();
  return bytes;
}

std::size_t WebClientQueue::pendingMessages() const {
  return (scene_.data ? 1 : 0) + (frame_.data ? 1 : 0) + state_.size();
}

// ---- client messages -----------------------------------------------------------------------------------

namespace {

WebClientError error(std::uint16_t code, std::string reason) { return WebClientError{code, std::move(reason)}; }

bool readId(const nlohmann::json& j, WebClientRequest& request, WebClientError& err) {
  if (!j.contains("id")) return true;
  const auto& id = j.at("id");
  if (id.is_string()) {
    request.id = id.get<std::string>();
  } else if (id.is_number_integer()) {
    request.id = std::to_string(id.get<long long>());
  } else {
    err = error(web_close::kInvalidPayload, "\"id\" must be a string or an integer");
    return false;
  }
  if (const std::string why = checkMaxLength("\"id\"", request.id, 64); !why.empty()) {
    err = error(web_close::kInvalidPayload, why);
    return false;
  }
  return true;
}

WebClientError onlyKeys(const nlohmann::json& j, const std::vector<std::string>& allowed, const std::string& type) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (std::find(allowed.begin(), allowed.end(), it.key()) == allowed.end()) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      std::string key = it.key().substr(0, 40);
      return error(web_close::kPolicy, "unexpected key \"" + key + "\" in a " + type + " message; its keys are " + list);
    }
  }
  return {};
}

}  // namespace

WebClientError parseClientMessage(const std::string& text, bool binary, const WebClientLimits& limits,
                                  WebClientRequest& request) {
  request = WebClientRequest();
  if (binary) return error(web_close::kUnsupportedData, "binary messages are not understood; send JSON text");
  if (text.size() > limits.max_client_message) {
    return error(web_close::kTooBig, "a message of " + std::to_string(text.size()) + " bytes is over the limit of " +
                                         std::to_string(limits.max_client_message) + " bytes");
  }
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    return error(web_close::kInvalidPayload, "not JSON (at byte " + std::to_string(e.byte) + ")");
  }
  if (!j.is_object()) return error(web_close::kInvalidPayload, "a message must be a JSON object with a \"type\"");
  if (!j.contains("type") || !j.at("type").is_string()) {
    return error(web_close::kInvalidPayload, "a message must have a string \"type\": config, command or ping");
  }
  const std::string type = j.at("type").get<std::string>();
  WebClientError err;
  if (type == "config") {
    request.kind = WebClientRequest::Kind::Config;
    if (err = onlyKeys(j, {"type", "rate", "id"}, "config"); err.code) return err;
    if (j.contains("rate")) {
      const auto& rate = j.at("rate");
      if (rate.is_string() && rate.get<std::string>() == "full") {
        request.rate = 0;
      } else if (rate.is_number()) {
        request.rate = rate.get<double>();
        if (!(request.rate >= 0.1 && request.rate <= limits.max_rate)) {  // also NaN (a number only in theory here)
          return error(web_close::kInvalidPayload, "\"rate\" " + describeNumber(request.rate) +
                                                       " is out of range; it must be 0.1.." +
                                                       describeNumber(limits.max_rate) + " frames per second or \"full\"");
        }
      } else {
        return error(web_close::kInvalidPayload, "\"rate\" must be a number of frames per second or \"full\"");
      }
      request.has_rate = true;
    }
  } else if (type == "command") {
    request.kind = WebClientRequest::Kind::Command;
    if (err = onlyKeys(j, {"type", "command", "token", "id"}, "command"); err.code) return err;
    if (!j.contains("command") || !j.at("command").is_string()) {
      return error(web_close::kInvalidPayload, "a command message needs a string \"command\": pause, resume or confirm");
    }
    request.command = j.at("command").get<std::string>();
    if (request.command != "pause" && request.command != "resume" && request.command != "confirm") {
      return error(web_close::kPolicy, "unknown command \"" + request.command.substr(0, 40) +
                                           "\"; the commands are pause, resume and confirm");
    }
    if (j.contains("token")) {
      if (!j.at("token").is_string()) return error(web_close::kInvalidPayload, "\"token\" must be a string");
      request.token = j.at("token").get<std::string>();
    }
  } else if (type == "ping") {
    request.kind = WebClientRequest::Kind::Ping;
    if (err = onlyKeys(j, {"type", "id"}, "ping"); err.code) return err;
  } else {
    return error(web_close::kPolicy, "unknown message type \"" + type.substr(0, 40) + "\"; the types are config, command and ping");
  }
  if (!readId(j, request, err)) return err;
  return {};
}

WebClientError checkCommandAllowed(const WebClientRequest& request, bool allow_commands, const std::string& token) {
  if (request.kind != WebClientRequest::Kind::Command) return {};
  if (!allow_commands) {
    return error(web_close::kPolicy, "this bridge is read-only: commands are off (~allow_commands is false)");
  }
  // Constant time in the token's content: no early exit on the first differing byte.
  unsigned char diff = token.empty() || request.token.size() != token.size() ? 1 : 0;
  for (std::size_t i = 0; i < request.token.size(); ++i) {
    diff |= static_cast<unsigned char>(request.token[i] ^ token[i % std::max<std::size_t>(1, token.size())]);
  }
  if (diff) return error(web_close::kPolicy, "the command's token is wrong");
  return {};
}

// ---- scene and frames ----------------------------------------------------------------------------------

namespace {

nlohmann::json transformJson(const Eigen::Isometry3d& t) {
  const Eigen::Quaterniond q(t.rotation());
  const Eigen::Vector3d p = t.translation();
  return {{"t", {p.x(), p.y(), p.z()}}, {"q", {q.x(), q.y(), q.z(), q.w()}}};
}

std::string baseName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

}  // namespace

std::vector<std::string> frameNodes(const SceneDescription& scene) {
  std::vector<std::string> names;
  for (const auto& node : scene.nodes) {
    if (node.dynamic) names.push_back(node.name);
  }
  return names;
}

std::string sceneToJson(const SceneDescription& scene, std::uint32_t generation) {
  nlohmann::json nodes = nlohmann::json::array();
  for (const auto& node : scene.nodes) {
    nlohmann::json visuals = nlohmann::json::array();
    for (const auto& v : node.visuals) {
      nlohmann::json shape = transformJson(v.offset);
      switch (v.shape.type) {
        case Shape::Type::Box:
          shape["type"] = "box";
          shape["size"] = {v.shape.box_size.x(), v.shape.box_size.y(), v.shape.box_size.z()};
          break;
        case Shape::Type::Cylinder:
          shape["type"] = "cylinder";
          shape["radius"] = v.shape.radius;
          shape["length"] = v.shape.length;
          break;
        case Shape::Type::Sphere:
          shape["type"] = "sphere";
          shape["radius"] = v.shape.radius;
          break;
      }
      shape["color"] = {v.color.r, v.color.g, v.color.b, v.color.a};
      visuals.push_back(shape);
    }
    nlohmann::json n = transformJson(node.parent_from_node);
    n["name"] = node.name;
    n["parent"] = node.parent;
    n["dynamic"] = node.dynamic;
    n["visuals"] = visuals;
    nodes.push_back(n);
  }
  nlohmann::json cameras = nlohmann::json::array();
  for (const auto& c : scene.cameras) {
    cameras.push_back({{"name", c.name}, {"frame", c.frame}, {"width", c.width}, {"height", c.height}, {"fx", c.fx},
                       {"fy", c.fy}, {"cx", c.cx}, {"cy", c.cy}});
  }
  nlohmann::json j = {{"type", "scene"},
                      {"generation", generation},
                      {"world_frame", scene.world_frame},
                      {"world_file", baseName(scene.world_file)},
                      {"robot_root", scene.robot_root},
                      {"robot_marker", scene.robot_marker},
                      {"objects", scene.objects},
                      {"arena", {scene.arena_size_x, scene.arena_size_y}},
                      {"nodes", nodes},
                      {"cameras", cameras},
                      {"frame_nodes", frameNodes(scene)}};
  return dumpJson(j);
}

std::string encodeFrame(const WebFrame& frame) {
  if (frame.poses.size() % 7 != 0) {
    throw ValidationError("a frame's poses must come in sevens (x y z qx qy qz qw), not " +
                          std::to_string(frame.poses.size()) + " numbers");
  }
  std::string out;
  out.reserve(kFrameHeader + frame.poses.size() * 4);
  out.append(kFrameMagic, 4);
  put<std::uint32_t>(out, frame.generation);
  put<std::uint64_t>(out, frame.seq);
  put<double>(out, frame.sim_time);
  put<double>(out, frame.wall_time);
  put<std::uint32_t>(out, static_cast<std::uint32_t>(frame.poses.size() / 7));
  for (float f : frame.poses) put<float>(out, f);
  return out;
}

WebFrame decodeFrame(const std::string& bytes) {
  if (bytes.size() < kFrameHeader || std::memcmp(bytes.data(), kFrameMagic, 4) != 0) {
    throw ValidationError("not a frame: " + std::to_string(bytes.size()) + " bytes without the XPF1 header");
  }
  std::size_t at = 4;
  WebFrame frame;
  frame.generation = get<std::uint32_t>(bytes, at);
  frame.seq = get<std::uint64_t>(bytes, at);
  frame.sim_time = get<double>(bytes, at);
  frame.wall_time = get<double>(bytes, at);
  const auto n = get<std::uint32_t>(bytes, at);
  if (bytes.size() != kFrameHeader + std::size_t{n} * 28) {
    throw ValidationError("a frame of " + std::to_string(n) + " nodes must be " + std::to_string(kFrameHeader + n * 28) +
                          " bytes, not " + std::to_string(bytes.size()));
  }
  frame.poses.resize(std::size_t{n} * 7);
  for (auto& f : frame.poses) f = get<float>(bytes, at);
  return frame;
}

std::string jsonString(const std::string& text) { return dumpJson(nlohmann::json(text)); }

std::string dumpJson(const nlohmann::json& j) { return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace); }

}  // namespace xpersif::core
