/**
 * @file foxglove_protocol.h
 * @brief The Foxglove WebSocket protocol (subprotocol `foxglove.websocket.v1`,
 *        https://github.com/foxglove/ws-protocol/blob/main/docs/spec.md) on a WebServer, without ROS: what
 *        Foxglove and Lichtblick speak when they connect live.
 *
 * The server says `serverInfo` and `advertise`s its channels (a topic, encoding "ros1", the ROS type as
 * schemaName and the full message definition as schema); a client subscribes to channels and gets binary
 * Message Data frames (opcode 0x01, its subscription id, the receive stamp in ns, the serialized message), and
 * binary Time frames (0x02). Read-only: no capability lets a client publish, call services or set parameters, so a
 * client that tries (a client `advertise`, a binary message, any other op) is closed with code 1008 and a sentence;
 * malformed JSON or fields of the wrong type with 1007.
 *
 * Bounded per client as the page's protocol is: messages go through the client's WebClientQueue under one key per
 * channel and publisher, so a slow client gets the newest message of each and never a backlog.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "xpersif/core/web/web_server.h"

namespace xpersif::core {

/// The subprotocol a Foxglove client asks for.
inline constexpr const char* kFoxgloveSubprotocol = "foxglove.websocket.v1";

/// One channel a server advertises: a topic with its type and message definition.
struct FoxgloveChannel {
  std::uint32_t id = 0;  ///< chosen by FoxgloveProtocol::advertise
  std::string topic;
  std::string encoding = "ros1";
  std::string schema_name;  ///< the ROS type, e.g. "tf2_msgs/TFMessage"
  std::string schema;       ///< the full message definition, as rosbag stores it
  bool latched = false;     ///< a new subscriber gets each publisher's newest message at once
};

/// Message Data, little-endian: 0x01, u32 subscription id, u64 receive stamp (ns), then @p message.
std::string encodeFoxgloveMessage(std::uint32_t subscription, std::uint64_t stamp_ns, const std::string& message);
/// Time, little-endian: 0x02, u64 stamp (ns).
std::string encodeFoxgloveTime(std::uint64_t stamp_ns);

/// A client's request once parsed: subscribe (subscription id, channel id pairs) or unsubscribe (ids).
struct FoxgloveRequest {
  enum class Kind { Subscribe, Unsubscribe };
  Kind kind = Kind::Subscribe;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> subscribe;
  std::vector<std::uint32_t> unsubscribe;
};

/**
 * @brief Parse one client message. Only `subscribe` and `unsubscribe` are taken; a binary message (client
 *        publishing or a service call), a client `advertise` and any other op are refused with code 1008, text that
 *        is not a JSON object with the fields of the wrong type with 1007. Never throws.
 */
WebClientError parseFoxgloveRequest(const std::string& data, bool binary, FoxgloveRequest& request);

class FoxgloveProtocol : public WebProtocol {
 public:
  /// On the network thread: @p channel has its first subscribed client (true) or lost its last one (false).
  using InterestChanged = std::function<void(std::uint32_t channel, bool wanted)>;

  /// @p name goes to clients in `serverInfo`; register the protocol with WebServer::addProtocol.
  FoxgloveProtocol(WebServer& server, std::string name, InterestChanged interest_changed = {});

  /// Forget a wake-up that a stopped server dropped; call before each WebServer::start.
  void start();

  /// Any thread: make @p channel known (to the clients there are and to later ones); its id. A channel with the
  /// same topic, encoding, schema name and schema as a known one keeps that one's id.
  std::uint32_t advertise(FoxgloveChannel channel);
  /// Any thread: @p message (serialized as the channel's encoding) from @p publisher, received at @p stamp_ns;
  /// replaces an unsent one of the same channel and publisher.
  void publish(std::uint32_t channel, const std::string& publisher, std::uint64_t stamp_ns, std::string message);
  /// Any thread: the server's time (the clients' Time frames; stamps of published messages use the same clock).
  void publishTime(std::uint64_t stamp_ns);
  /// Any thread: clients subscribed to @p channel now.
  std::size_t subscribers(std::uint32_t channel) const;
  /// Any thread: the channels advertised so far.
  std::vector<FoxgloveChannel> channels() const;

  void opened(WebServer& server, WebClientId client) override;
  void received(WebServer& server, WebClientId client, const std::string& data, bool binary) override;
  void closed(WebServer& server, WebClientId client) override;

 private:
  struct Message {
    std::uint64_t stamp_ns = 0;
    std::shared_ptr<const std::string> data;
  };
  using Key = std::pair<std::uint32_t, std::string>;  // channel, publisher
  /// A client's subscriptions both ways (network thread).
  struct Subscriptions {
    std::map<std::uint32_t, std::uint32_t> channel_of;  // subscription id -> channel
    std::map<std::uint32_t, std::uint32_t> id_of;       // channel -> subscription id
  };

  void postPump();
  void pump();
  void offer(WebClientId client, std::uint32_t subscription, const Key& key, const Message& message);
  void subscribe(WebClientId client, std::uint32_t subscription, std::uint32_t channel);
  void unsubscribe(WebClientId client, std::uint32_t subscription);
  void countSubscriber(std::uint32_t channel, int change);
  void status(WebClientId client, int level, const std::string& message);

  WebServer& server_;
  std::string name_;
  InterestChanged interest_changed_;

  mutable std::mutex mutex_;  // guards what ROS threads and the network thread share, below
  std::map<std::uint32_t, FoxgloveChannel> channels_;
  std::map<Key, Message> newest_;  // every channel's newest message per publisher (latched ones are replayed)
  std::set<Key> unsent_;
  std::uint64_t time_ns_ = 0;
  bool time_unsent_ = false;
  bool pump_posted_ = false;
  std::map<std::uint32_t, std::size_t> subscriber_count_;
  std::size_t client_count_ = 0;  // clients_.size(), for the threads that publish

  std::map<WebClientId, Subscriptions> clients_;  // network thread only
};

}  // namespace xpersif::core
