/**
 * @file web_stream.h
 * @brief What the browser bridge (WebBridge, issue 18) sends to each client and when, without ROS or sockets:
 *        the scene once, the loop's state as it changes, and the simulator's frames at the rate each client
 *        asked for, with a memory bound per client whatever the client does.
 *
 * The bridge serializes every message once and offers the same shared payload to every client's
 * WebClientQueue. A queue keeps at most one unsent message per key ("scene", "progress", "notions", ...,
 * "frame"): a newer one replaces the older, so a slow client gets the newest state and the newest frame and
 * never a backlog. What a queue hands out at once is limited by the bytes still waiting in the client's socket
 * (the send window), so the socket's queue stays below window + one message. A client whose socket queue
 * does not drain for `stall_timeout` seconds has stopped reading and is to be disconnected.
 *
 * The wire format (doc/watching.md): text messages are JSON objects with a "type"; frames
 * are binary (encodeFrame). Client messages are JSON objects too (parseClientMessage); anything else gets a
 * WebSocket close code and a sentence.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "xpersif/core/common/scene.h"

namespace xpersif::core {

/// Limits of one client (the bridge's parameters; see web_bridge.h).
struct WebClientLimits {
  double default_rate = 30.0;         ///< frames per second until the client asks for another rate
  double max_rate = 1000.0;           ///< the most a client may ask for; "full" (0) means every frame, up to this
  std::size_t send_window = 256 * 1024;  ///< hand out nothing more while the socket queue holds this many bytes
  double stall_timeout = 10.0;        ///< seconds of a non-draining socket queue before the client is dropped
  std::size_t max_client_message = 4096;   ///< bytes of one message from a client
  double client_messages_per_second = 20;  ///< sustained rate of client messages (a burst of twice that)
};

/// One message as it goes out: shared by every client it is offered to.
struct WebPayload {
  std::shared_ptr<const std::string> data;
  bool binary = false;
  std::size_t size() const { return data ? data->size() : 0; }
};

/// Counters of one client (shown in the bridge's status and its /stats page).
struct WebClientStats {
  std::uint64_t frames_offered = 0;
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_dropped = 0;  ///< replaced by a newer frame before they could go, or skipped for the rate
  std::uint64_t messages_sent = 0;   ///< everything, frames included
  std::uint64_t bytes_sent = 0;
  std::uint64_t state_replaced = 0;  ///< state messages replaced by newer ones before they could go
};

/**
 * @brief The outgoing queue and pacing of one client. Not thread-safe: the bridge uses it from its network
 *        thread only. Times are seconds on any monotonic clock.
 */
class WebClientQueue {
 public:
  explicit WebClientQueue(WebClientLimits limits = {});

  /// Frames per second for this client; 0 = every frame (at most max_rate). @throws ValidationError if out of
  /// range (negative, non-finite, above max_rate).
  void setRate(double hz);
  double rate() const { return rate_; }

  /// Queue @p payload under @p key, replacing an unsent one with the same key. The key "scene" goes first and
  /// drops a pending frame (frames refer to the scene's node order).
  void offer(const std::string& key, WebPayload payload);
  /// Queue a frame, replacing an unsent one (counted as dropped).
  void offerFrame(WebPayload payload);

  /**
   * @brief What to send now, in order: the scene, state messages (by key), the frame if the client's rate
   *        allows. @p queued_bytes is what the client's socket still holds; nothing is handed out past the send
   *        window, except one message when the socket is empty (so a message larger than the window still goes).
   */
  std::vector<WebPayload> take(double now, std::size_t queued_bytes);

  /// Seconds from @p now until take() would hand out a pending frame that waits for the rate; negative when
  /// nothing waits for time (an empty queue, or one that waits for the socket to drain).
  double nextDue(double now) const;

  /// "" while the client reads; else a sentence: its socket queue has not drained for stall_timeout seconds.
  std::string stalled(double now, std::size_t queued_bytes);

  /// Whether a client message arriving at @p now is within the client's allowance (a token bucket).
  bool allowIncoming(double now);

  /// Bytes of the payloads waiting here (shared payloads counted in full).
  std::size_t pendingBytes() const;
  std::size_t pendingMessages() const;
  const WebClientStats& stats() const { return stats_; }
  const WebClientLimits& limits() const { return limits_; }

 private:
  WebClientLimits limits_;
  double rate_;
  WebPayload scene_;
  std::map<std::string, WebPayload> state_;
  WebPayload frame_;
  bool scene_sent_ = false;
  double next_frame_ = -1e300;  ///< earliest time the next frame may go (rate schedule)
  double progress_time_ = -1;   ///< last time the socket queue was seen empty or shrinking
  std::size_t last_queued_ = 0;
  double tokens_;
  double tokens_time_ = -1;
  WebClientStats stats_;
};

/// A request from a client, once parsed and checked.
struct WebClientRequest {
  enum class Kind { Config, Command, Ping };
  Kind kind = Kind::Config;
  bool has_rate = false;
  double rate = 0;           ///< 0 = every frame
  std::string command;       ///< pause | resume | confirm
  std::string token;
  std::string id;            ///< echoed in the answer (at most 64 characters)
};

/// Why a client message is refused: a WebSocket close code and a sentence.
struct WebClientError {
  std::uint16_t code = 0;  ///< 0: no error
  std::string reason;
};

/// WebSocket close codes the bridge uses (RFC 6455 §7.4.1).
namespace web_close {
constexpr std::uint16_t kNormal = 1000;
constexpr std::uint16_t kGoingAway = 1001;
constexpr std::uint16_t kUnsupportedData = 1003;  ///< a binary message: clients send JSON text
constexpr std::uint16_t kInvalidPayload = 1007;   ///< not JSON, not an object, a field of the wrong type
constexpr std::uint16_t kPolicy = 1008;           ///< unknown type, commands not allowed, wrong token, flooding, not reading
constexpr std::uint16_t kTooBig = 1009;           ///< over max_client_message
}  // namespace web_close

/**
 * @brief Parse one client message: `{"type":"config","rate":30|"full"}`, `{"type":"command","command":
 *        "pause|resume|confirm","token":"..."}` or `{"type":"ping","id":"..."}`.
 * @return the request, or an error (close code and sentence) for a binary, oversized, malformed or unexpected
 *         message. Never throws.
 */
WebClientError parseClientMessage(const std::string& text, bool binary, const WebClientLimits& limits,
                                  WebClientRequest& request);

/**
 * @brief Whether @p request may run: commands need `allow_commands` and the bridge's token (compared in
 *        constant time; an empty configured token refuses every command). Close code 1008 and a sentence if not.
 */
WebClientError checkCommandAllowed(const WebClientRequest& request, bool allow_commands, const std::string& token);

/// The scene as the page's JSON message (`"type":"scene"`): nodes with parents, shapes, sizes, colours and
/// offsets; cameras; the roles; and `frame_nodes`, the dynamic nodes in the order frames list them.
std::string sceneToJson(const SceneDescription& scene, std::uint32_t generation);
/// The dynamic nodes of @p scene in frame order.
std::vector<std::string> frameNodes(const SceneDescription& scene);

/// One frame: every dynamic node's parent_from_node, in frameNodes() order.
struct WebFrame {
  std::uint32_t generation = 0;  ///< the scene message's generation it refers to
  std::uint64_t seq = 0;
  double sim_time = 0;           ///< the frame's stamp (simulated seconds)
  double wall_time = 0;          ///< when the bridge received it (Unix seconds): clients measure latency with it
  std::vector<float> poses;      ///< 7 per node: x y z qx qy qz qw
};

/**
 * @brief Binary frame, little-endian: "XPF1", u32 generation, u64 seq, f64 sim_time, f64 wall_time, u32 node
 *        count N, then N × 7 f32 (x y z qx qy qz qw). 36 + 28 N bytes.
 */
std::string encodeFrame(const WebFrame& frame);
/// @throws ValidationError for a buffer that is not a whole frame.
WebFrame decodeFrame(const std::string& bytes);

/// JSON string literal of @p text (quotes and escapes), for messages built by hand.
std::string jsonString(const std::string& text);
/// @p j as one line of JSON text, as every message goes out: invalid UTF-8 in a string is replaced, never thrown.
std::string dumpJson(const nlohmann::json& j);

}  // namespace xpersif::core
