#include "xpersif/core/web/web_stream_protocol.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <exception>

namespace xpersif::core {

namespace {

constexpr std::size_t kMaxWaitingCommands = 8;

/// Unix seconds: clients measure their latency with it.
double wallNow() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string commandResult(const std::string& id, const std::string& command, const WebCommandResult& result) {
  return dumpJson({{"type", "command_result"},
                   {"id", id},
                   {"command", command},
                   {"success", result.success},
                   {"message", result.message}});
}

}  // namespace

WebStreamProtocol::WebStreamProtocol(WebServer& server, CommandRunner run_command)
    : server_(server), run_command_(std::move(run_command)) {}

WebStreamProtocol::~WebStreamProtocol() { stop(); }

void WebStreamProtocol::start(bool allow_commands, std::string token) {
  allow_commands_ = allow_commands;
  token_ = std::move(token);
  {
    std::lock_guard<std::mutex> lock(jobs_mutex_);
    jobs_stop_ = false;
  }
  worker_ = std::thread([this] { work(); });
}

void WebStreamProtocol::stop() {
  {
    std::lock_guard<std::mutex> lock(jobs_mutex_);
    jobs_stop_ = true;
  }
  jobs_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
  std::lock_guard<std::mutex> lock(jobs_mutex_);
  jobs_.clear();
}

void WebStreamProtocol::received(WebServer& server, WebClientId client, const std::string& data, bool binary) {
  WebClientRequest request;
  WebClientError error = parseClientMessage(data, binary, server.options().limits, request);
  if (!error.code) error = checkCommandAllowed(request, allow_commands_, token_);
  if (error.code) {
    server.refuse(client, error.code, error.reason);
    return;
  }
  switch (request.kind) {
    case WebClientRequest::Kind::Config: {
      WebClientQueue* queue = server.queue(client);
      if (request.has_rate) queue->setRate(request.rate);  // checked by the parser
      server.send(client, dumpJson({{"type", "config"}, {"id", request.id}, {"rate", queue->rate()}}));
      break;
    }
    case WebClientRequest::Kind::Ping:
      server.send(client, dumpJson({{"type", "pong"}, {"id", request.id}, {"wall_time", wallNow()}}));
      break;
    case WebClientRequest::Kind::Command:
      queueCommand(client, request);
      break;
  }
}

void WebStreamProtocol::queueCommand(WebClientId client, const WebClientRequest& request) {
  std::lock_guard<std::mutex> lock(jobs_mutex_);
  if (jobs_.size() >= kMaxWaitingCommands) {
    server_.send(client, commandResult(request.id, request.command,
                                       {false, "the bridge is busy with earlier commands; try again"}));
    return;
  }
  jobs_.push_back({client, request.command, request.id});
  jobs_cv_.notify_one();
}

void WebStreamProtocol::work() {
  for (;;) {
    CommandJob job;
    {
      std::unique_lock<std::mutex> lock(jobs_mutex_);
      jobs_cv_.wait(lock, [this] { return jobs_stop_ || !jobs_.empty(); });
      if (jobs_stop_) return;
      job = jobs_.front();
      jobs_.pop_front();
    }
    WebCommandResult result;
    try {
      result = run_command_(job.command);
    } catch (const std::exception& e) {  // never out of the worker thread
      result = {false, e.what()};
    }
    server_.sendLater(job.client, commandResult(job.id, job.command, result));
  }
}

}  // namespace xpersif::core
