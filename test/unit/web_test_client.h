// A WebSocket client for the web server's unit tests (websocketpp's client on its own thread).
#pragma once

#include <nlohmann/json.hpp>
#include <websocketpp/client.hpp>
#include <websocketpp/config/asio_no_tls_client.hpp>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace xpersif::test {

using json = nlohmann::json;

constexpr auto kTimeout = std::chrono::seconds(5);

struct Received {
  std::string data;
  bool binary = false;
};

/// A WebSocket client on its own thread: what it receives waits in a list for the test to read.
class TestClient {
 public:
  using Client = websocketpp::client<websocketpp::config::asio_client>;

  explicit TestClient(int port, const std::string& subprotocol = "") {
    client_.clear_access_channels(websocketpp::log::alevel::all);
    client_.clear_error_channels(websocketpp::log::elevel::all);
    client_.init_asio();
    client_.set_open_handler([this](websocketpp::connection_hdl) { note([this] { open_ = true; }); });
    client_.set_fail_handler([this](websocketpp::connection_hdl) { note([this] { closed_ = true; }); });
    client_.set_close_handler([this](websocketpp::connection_hdl h) {
      const auto con = client_.get_con_from_hdl(h);
      const auto code = con->get_remote_close_code();
      const std::string reason = con->get_remote_close_reason();
      note([this, code, reason] {
        close_code_ = code;
        close_reason_ = reason;
        closed_ = true;
      });
    });
    client_.set_message_handler([this](websocketpp::connection_hdl, Client::message_ptr m) {
      Received r{m->get_payload(), m->get_opcode() == websocketpp::frame::opcode::binary};
      note([this, r] { received_.push_back(r); });
    });
    websocketpp::lib::error_code ec;
    auto con = client_.get_connection("ws://127.0.0.1:" + std::to_string(port) + "/", ec);
    if (ec) throw std::runtime_error(ec.message());
    if (!subprotocol.empty()) con->add_subprotocol(subprotocol);
    connection_ = con;
    client_.connect(con);
    thread_ = std::thread([this] { client_.run(); });
  }

  ~TestClient() {
    websocketpp::lib::error_code ec;
    if (open_ && !closed_) client_.close(connection_, websocketpp::close::status::normal, "", ec);
    wait([this] { return closed_; });
    client_.stop();
    thread_.join();
  }

  bool waitOpen() { return wait([this] { return open_ || closed_; }) && open_; }
  /// The subprotocol the server chose ("" for none).
  std::string subprotocol() { return connection_->get_response_header("Sec-WebSocket-Protocol"); }

  void send(const std::string& message, bool binary = false) {
    websocketpp::lib::error_code ec;
    client_.send(connection_, message, binary ? websocketpp::frame::opcode::binary : websocketpp::frame::opcode::text,
                 ec);
  }

  /// The next message, or nothing within the timeout.
  std::optional<Received> next() {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!cv_.wait_for(lock, kTimeout, [this] { return !received_.empty(); })) return std::nullopt;
    Received r = received_.front();
    received_.pop_front();
    return r;
  }

  /// The next text message as JSON (binary ones skipped); null when none comes.
  json nextJson() {
    while (auto r = next()) {
      if (!r->binary) return json::parse(r->data);
    }
    return nullptr;
  }

  /// The server's close code (0 when it never closed).
  int closeCode() {
    wait([this] { return closed_; });
    std::lock_guard<std::mutex> lock(mutex_);
    return close_code_;
  }
  /// The server's close reason ("" when it never closed or gave none).
  std::string closeReason() {
    wait([this] { return closed_; });
    std::lock_guard<std::mutex> lock(mutex_);
    return close_reason_;
  }

 private:
  template <class F>
  void note(F change) {
    std::lock_guard<std::mutex> lock(mutex_);
    change();
    cv_.notify_all();
  }
  template <class P>
  bool wait(P done) {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, kTimeout, done);
  }

  Client client_;
  Client::connection_ptr connection_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool open_ = false, closed_ = false;
  int close_code_ = 0;
  std::string close_reason_;
  std::deque<Received> received_;
};

}  // namespace xpersif::test
