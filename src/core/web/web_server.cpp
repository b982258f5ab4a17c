#include "xpersif/core/web/web_server.h"

#include <boost/asio/steady_timer.hpp>
#include <nlohmann/json.hpp>
#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

using Server = websocketpp::server<websocketpp::config::asio>;
using Hdl = websocketpp::connection_hdl;
using json = nlohmann::json;

double steadyNow() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// One log line a second at most from one place: a crowd of bad clients makes one line, not thousands.
class Throttle {
 public:
  bool allow() {
    const double now = steadyNow();
    if (last_ + 1.0 > now) return false;
    last_ = now;
    return true;
  }

 private:
  double last_ = -1e300;
};

}  // namespace

std::string ipAddressProblem(const std::string& address) {
  boost::system::error_code ec;
  boost::asio::ip::make_address(address, ec);
  return ec ? ec.message() : "";
}

struct WebServer::Impl {
  Impl(WebServer& owner, WebLog log) : owner(owner), log(std::move(log)) {}

  WebServer& owner;
  WebLog log;
  WebServerOptions options;
  WebSite site;
  WebProtocol* default_protocol = nullptr;
  std::map<std::string, WebProtocol*> protocols;  // by WebSocket subprotocol

  // ---- the newest of everything, published from any thread, handed to the clients on the network thread ----
  std::mutex latest_mutex;
  std::map<std::string, WebPayload> latest;  // by key, "scene" included
  std::set<std::string> dirty;
  WebPayload latest_frame;
  bool frame_dirty = false;
  std::atomic<bool> pump_posted{false};
  std::mutex post_mutex;  // accepting and posting: nothing is posted to a server that is going away
  bool accepting = false;
  std::atomic<std::uint64_t> frames_in{0};
  std::atomic<int> bound{0};

  // ---- the network thread's own ----
  struct Client {
    explicit Client(const WebClientLimits& l) : queue(l) {}
    WebClientQueue queue;
    Hdl hdl;
    std::string remote;
    WebClientId id = 0;
    WebProtocol* protocol = nullptr;
  };
  std::unique_ptr<Server> server;
  std::map<WebClientId, std::shared_ptr<Client>> clients;
  std::map<Hdl, WebClientId, std::owner_less<Hdl>> ids;
  WebClientId next_client_id = 1;
  std::unique_ptr<boost::asio::steady_timer> housekeeping;
  std::unique_ptr<boost::asio::steady_timer> due_timer;
  double due_at = -1;
  std::thread network;
  std::uint64_t disconnected_stalled = 0, closed_bad_messages = 0, refused_full = 0;
  Throttle full_throttle, too_big_throttle, refuse_throttle;

  // ---- summary for a status display (network thread writes, anyone reads) ----
  mutable std::mutex summary_mutex;
  std::string summary = "not listening";

  // ---- start and stop ----------------------------------------------------------------------------------------
  void makeServer() {
    server = std::make_unique<Server>();
    server->clear_access_channels(websocketpp::log::alevel::all);
    server->clear_error_channels(websocketpp::log::elevel::all);  // its failures reach our handlers, logged there
    websocketpp::lib::error_code ec;
    server->init_asio(ec);
    if (ec) {
      server.reset();
      throw std::runtime_error("cannot start the web server: " + ec.message());
    }
    server->set_reuse_addr(true);
    server->set_max_message_size(options.limits.max_client_message);
    server->set_max_http_body_size(1024);
    server->set_open_handshake_timeout(5000);
    server->set_close_handshake_timeout(2000);
    server->set_listen_backlog(64);
    server->set_tcp_init_handler([this](Hdl hdl) { onTcpInit(hdl); });
    server->set_validate_handler([this](Hdl hdl) { return onValidate(hdl); });
    server->set_open_handler([this](Hdl hdl) { onOpen(hdl); });
    server->set_close_handler([this](Hdl hdl) { onGone(hdl, "closed"); });
    server->set_fail_handler([this](Hdl hdl) { onGone(hdl, "failed"); });
    server->set_message_handler([this](Hdl hdl, Server::message_ptr msg) { onMessage(hdl, msg); });
    server->set_http_handler([this](Hdl hdl) { onHttp(hdl); });
  }

  void listen() {
    const std::string where = options.address + ":" + std::to_string(options.port);
    websocketpp::lib::error_code ec;
    boost::system::error_code be;
    const boost::asio::ip::tcp::endpoint endpoint(boost::asio::ip::make_address(options.address, be),
                                                  static_cast<unsigned short>(options.port));
    server->listen(endpoint, ec);
    if (ec) {
      server.reset();
      throw std::runtime_error("cannot listen on " + where + ": " + ec.message());
    }
    const int port = server->get_local_endpoint(be).port();
    server->start_accept(ec);
    if (ec) {
      server.reset();
      throw std::runtime_error("cannot accept on " + where + ": " + ec.message());
    }
    bound = port;
  }

  void run() {
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
          log(WebLogLevel::Error, std::string("network thread: ") + e.what());
        }
      }
    });
    std::lock_guard<std::mutex> lock(post_mutex);
    accepting = true;
    pump_posted = false;
  }

  void stop() {
    {
      std::lock_guard<std::mutex> lock(post_mutex);
      accepting = false;
    }
    if (!server) return;
    boost::asio::post(server->get_io_service(), [this] {
      websocketpp::lib::error_code ec;
      server->stop_listening(ec);
      housekeeping->cancel();
      due_timer->cancel();
      while (!clients.empty()) {
        const Hdl hdl = clients.begin()->second->hdl;
        forget(clients.begin()->first);
        server->close(hdl, web_close::kGoingAway, "the bridge stops", ec);
      }
    });
    // The close handshakes get a moment; then the loop stops whatever is left.
    for (int i = 0; i < 20 && !server->stopped(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    server->stop();
    if (network.joinable()) network.join();
    housekeeping.reset();
    due_timer.reset();
    clients.clear();
    ids.clear();
    server.reset();
    bound = 0;
    std::lock_guard<std::mutex> lock(summary_mutex);
    summary = "not listening";
  }

  // ---- clients come and go ---------------------------------------------------------------------------------
  void onTcpInit(Hdl hdl) {
    websocketpp::lib::error_code e;
    auto con = server->get_con_from_hdl(hdl, e);
    if (e) return;
    boost::system::error_code be;
    con->get_socket().set_option(boost::asio::ip::tcp::no_delay(true), be);
    con->get_socket().set_option(
        boost::asio::socket_base::send_buffer_size(static_cast<int>(options.socket_send_buffer)), be);
  }

  /// The protocol a connection speaks: the one of its chosen subprotocol, else the default one.
  WebProtocol* protocolFor(const std::string& subprotocol) const {
    auto it = protocols.find(subprotocol);
    return it == protocols.end() ? default_protocol : it->second;
  }

  bool onValidate(Hdl hdl) {
    auto con = server->get_con_from_hdl(hdl);
    if (static_cast<int>(clients.size()) >= options.max_clients) {
      ++refused_full;
      if (full_throttle.allow()) {
        log(WebLogLevel::Warn,
            "refusing a web client: " + std::to_string(options.max_clients) + " clients already (~max_clients)");
      }
      con->set_status(websocketpp::http::status_code::service_unavailable);
      con->set_body("too many clients (~max_clients)\n");
      return false;
    }
    // The first subprotocol the client asks for that a protocol here speaks; none: the default protocol.
    for (const auto& asked : con->get_requested_subprotocols()) {
      if (protocols.count(asked) == 0) continue;
      con->select_subprotocol(asked);
      return true;
    }
    if (default_protocol) return true;
    con->set_status(websocketpp::http::status_code::bad_request);
    con->set_body("no protocol here for this client's subprotocols\n");
    return false;
  }

  void onOpen(Hdl hdl) {
    auto client = std::make_shared<Client>(options.limits);
    client->id = next_client_id++;
    client->hdl = hdl;
    client->protocol = default_protocol;
    websocketpp::lib::error_code e;
    auto con = server->get_con_from_hdl(hdl, e);
    if (!e) {
      client->remote = con->get_remote_endpoint();
      client->protocol = protocolFor(con->get_subprotocol());
    }
    if (client->protocol == default_protocol) {
      std::lock_guard<std::mutex> lock(latest_mutex);
      for (const auto& [key, payload] : latest) client->queue.offer(key, payload);
      if (latest_frame.data) client->queue.offerFrame(latest_frame);
    }
    clients[client->id] = client;
    ids[hdl] = client->id;
    log(WebLogLevel::Info, "web client " + std::to_string(client->id) + " connected from " + client->remote + " (" +
                               std::to_string(clients.size()) + " now)");
    client->protocol->opened(owner, client->id);
    flush();
  }

  static std::string closeDetail(const Server::connection_ptr& con) {
    std::string detail = "local code " + std::to_string(con->get_local_close_code());
    if (!con->get_local_close_reason().empty()) detail += " '" + con->get_local_close_reason() + "'";
    detail += ", remote code " + std::to_string(con->get_remote_close_code());
    if (con->get_ec()) detail += ", " + con->get_ec().message();
    return detail;
  }

  void onGone(Hdl hdl, const char* how) {
    websocketpp::lib::error_code e;
    auto con = server->get_con_from_hdl(hdl, e);
    auto it = ids.find(hdl);
    if (it == ids.end()) return;  // refused or dropped already, and logged then
    const Client& client = *clients.at(it->second);
    const std::string who = "web client " + std::to_string(client.id) + " (" + client.remote + ")";
    const std::string detail = e ? "" : closeDetail(con);
    // The library closes an oversized message itself (1009): that is a bad message too, and logged as one.
    if (!e && con->get_local_close_code() == websocketpp::close::status::message_too_big) {
      ++closed_bad_messages;
      if (too_big_throttle.allow()) {
        log(WebLogLevel::Warn, who + " sent a message over ~max_client_message (" +
                                   std::to_string(options.limits.max_client_message) + " bytes): " + detail);
      }
    } else {
      log(WebLogLevel::Info, who + " " + how + " (" + detail + ")");
    }
    forget(client.id);
  }

  /// Drop @p id from the tables (its queue goes now) and tell its protocol.
  void forget(WebClientId id) {
    auto it = clients.find(id);
    if (it == clients.end()) return;
    const auto client = it->second;
    ids.erase(client->hdl);
    clients.erase(it);
    client->protocol->closed(owner, id);
  }

  // ---- what clients send ---------------------------------------------------------------------------------------
  void onMessage(Hdl hdl, const Server::message_ptr& msg) {
    try {
      auto it = ids.find(hdl);
      if (it == ids.end()) return;
      const auto client = clients.at(it->second);
      if (!client->queue.allowIncoming(steadyNow())) {
        refuse(hdl, web_close::kPolicy,
               "too many messages (more than " + describeNumber(options.limits.client_messages_per_second) +
                   " a second)");
        return;
      }
      client->protocol->received(owner, client->id, msg->get_payload(),
                                 msg->get_opcode() != websocketpp::frame::opcode::text);
    } catch (const std::exception& e) {  // never out of the network thread
      refuse(hdl, web_close::kInvalidPayload, e.what());
    }
  }

  void refuse(Hdl hdl, std::uint16_t code, const std::string& why) {
    auto it = ids.find(hdl);
    const Client* client = it == ids.end() ? nullptr : clients.at(it->second).get();
    const std::string who = client ? std::to_string(client->id) + " (" + client->remote + ")" : "?";
    if (refuse_throttle.allow()) {
      log(WebLogLevel::Warn, "web client " + who + ": " + why + "; closing with code " + std::to_string(code));
    }
    ++closed_bad_messages;
    if (client) forget(client->id);
    websocketpp::lib::error_code ec;
    // A close reason is at most 123 bytes (RFC 6455).
    server->close(hdl, code, why.substr(0, 120), ec);
  }

  // ---- HTTP ---------------------------------------------------------------------------------------------------
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
    auto it = site.assets.find(path);
    if (it == site.assets.end()) {
      con->set_status(websocketpp::http::status_code::not_found);
      con->append_header("Content-Type", "text/plain; charset=utf-8");
      con->set_body(site.not_found);
      return;
    }
    con->set_status(static_cast<websocketpp::http::status_code::value>(it->second.status));
    con->append_header("Content-Type", it->second.type);
    con->append_header("Cache-Control", "no-cache");
    con->set_body(it->second.body);
  }

  std::string stats() {
    json list = json::array();
    for (auto& [id, client] : clients) {
      websocketpp::lib::error_code ec;
      auto con = server->get_con_from_hdl(client->hdl, ec);
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
    return dumpJson({{"frames_in", frames_in.load()},
                     {"clients", list},
                     {"send_window", options.limits.send_window},
                     {"disconnected_not_reading", disconnected_stalled},
                     {"closed_bad_messages", closed_bad_messages},
                     {"refused_full", refused_full}});
  }

  // ---- what goes out ------------------------------------------------------------------------------------------
  void postPump() {
    std::lock_guard<std::mutex> lock(post_mutex);
    if (!accepting || pump_posted.exchange(true)) return;
    boost::asio::post(server->get_io_service(), [this] { pump(); });
  }

  /// Network thread: hand the newest messages to the queue of every client of the default protocol, then send
  /// what may go.
  void pump() {
    pump_posted = false;
    std::vector<std::pair<std::string, WebPayload>> state;
    WebPayload frame;
    {
      std::lock_guard<std::mutex> lock(latest_mutex);
      for (const auto& key : dirty) state.emplace_back(key, latest[key]);
      dirty.clear();
      if (frame_dirty) frame = latest_frame;
      frame_dirty = false;
    }
    for (auto& [id, client] : clients) {
      if (client->protocol != default_protocol) continue;
      for (const auto& [key, payload] : state) client->queue.offer(key, payload);
      if (frame.data) client->queue.offerFrame(frame);
    }
    flush();
  }

  /// Send what each client's queue hands out now; wake up again when the next paced frame is due.
  void flush() {
    const double now = steadyNow();
    double next = -1;
    for (auto& [id, client] : clients) {
      websocketpp::lib::error_code ec;
      auto con = server->get_con_from_hdl(client->hdl, ec);
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

  /// Every 20 ms: drop clients that stopped reading, send what waited for a socket to drain, refresh summary.
  void houseKeep() {
    const std::size_t queued_total = dropStalled();
    flush();
    writeSummary(queued_total);
  }

  /// Close the clients whose sockets have not drained for stall_timeout; the bytes the others' sockets hold.
  std::size_t dropStalled() {
    const double now = steadyNow();
    std::vector<std::pair<WebClientId, std::string>> stalled;
    std::size_t queued_total = 0;
    for (auto& [id, client] : clients) {
      websocketpp::lib::error_code ec;
      auto con = server->get_con_from_hdl(client->hdl, ec);
      if (ec || con->get_state() != websocketpp::session::state::open) continue;
      const std::size_t queued = con->get_buffered_amount();
      queued_total += queued;
      std::string why = client->queue.stalled(now, queued);
      if (!why.empty()) stalled.emplace_back(id, why);
    }
    for (const auto& [id, why] : stalled) {
      auto it = clients.find(id);
      if (it == clients.end()) continue;
      const auto client = it->second;
      log(WebLogLevel::Warn, "disconnecting web client " + std::to_string(id) + " (" + client->remote + "): " + why);
      ++disconnected_stalled;
      websocketpp::lib::error_code ec;
      auto con = server->get_con_from_hdl(client->hdl, ec);
      forget(id);  // its queue goes now; the socket after the close handshake times out
      if (!ec) con->close(web_close::kPolicy, "not reading", ec);
    }
    return queued_total;
  }

  void writeSummary(std::size_t queued_total) {
    char text[256];
    std::snprintf(text, sizeof text, "listening on %s:%d; %zu clients, %zu bytes waiting in their sockets; %llu frames in; "
                  "%llu dropped for not reading, %llu closed for bad messages, %llu refused (full)",
                  options.address.c_str(), bound.load(), clients.size(), queued_total,
                  static_cast<unsigned long long>(frames_in.load()), static_cast<unsigned long long>(disconnected_stalled),
                  static_cast<unsigned long long>(closed_bad_messages), static_cast<unsigned long long>(refused_full));
    std::lock_guard<std::mutex> lock(summary_mutex);
    summary = text;
  }
};

// ---- WebServer ------------------------------------------------------------------------------------------------

WebServer::WebServer(WebLog log) : impl_(std::make_unique<Impl>(*this, std::move(log))) {}

WebServer::~WebServer() { stop(); }

void WebServer::addProtocol(WebProtocol& protocol, const std::string& subprotocol) {
  if (subprotocol.empty()) {
    impl_->default_protocol = &protocol;
  } else {
    impl_->protocols[subprotocol] = &protocol;
  }
}

void WebServer::start(const WebServerOptions& options, WebSite site) {
  impl_->options = options;
  impl_->site = std::move(site);
  impl_->makeServer();
  impl_->listen();
  impl_->run();
}

void WebServer::stop() { impl_->stop(); }

int WebServer::boundPort() const { return impl_->bound; }

std::string WebServer::summary() const {
  std::lock_guard<std::mutex> lock(impl_->summary_mutex);
  return impl_->summary;
}

std::uint64_t WebServer::framesIn() const { return impl_->frames_in; }

const WebServerOptions& WebServer::options() const { return impl_->options; }

void WebServer::publish(const std::string& key, WebPayload payload) {
  {
    std::lock_guard<std::mutex> lock(impl_->latest_mutex);
    impl_->latest[key] = std::move(payload);
    impl_->dirty.insert(key);
    if (key == "scene") {
      impl_->latest_frame = WebPayload();
      impl_->frame_dirty = false;
    }
  }
  impl_->postPump();
}

void WebServer::publishFrame(WebPayload payload) {
  ++impl_->frames_in;
  {
    std::lock_guard<std::mutex> lock(impl_->latest_mutex);
    impl_->latest_frame = std::move(payload);
    impl_->frame_dirty = true;
  }
  impl_->postPump();
}

bool WebServer::post(std::function<void()> task) {
  std::lock_guard<std::mutex> lock(impl_->post_mutex);
  if (!impl_->accepting) return false;
  boost::asio::post(impl_->server->get_io_service(), std::move(task));
  return true;
}

void WebServer::sendLater(WebClientId client, std::string text) {
  post([this, client, text = std::move(text)] { send(client, text); });
}

void WebServer::send(WebClientId client, const std::string& text) {
  auto it = impl_->clients.find(client);
  if (it == impl_->clients.end()) return;
  websocketpp::lib::error_code ec;
  impl_->server->send(it->second->hdl, text, websocketpp::frame::opcode::text, ec);
}

void WebServer::refuse(WebClientId client, std::uint16_t code, const std::string& why) {
  auto it = impl_->clients.find(client);
  if (it != impl_->clients.end()) impl_->refuse(it->second->hdl, code, why);
}

WebClientQueue* WebServer::queue(WebClientId client) {
  auto it = impl_->clients.find(client);
  return it == impl_->clients.end() ? nullptr : &it->second->queue;
}

void WebServer::flush() { impl_->flush(); }

}  // namespace xpersif::core
