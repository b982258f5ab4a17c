// The browser bridge's server (core/web_server.h) and the page's protocol on it (core/web_stream_protocol.h),
// without ROS: started on a free loopback port, spoken to by websocketpp's client and by plain HTTP over a socket.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <nlohmann/json.hpp>
#include <websocketpp/client.hpp>
#include <websocketpp/config/asio_no_tls_client.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>

#include "xpersif/core/web/web_server.h"
#include "xpersif/core/web/web_stream_protocol.h"
#include "web_test_client.h"

using namespace xpersif::core;
using xpersif::test::Received;
using xpersif::test::TestClient;
using json = nlohmann::json;

namespace {

WebPayload text(const std::string& s) { return {std::make_shared<const std::string>(s), false}; }

/// An HTTP request over a plain socket; the whole answer (status line, headers, body) as the server sent it.
std::string http(int port, const std::string& method, const std::string& path) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  inet_pton(AF_INET, "127.0.0.1", &address.sin_addr);
  timeval timeout{5, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    close(fd);
    return "";
  }
  const std::string request = method + " " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
  send(fd, request.data(), request.size(), 0);
  std::string answer;
  char buffer[4096];
  for (ssize_t n; (n = recv(fd, buffer, sizeof buffer, 0)) > 0;) answer.append(buffer, static_cast<std::size_t>(n));
  close(fd);
  return answer;
}

/// A second protocol beside the page's: echoes what it gets, and counts its clients.
class EchoProtocol : public WebProtocol {
 public:
  void opened(WebServer&, WebClientId) override { ++open; }
  void received(WebServer& server, WebClientId client, const std::string& data, bool) override {
    server.send(client, "echo " + data);
  }
  void closed(WebServer&, WebClientId) override { --open; }
  std::atomic<int> open{0};
};

class WebServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server.addProtocol(protocol);
    server.addProtocol(echo, "echo.v1");
    protocol.start(true, "secret-token");
    WebSite site;
    site.assets["/hello.txt"] = WebAsset{200, "text/plain; charset=utf-8", "hello"};
    site.not_found = "not here\n";
    WebServerOptions options;
    options.port = 0;
    options.limits.max_client_message = 256;
    server.start(options, site);
    port = server.boundPort();
  }
  void TearDown() override {
    protocol.stop();
    server.stop();
  }

  std::mutex log_mutex;
  std::vector<std::string> log;
  std::vector<std::string> commands;
  WebServer server{[this](WebLogLevel, const std::string& line) {
    std::lock_guard<std::mutex> lock(log_mutex);
    log.push_back(line);
  }};
  WebStreamProtocol protocol{server, [this](const std::string& command) {
                               commands.push_back(command);  // one worker thread: no lock needed
                               return WebCommandResult{true, "done: " + command};
                             }};
  EchoProtocol echo;
  int port = 0;
};

}  // namespace

TEST_F(WebServerTest, ListensOnAFreePortAndSaysSo) {
  EXPECT_GT(port, 0);
  // The summary is written by the network thread's housekeeping, every 20 ms.
  for (int i = 0; i < 100 && server.summary() == "not listening"; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(server.summary().rfind("listening on 127.0.0.1:" + std::to_string(port), 0), 0u) << server.summary();
  server.stop();
  EXPECT_EQ(server.boundPort(), 0);
  EXPECT_EQ(server.summary(), "not listening");
}

TEST_F(WebServerTest, ServesItsFilesStatsAndNothingElse) {
  const std::string page = http(port, "GET", "/hello.txt?x=1");
  EXPECT_EQ(page.rfind("HTTP/1.1 200", 0), 0u) << page;
  EXPECT_NE(page.find("Content-Type: text/plain; charset=utf-8"), std::string::npos) << page;
  EXPECT_NE(page.find("Cache-Control: no-cache"), std::string::npos) << page;
  EXPECT_EQ(page.substr(page.size() - 5), "hello");

  const std::string missing = http(port, "GET", "/../hello.txt");
  EXPECT_EQ(missing.rfind("HTTP/1.1 404", 0), 0u) << missing;
  EXPECT_EQ(missing.substr(missing.size() - 9), "not here\n");

  const std::string post = http(port, "POST", "/hello.txt");
  EXPECT_EQ(post.rfind("HTTP/1.1 405", 0), 0u) << post;

  server.publishFrame({std::make_shared<const std::string>("f"), true});
  const std::string stats = http(port, "GET", "/stats");
  EXPECT_NE(stats.find("Cache-Control: no-store"), std::string::npos) << stats;
  const json j = json::parse(stats.substr(stats.find("\r\n\r\n") + 4));
  EXPECT_EQ(j["frames_in"], 1);
  EXPECT_EQ(j["clients"], json::array());
}

TEST_F(WebServerTest, ANewClientGetsTheSceneThenTheState) {
  server.publish("scene", text(R"({"type":"scene"})"));
  server.publish("loop", text(R"({"type":"loop"})"));
  TestClient client(port);
  ASSERT_TRUE(client.waitOpen());
  EXPECT_EQ(client.nextJson()["type"], "scene");
  EXPECT_EQ(client.nextJson()["type"], "loop");
  server.publish("loop", text(R"({"type":"loop","state":"running"})"));
  EXPECT_EQ(client.nextJson()["state"], "running");
}

TEST_F(WebServerTest, PingAndConfigAreAnswered) {
  TestClient client(port);
  ASSERT_TRUE(client.waitOpen());
  client.send(R"({"type":"ping","id":"p1"})");
  json pong = client.nextJson();
  EXPECT_EQ(pong["type"], "pong");
  EXPECT_EQ(pong["id"], "p1");
  EXPECT_GT(pong["wall_time"].get<double>(), 1e9);  // Unix seconds
  client.send(R"({"type":"config","rate":"full","id":7})");
  json config = client.nextJson();
  EXPECT_EQ(config["type"], "config");
  EXPECT_EQ(config["id"], "7");
  EXPECT_EQ(config["rate"], 0);
}

TEST_F(WebServerTest, ACommandWithTheTokenRunsOnTheWorker) {
  TestClient client(port);
  ASSERT_TRUE(client.waitOpen());
  client.send(R"({"type":"command","command":"pause","token":"secret-token","id":"c"})");
  json answer = client.nextJson();
  EXPECT_EQ(answer["type"], "command_result");
  EXPECT_EQ(answer["id"], "c");
  EXPECT_EQ(answer["success"], true);
  EXPECT_EQ(answer["message"], "done: pause");
  EXPECT_EQ(commands, std::vector<std::string>{"pause"});
}

TEST_F(WebServerTest, BadMessagesCloseTheClientWithTheirCode) {
  {
    TestClient client(port);
    ASSERT_TRUE(client.waitOpen());
    client.send("{not json");
    EXPECT_EQ(client.closeCode(), web_close::kInvalidPayload);
  }
  {
    TestClient client(port);
    ASSERT_TRUE(client.waitOpen());
    client.send(R"({"type":"command","command":"pause","token":"wrong-token"})");
    EXPECT_EQ(client.closeCode(), web_close::kPolicy);
  }
  {
    TestClient client(port);
    ASSERT_TRUE(client.waitOpen());
    client.send(R"({"type":"ping","id":")" + std::string(300, 'x') + "\"}");  // over max_client_message
    EXPECT_EQ(client.closeCode(), web_close::kTooBig);
  }
  const std::string stats = http(port, "GET", "/stats");
  EXPECT_EQ(json::parse(stats.substr(stats.find("\r\n\r\n") + 4))["closed_bad_messages"], 3);
  EXPECT_TRUE(commands.empty());
}

TEST_F(WebServerTest, ASubprotocolChoosesItsProtocol) {
  server.publish("scene", text(R"({"type":"scene"})"));
  {
    TestClient client(port, "echo.v1");
    ASSERT_TRUE(client.waitOpen());
    EXPECT_EQ(client.subprotocol(), "echo.v1");
    client.send("hi");
    auto r = client.next();  // the echo, not the page's scene: broadcasts go to the default protocol's clients
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->data, "echo hi");
    EXPECT_EQ(echo.open, 1);
  }
  for (int i = 0; i < 100 && echo.open != 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(echo.open, 0);
  // A subprotocol no protocol here speaks: the page's protocol, as before there were others.
  TestClient page(port, "unknown.v1");
  ASSERT_TRUE(page.waitOpen());
  EXPECT_EQ(page.subprotocol(), "");
  EXPECT_EQ(page.nextJson()["type"], "scene");
}
