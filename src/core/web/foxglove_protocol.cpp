#include "xpersif/core/web/foxglove_protocol.h"

#include <nlohmann/json.hpp>

#include <limits>

namespace xpersif::core {

namespace {

using json = nlohmann::json;

constexpr char kMessageData = 0x01;
constexpr char kTime = 0x02;

template <class T>
void putLittleEndian(std::string& out, T value) {
  for (std::size_t i = 0; i < sizeof(T); ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xff));
}

WebClientError refused(std::uint16_t code, std::string reason) { return {code, std::move(reason)}; }

/// @p j[field] as a u32, or false when it is missing or not one.
bool readId(const json& j, const char* field, std::uint32_t& id) {
  if (!j.is_object() || !j.contains(field) || !j.at(field).is_number_unsigned()) return false;
  const auto value = j.at(field).get<std::uint64_t>();
  if (value > std::numeric_limits<std::uint32_t>::max()) return false;
  id = static_cast<std::uint32_t>(value);
  return true;
}

WebClientError parseSubscribe(const json& j, FoxgloveRequest& request) {
  if (!j.contains("subscriptions") || !j.at("subscriptions").is_array()) {
    return refused(web_close::kInvalidPayload, "subscribe needs \"subscriptions\": [{\"id\", \"channelId\"}, ...]");
  }
  request.kind = FoxgloveRequest::Kind::Subscribe;
  for (const auto& s : j.at("subscriptions")) {
    std::uint32_t id = 0, channel = 0;
    if (!readId(s, "id", id) || !readId(s, "channelId", channel)) {
      return refused(web_close::kInvalidPayload, "each subscription needs an \"id\" and a \"channelId\" (uint32)");
    }
    request.subscribe.emplace_back(id, channel);
  }
  return {};
}

WebClientError parseUnsubscribe(const json& j, FoxgloveRequest& request) {
  if (!j.contains("subscriptionIds") || !j.at("subscriptionIds").is_array()) {
    return refused(web_close::kInvalidPayload, "unsubscribe needs \"subscriptionIds\": [...]");
  }
  request.kind = FoxgloveRequest::Kind::Unsubscribe;
  for (const auto& id : j.at("subscriptionIds")) {
    if (!id.is_number_unsigned() || id.get<std::uint64_t>() > std::numeric_limits<std::uint32_t>::max()) {
      return refused(web_close::kInvalidPayload, "\"subscriptionIds\" must be uint32 numbers");
    }
    request.unsubscribe.push_back(id.get<std::uint32_t>());
  }
  return {};
}

std::string advertiseMessage(const std::vector<FoxgloveChannel>& channels) {
  json list = json::array();
  for (const auto& c : channels) {
    list.push_back({{"id", c.id},
                    {"topic", c.topic},
                    {"encoding", c.encoding},
                    {"schemaName", c.schema_name},
                    {"schema", c.schema}});
  }
  return dumpJson({{"op", "advertise"}, {"channels", list}});
}

std::string channelKey(std::uint32_t channel, const std::string& publisher) {
  return "channel " + std::to_string(channel) + " " + publisher;
}

}  // namespace

std::string encodeFoxgloveMessage(std::uint32_t subscription, std::uint64_t stamp_ns, const std::string& message) {
  std::string out;
  out.reserve(13 + message.size());
  out.push_back(kMessageData);
  putLittleEndian(out, subscription);
  putLittleEndian(out, stamp_ns);
  out += message;
  return out;
}

std::string encodeFoxgloveTime(std::uint64_t stamp_ns) {
  std::string out(1, kTime);
  putLittleEndian(out, stamp_ns);
  return out;
}

WebClientError parseFoxgloveRequest(const std::string& data, bool binary, FoxgloveRequest& request) {
  request = FoxgloveRequest();
  if (binary) {
    return refused(web_close::kPolicy, "read-only server: clients may not publish or call services");
  }
  const json j = json::parse(data, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return refused(web_close::kInvalidPayload, "a message must be a JSON object");
  if (!j.contains("op") || !j.at("op").is_string()) {
    return refused(web_close::kInvalidPayload, "a message needs an \"op\" string");
  }
  const std::string op = j.at("op").get<std::string>();
  if (op == "subscribe") return parseSubscribe(j, request);
  if (op == "unsubscribe") return parseUnsubscribe(j, request);
  if (op == "advertise" || op == "unadvertise") {
    return refused(web_close::kPolicy, "read-only server (no clientPublish capability): a client may not " + op);
  }
  return refused(web_close::kPolicy, "op \"" + op.substr(0, 40) + "\" is not offered here (read-only server)");
}

FoxgloveProtocol::FoxgloveProtocol(WebServer& server, std::string name, InterestChanged interest_changed)
    : server_(server), name_(std::move(name)), interest_changed_(std::move(interest_changed)) {}

void FoxgloveProtocol::start() {
  std::lock_guard<std::mutex> lock(mutex_);
  pump_posted_ = false;
}

std::uint32_t FoxgloveProtocol::advertise(FoxgloveChannel channel) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // The same channel again (a bridge activated anew) keeps its id, as the spec allows; clients know it already.
    for (const auto& [id, known] : channels_) {
      if (known.topic == channel.topic && known.encoding == channel.encoding &&
          known.schema_name == channel.schema_name && known.schema == channel.schema) {
        return id;
      }
    }
    channel.id = channels_.empty() ? 1 : channels_.rbegin()->first + 1;
    channels_[channel.id] = channel;
  }
  const std::string text = advertiseMessage({channel});
  server_.post([this, text] {
    for (const auto& [client, subscriptions] : clients_) server_.send(client, text);
  });
  return channel.id;
}

void FoxgloveProtocol::publish(std::uint32_t channel, const std::string& publisher, std::uint64_t stamp_ns,
                               std::string message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const Key key{channel, publisher};
    newest_[key] = {stamp_ns, std::make_shared<const std::string>(std::move(message))};
    unsent_.insert(key);
  }
  postPump();
}

void FoxgloveProtocol::publishTime(std::uint64_t stamp_ns) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    time_ns_ = stamp_ns;
    time_unsent_ = true;
  }
  postPump();
}

std::size_t FoxgloveProtocol::subscribers(std::uint32_t channel) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = subscriber_count_.find(channel);
  return it == subscriber_count_.end() ? 0 : it->second;
}

std::vector<FoxgloveChannel> FoxgloveProtocol::channels() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<FoxgloveChannel> list;
  for (const auto& [id, channel] : channels_) list.push_back(channel);
  return list;
}

// One pump waits on the network thread at a time: messages published meanwhile are coalesced into it. Without
// clients nothing is posted (a latched message waits in newest_ for the first one).
void FoxgloveProtocol::postPump() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (pump_posted_ || client_count_ == 0) return;
  pump_posted_ = server_.post([this] { pump(); });
}

void FoxgloveProtocol::pump() {
  std::vector<std::pair<Key, Message>> messages;
  std::uint64_t time_ns = 0;
  bool send_time = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pump_posted_ = false;
    for (const auto& key : unsent_) messages.emplace_back(key, newest_[key]);
    unsent_.clear();
    send_time = time_unsent_;
    time_unsent_ = false;
    time_ns = time_ns_;
  }
  const WebPayload time{std::make_shared<const std::string>(encodeFoxgloveTime(time_ns)), true};
  for (const auto& [client, subscriptions] : clients_) {
    WebClientQueue* queue = server_.queue(client);
    if (!queue) continue;
    if (send_time) queue->offer("time", time);
    for (const auto& [key, message] : messages) {
      auto it = subscriptions.id_of.find(key.first);
      if (it != subscriptions.id_of.end()) offer(client, it->second, key, message);
    }
  }
  server_.flush();
}

void FoxgloveProtocol::offer(WebClientId client, std::uint32_t subscription, const Key& key, const Message& message) {
  WebClientQueue* queue = server_.queue(client);
  if (!queue) return;
  const std::string frame = encodeFoxgloveMessage(subscription, message.stamp_ns, *message.data);
  queue->offer(channelKey(key.first, key.second), {std::make_shared<const std::string>(frame), true});
}

void FoxgloveProtocol::opened(WebServer& server, WebClientId client) {
  clients_[client];
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // What was published while nobody listened is not news to the first client (latched channels are replayed).
    if (client_count_ == 0) unsent_.clear();
    client_count_ = clients_.size();
  }
  server.send(client, dumpJson({{"op", "serverInfo"},
                                {"name", name_},
                                {"capabilities", {"time"}},
                                {"metadata", {{"encoding", "ros1"}, {"read_only", "true"}}}}));
  const std::vector<FoxgloveChannel> known = channels();
  if (!known.empty()) server.send(client, advertiseMessage(known));
}

void FoxgloveProtocol::received(WebServer& server, WebClientId client, const std::string& data, bool binary) {
  FoxgloveRequest request;
  const WebClientError error = parseFoxgloveRequest(data, binary, request);
  if (error.code) {
    server.refuse(client, error.code, error.reason);
    return;
  }
  for (const auto& [subscription, channel] : request.subscribe) subscribe(client, subscription, channel);
  for (const auto subscription : request.unsubscribe) unsubscribe(client, subscription);
  server.flush();
}

// A subscription the spec lets the server ignore (an unknown channel, an id or channel in use) is answered with
// an error status, as the spec says, and the client stays.
void FoxgloveProtocol::subscribe(WebClientId client, std::uint32_t subscription, std::uint32_t channel) {
  Subscriptions& mine = clients_[client];
  bool latched = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = channels_.find(channel);
    if (it == channels_.end()) return status(client, 2, "no channel " + std::to_string(channel));
    latched = it->second.latched;
  }
  if (mine.channel_of.count(subscription) || mine.id_of.count(channel)) {
    return status(client, 2, "subscription " + std::to_string(subscription) + " or channel " +
                                 std::to_string(channel) + " is subscribed already");
  }
  mine.channel_of[subscription] = channel;
  mine.id_of[channel] = subscription;
  countSubscriber(channel, +1);
  if (!latched) return;
  std::vector<std::pair<Key, Message>> replay;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = newest_.lower_bound({channel, ""}); it != newest_.end() && it->first.first == channel; ++it) {
      replay.emplace_back(*it);
    }
  }
  for (const auto& [key, message] : replay) offer(client, subscription, key, message);
}

void FoxgloveProtocol::unsubscribe(WebClientId client, std::uint32_t subscription) {
  Subscriptions& mine = clients_[client];
  auto it = mine.channel_of.find(subscription);
  if (it == mine.channel_of.end()) return status(client, 1, "no subscription " + std::to_string(subscription));
  const std::uint32_t channel = it->second;
  mine.channel_of.erase(it);
  mine.id_of.erase(channel);
  countSubscriber(channel, -1);
}

void FoxgloveProtocol::closed(WebServer&, WebClientId client) {
  auto it = clients_.find(client);
  if (it == clients_.end()) return;
  for (const auto& [channel, subscription] : it->second.id_of) countSubscriber(channel, -1);
  clients_.erase(it);
  std::lock_guard<std::mutex> lock(mutex_);
  client_count_ = clients_.size();
}

void FoxgloveProtocol::countSubscriber(std::uint32_t channel, int change) {
  std::size_t now = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::size_t& count = subscriber_count_[channel];
    count = change > 0 ? count + 1 : count - 1;
    now = count;
  }
  const bool first = change > 0 && now == 1, last = change < 0 && now == 0;
  if (interest_changed_ && (first || last)) interest_changed_(channel, first);
}

void FoxgloveProtocol::status(WebClientId client, int level, const std::string& message) {
  server_.send(client, dumpJson({{"op", "status"}, {"level", level}, {"message", message}}));
}

}  // namespace xpersif::core
