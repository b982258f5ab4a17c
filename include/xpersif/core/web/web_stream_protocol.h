/**
 * @file web_stream_protocol.h
 * @brief The page's protocol (doc/watching.md) on a WebServer, without ROS: what the bridge broadcasts is the
 *        scene, the loop's state and frames (WebServer::publish); what a client may send is a JSON config, ping
 *        or command (parseClientMessage in web_stream.h).
 *
 * A config sets the client's frame rate and is answered with the rate; a ping is answered with the wall time; a
 * command (pause, resume, confirm), when allowed and with the right token (checkCommandAllowed), is run by the
 * CommandRunner on a worker thread of its own, at most 8 waiting, and answered with its result. Anything else
 * closes the client with the close code and sentence of web_stream.h.
 */
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "xpersif/core/web/web_server.h"

namespace xpersif::core {

/// What a client's command gave: whether it succeeded, and a sentence for the client.
struct WebCommandResult {
  bool success = false;
  std::string message;
};

class WebStreamProtocol : public WebProtocol {
 public:
  /// Runs a client's command ("pause", "resume" or "confirm") on the protocol's worker thread; it may block.
  using CommandRunner = std::function<WebCommandResult(const std::string& command)>;

  /// Commands' answers go out through @p server; register the protocol with WebServer::addProtocol.
  WebStreamProtocol(WebServer& server, CommandRunner run_command);
  ~WebStreamProtocol() override;

  /// Take commands when @p allow_commands, from clients that send @p token; start the worker thread.
  void start(bool allow_commands, std::string token);
  /// Stop the worker thread once its current command is done; commands still waiting are dropped.
  void stop();

  void received(WebServer& server, WebClientId client, const std::string& data, bool binary) override;

 private:
  struct CommandJob {
    WebClientId client = 0;
    std::string command, id;
  };
  void queueCommand(WebClientId client, const WebClientRequest& request);
  void work();

  WebServer& server_;
  CommandRunner run_command_;
  bool allow_commands_ = false;
  std::string token_;

  std::mutex jobs_mutex_;
  std::condition_variable jobs_cv_;
  std::deque<CommandJob> jobs_;
  bool jobs_stop_ = false;
  std::thread worker_;
};

}  // namespace xpersif::core
