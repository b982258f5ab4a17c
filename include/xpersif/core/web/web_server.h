/**
 * @file web_server.h
 * @brief The browser bridge's transport, without ROS: one WebSocket and HTTP server (websocketpp on Boost.Asio,
 *        one network thread) that serves a page's files and `/stats` over HTTP, and gives each WebSocket client a
 *        core::WebClientQueue (pacing, send window, stall timeout; web_stream.h).
 *
 * What the clients and the server say to each other is a WebProtocol's business: the server hands each client's
 * messages to the protocol the client chose in its handshake (its WebSocket subprotocol) and sends what the
 * protocol asks it to. The page's protocol (web_stream_protocol.h) takes the clients that ask for no subprotocol,
 * or for one no protocol here speaks; another (e.g. "foxglove.websocket.v1") can be added beside it.
 *
 * The newest message of each kind and the newest frame are broadcast (publish, publishFrame) from any thread:
 * the server keeps one copy, hands it to every client of the default protocol on its network thread, and to
 * each client that connects later. Whatever a client does, what waits for it is bounded: one message per kind
 * in its queue, the send window in its socket. A client that stops reading, floods, or sends a message over
 * `max_client_message` is closed with a close code and a log line.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "xpersif/core/web/web_stream.h"

namespace xpersif::core {

/// A client of a WebServer: unique for the server's life (never reused).
using WebClientId = std::uint64_t;

/// Where and how the server listens, and its limits per client.
struct WebServerOptions {
  std::string address = "127.0.0.1";     ///< an IP address (ipAddressProblem)
  int port = 8765;                       ///< 0: any free port (boundPort tells which)
  std::size_t socket_send_buffer = 65536;  ///< the kernel's SO_SNDBUF per client
  int max_clients = 128;                 ///< clients at once; more are refused with HTTP 503
  WebClientLimits limits;                ///< each client's queue, and its messages' size and rate
};

/// One file the server answers a GET with.
struct WebAsset {
  int status = 200;
  std::string type;  ///< Content-Type
  std::string body;
};

/// What the server answers over HTTP besides `/stats`: files by path (without the query), and the body of a 404.
struct WebSite {
  std::map<std::string, WebAsset> assets;
  std::string not_found = "not found\n";
};

/// How serious a line the server logs is.
enum class WebLogLevel { Info, Warn, Error };
/// Where the server's log lines go (from its network thread, and from start and stop).
using WebLog = std::function<void(WebLogLevel, const std::string&)>;

/// "" when @p address is an IP address (v4 or v6); else why not.
std::string ipAddressProblem(const std::string& address);

class WebServer;

/// A wire protocol spoken over a WebServer's WebSocket connections. Every call comes on the network thread.
class WebProtocol {
 public:
  virtual ~WebProtocol() = default;
  /// @p client has connected and speaks this protocol (the server has queued the broadcast state for it).
  virtual void opened(WebServer& server, WebClientId client) {}
  /// A message from @p client, within its allowance (a flood is refused before it gets here). What it throws
  /// closes the client with code 1007 and the exception's text.
  virtual void received(WebServer& server, WebClientId client, const std::string& data, bool binary) = 0;
  /// @p client is gone: closed by either side, failed, or refused.
  virtual void closed(WebServer& server, WebClientId client) {}
};

/**
 * @brief The WebSocket and HTTP server. start() and stop() may alternate; the broadcast state survives them.
 *        Thread-safe: publish, publishFrame, post, sendLater, boundPort, summary, framesIn. The other calls are
 *        for the network thread only (a WebProtocol's callbacks, or a task given to post).
 */
class WebServer {
 public:
  explicit WebServer(WebLog log);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  /**
   * @brief Speak @p protocol with the clients that ask for @p subprotocol in their handshake; with "" (the
   *        default protocol), with every other client. Call before start(); @p protocol must outlive the server.
   */
  void addProtocol(WebProtocol& protocol, const std::string& subprotocol = "");

  /**
   * @brief Listen on @p options' address and port, serve @p site, and run the network thread.
   * @throws std::runtime_error when the server cannot start, listen or accept ("cannot listen on ADDRESS:PORT: ...").
   */
  void start(const WebServerOptions& options, WebSite site);
  /// Close every client (code 1001, "the bridge stops"), give the close handshakes up to a second, then stop.
  void stop();

  /// The port listened on (useful with port 0); 0 when not listening.
  int boundPort() const;
  /// One line for a status display: address, clients, bytes waiting, frames in, clients dropped; "not listening".
  std::string summary() const;
  /// Frames published since the server was made.
  std::uint64_t framesIn() const;
  /// The options of the last start().
  const WebServerOptions& options() const;

  /// The newest message of kind @p key for every client of the default protocol (replaces an unsent one). The
  /// key "scene" drops the newest frame too (frames refer to the scene's node order).
  void publish(const std::string& key, WebPayload payload);
  /// The newest frame for every client of the default protocol (replaces an unsent one).
  void publishFrame(WebPayload payload);

  /// Run @p task on the network thread; false (and nothing runs) when the server is not running.
  bool post(std::function<void()> task);
  /// send() from any thread: posted to the network thread, dropped if the client has gone by then.
  void sendLater(WebClientId client, std::string text);

  /// Send @p text to @p client now, past its queue (answers to its requests). Nothing if it has gone.
  void send(WebClientId client, const std::string& text);
  /// Close @p client with @p code and the sentence @p why, and log it (throttled) as a bad message.
  void refuse(WebClientId client, std::uint16_t code, const std::string& why);
  /// @p client's queue (its rate), or nullptr when it has gone.
  WebClientQueue* queue(WebClientId client);
  /// Send what every client's queue may hand out now (after a protocol offered to their queues).
  void flush();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace xpersif::core
