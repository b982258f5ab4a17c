// The Foxglove WebSocket protocol (core/foxglove_protocol.h) beside the page's protocol on one WebServer, without
// ROS: its frames byte by byte, its parser's refusals, and a websocketpp client that asks for foxglove.websocket.v1.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <vector>

#include "web_test_client.h"
#include "xpersif/core/web/foxglove_protocol.h"
#include "xpersif/core/web/web_stream_protocol.h"

using namespace xpersif::core;
using xpersif::test::Received;
using xpersif::test::TestClient;
using json = nlohmann::json;

namespace {

template <class T>
T readLittleEndian(const std::string& bytes, std::size_t at) {
  T value = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) value |= T{static_cast<unsigned char>(bytes.at(at + i))} << (8 * i);
  return value;
}

struct MessageData {
  std::uint32_t subscription = 0;
  std::uint64_t stamp_ns = 0;
  std::string message;
};

MessageData decodeMessageData(const std::string& bytes) {
  EXPECT_GE(bytes.size(), 13u);
  EXPECT_EQ(bytes.at(0), 0x01);
  return {readLittleEndian<std::uint32_t>(bytes, 1), readLittleEndian<std::uint64_t>(bytes, 5), bytes.substr(13)};
}

/// The next binary message (text ones skipped); nothing within the timeout.
std::optional<std::string> nextBinary(TestClient& client) {
  while (auto r = client.next()) {
    if (r->binary) return r->data;
  }
  return std::nullopt;
}

FoxgloveChannel channel(const std::string& topic, bool latched = false) {
  FoxgloveChannel c;
  c.topic = topic;
  c.schema_name = "std_msgs/String";
  c.schema = "string data\n";
  c.latched = latched;
  return c;
}

class FoxgloveProtocolTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server.addProtocol(page);
    server.addProtocol(foxglove, kFoxgloveSubprotocol);
    page.start(false, "");
    foxglove.start();
    WebServerOptions options;
    options.port = 0;
    server.start(options, WebSite());
    port = server.boundPort();
  }
  void TearDown() override {
    page.stop();
    server.stop();
  }

  /// A Foxglove client past serverInfo and the advertisement of the channels there are.
  std::unique_ptr<TestClient> connect() {
    auto client = std::make_unique<TestClient>(port, kFoxgloveSubprotocol);
    EXPECT_TRUE(client->waitOpen());
    EXPECT_EQ(client->nextJson()["op"], "serverInfo");
    if (!foxglove.channels().empty()) {
      EXPECT_EQ(client->nextJson()["op"], "advertise");
    }
    return client;
  }

  void subscribe(TestClient& client, std::uint32_t subscription, std::uint32_t channel_id) {
    const json subscriptions = json::array({{{"id", subscription}, {"channelId", channel_id}}});
    client.send(dumpJson({{"op", "subscribe"}, {"subscriptions", subscriptions}}));
  }

  /// Wait until @p channel_id has @p count subscribers (the subscription is handled on the network thread).
  bool waitSubscribers(std::uint32_t channel_id, std::size_t count) {
    for (int i = 0; i < 500; ++i) {
      if (foxglove.subscribers(channel_id) == count) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }

  WebServer server{[](WebLogLevel, const std::string&) {}};
  WebStreamProtocol page{server, [](const std::string&) { return WebCommandResult{}; }};
  std::mutex interest_mutex;
  std::vector<std::pair<std::uint32_t, bool>> interest;
  FoxgloveProtocol foxglove{server, "xpersif test", [this](std::uint32_t c, bool wanted) {
                              std::lock_guard<std::mutex> lock(interest_mutex);
                              interest.emplace_back(c, wanted);
                            }};
  int port = 0;
};

}  // namespace

TEST(FoxgloveFrames, MessageDataAndTimeAreLittleEndianWithTheirOpcodes) {
  const std::string data = encodeFoxgloveMessage(0x01020304u, 0x1122334455667788ull, "abc");
  const std::string want("\x01\x04\x03\x02\x01\x88\x77\x66\x55\x44\x33\x22\x11" "abc", 16);
  EXPECT_EQ(data, want);
  const std::string time = encodeFoxgloveTime(1500000000ull);
  ASSERT_EQ(time.size(), 9u);
  EXPECT_EQ(time[0], 0x02);
  EXPECT_EQ(readLittleEndian<std::uint64_t>(time, 1), 1500000000ull);
}

TEST(FoxgloveRequests, SubscribeAndUnsubscribeAreTaken) {
  FoxgloveRequest r;
  EXPECT_EQ(parseFoxgloveRequest(R"({"op":"subscribe","subscriptions":[{"id":7,"channelId":2}]})", false, r).code, 0);
  ASSERT_EQ(r.subscribe.size(), 1u);
  EXPECT_EQ(r.subscribe[0], std::make_pair(7u, 2u));
  EXPECT_EQ(parseFoxgloveRequest(R"({"op":"unsubscribe","subscriptionIds":[7,8]})", false, r).code, 0);
  EXPECT_EQ(r.kind, FoxgloveRequest::Kind::Unsubscribe);
  EXPECT_EQ(r.unsubscribe, (std::vector<std::uint32_t>{7, 8}));
}

TEST(FoxgloveRequests, PublishingAndUnknownOpsAreRefusedWithAReason) {
  FoxgloveRequest r;
  WebClientError e = parseFoxgloveRequest(std::string("\x01\x00\x00\x00\x01xyz", 8), true, r);
  EXPECT_EQ(e.code, web_close::kPolicy);
  EXPECT_NE(e.reason.find("read-only"), std::string::npos) << e.reason;
  e = parseFoxgloveRequest(R"({"op":"advertise","channels":[{"id":1,"topic":"/cmd_vel"}]})", false, r);
  EXPECT_EQ(e.code, web_close::kPolicy);
  EXPECT_NE(e.reason.find("clientPublish"), std::string::npos) << e.reason;
  e = parseFoxgloveRequest(R"({"op":"setParameters","parameters":[]})", false, r);
  EXPECT_EQ(e.code, web_close::kPolicy);
  EXPECT_NE(e.reason.find("setParameters"), std::string::npos) << e.reason;
}

TEST(FoxgloveRequests, MalformedMessagesAreRefusedAsInvalid) {
  FoxgloveRequest r;
  for (const char* bad : {"not json", "[1]", R"({"subscriptions":[]})", R"({"op":"subscribe"})",
                          R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]})",
                          R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":4294967296}]})",
                          R"({"op":"unsubscribe","subscriptionIds":["a"]})"}) {
    const WebClientError e = parseFoxgloveRequest(bad, false, r);
    EXPECT_EQ(e.code, web_close::kInvalidPayload) << bad;
    EXPECT_FALSE(e.reason.empty()) << bad;
  }
}

TEST_F(FoxgloveProtocolTest, AClientGetsServerInfoAndTheChannelsWithTheirSchemas) {
  foxglove.advertise(channel("/tf"));
  TestClient client(port, kFoxgloveSubprotocol);
  ASSERT_TRUE(client.waitOpen());
  EXPECT_EQ(client.subprotocol(), kFoxgloveSubprotocol);
  const json info = client.nextJson();
  EXPECT_EQ(info["op"], "serverInfo");
  EXPECT_EQ(info["name"], "xpersif test");
  EXPECT_EQ(info["capabilities"], json::array({"time"}));  // no clientPublish, services or parameters
  const json advertise = client.nextJson();
  ASSERT_EQ(advertise["op"], "advertise");
  ASSERT_EQ(advertise["channels"].size(), 1u);
  EXPECT_EQ(advertise["channels"][0]["topic"], "/tf");
  EXPECT_EQ(advertise["channels"][0]["encoding"], "ros1");
  EXPECT_EQ(advertise["channels"][0]["schemaName"], "std_msgs/String");
  EXPECT_EQ(advertise["channels"][0]["schema"], "string data\n");

  // A channel that comes later is advertised to the clients there are.
  const std::uint32_t later = foxglove.advertise(channel("/later"));
  const json more = client.nextJson();
  EXPECT_EQ(more["channels"][0]["id"], later);
}

TEST_F(FoxgloveProtocolTest, ASubscriberGetsItsChannelsMessagesUnderItsSubscriptionId) {
  const std::uint32_t tf = foxglove.advertise(channel("/tf"));
  const std::uint32_t other = foxglove.advertise(channel("/other"));
  auto client = connect();
  subscribe(*client, 42, tf);
  ASSERT_TRUE(waitSubscribers(tf, 1));
  foxglove.publish(other, "/sim", 1, "not for this client");
  foxglove.publish(tf, "/sim", 123456789, "pose bytes");
  const auto frame = nextBinary(*client);
  ASSERT_TRUE(frame);
  const MessageData data = decodeMessageData(*frame);
  EXPECT_EQ(data.subscription, 42u);
  EXPECT_EQ(data.stamp_ns, 123456789u);
  EXPECT_EQ(data.message, "pose bytes");

  client->send(R"({"op":"unsubscribe","subscriptionIds":[42]})");
  ASSERT_TRUE(waitSubscribers(tf, 0));
  foxglove.publish(tf, "/sim", 2, "after unsubscribing");
  EXPECT_FALSE(nextBinary(*client));
}

TEST_F(FoxgloveProtocolTest, TheFirstAndLastSubscriberOfAChannelAreAnnounced) {
  const std::uint32_t camera = foxglove.advertise(channel("/camera/image_raw/compressed"));
  {
    auto a = connect();
    auto b = connect();
    subscribe(*a, 1, camera);
    subscribe(*b, 5, camera);
    ASSERT_TRUE(waitSubscribers(camera, 2));
  }  // both go
  ASSERT_TRUE(waitSubscribers(camera, 0));
  std::lock_guard<std::mutex> lock(interest_mutex);
  EXPECT_EQ(interest, (std::vector<std::pair<std::uint32_t, bool>>{{camera, true}, {camera, false}}));
}

TEST_F(FoxgloveProtocolTest, ALatchedChannelGivesEachPublishersNewestToALateSubscriber) {
  const std::uint32_t statics = foxglove.advertise(channel("/tf_static", true));
  foxglove.publish(statics, "/sim", 1, "old");
  foxglove.publish(statics, "/sim", 2, "sim's newest");
  foxglove.publish(statics, "/robot", 3, "robot's");
  auto client = connect();
  subscribe(*client, 9, statics);
  std::vector<std::string> got;
  for (int i = 0; i < 2; ++i) {
    const auto frame = nextBinary(*client);
    ASSERT_TRUE(frame);
    got.push_back(decodeMessageData(*frame).message);
  }
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, (std::vector<std::string>{"robot's", "sim's newest"}));
}

TEST_F(FoxgloveProtocolTest, PageAndFoxgloveClientsGetOnlyTheirOwnProtocolsMessages) {
  const std::uint32_t tf = foxglove.advertise(channel("/tf"));
  auto fox = connect();
  TestClient page_client(port);
  ASSERT_TRUE(page_client.waitOpen());
  subscribe(*fox, 1, tf);
  ASSERT_TRUE(waitSubscribers(tf, 1));
  server.publish("scene", {std::make_shared<const std::string>(R"({"type":"scene"})"), false});  // frames follow it
  server.publishFrame({std::make_shared<const std::string>("XPF1 page frame"), true});
  foxglove.publish(tf, "/sim", 5, "foxglove message");
  foxglove.publishTime(7);
  std::vector<std::string> fox_got;
  for (int i = 0; i < 2; ++i) {
    const auto frame = nextBinary(*fox);
    ASSERT_TRUE(frame);
    fox_got.push_back(*frame);
  }
  for (const auto& f : fox_got) EXPECT_TRUE(f[0] == 0x01 || f[0] == 0x02) << f;
  EXPECT_NE(std::find(fox_got.begin(), fox_got.end(), encodeFoxgloveTime(7)), fox_got.end());
  EXPECT_EQ(nextBinary(page_client), std::optional<std::string>("XPF1 page frame"));
  EXPECT_FALSE(nextBinary(page_client));  // nothing of Foxglove's
}

TEST_F(FoxgloveProtocolTest, AClientThatTriesToPublishIsClosedWithTheReason) {
  foxglove.advertise(channel("/tf"));
  auto advertiser = connect();
  advertiser->send(R"({"op":"advertise","channels":[{"id":1,"topic":"/cmd_vel","encoding":"ros1",)"
                   R"("schemaName":"geometry_msgs/Twist"}]})");
  EXPECT_EQ(advertiser->closeCode(), web_close::kPolicy);
  EXPECT_NE(advertiser->closeReason().find("read-only"), std::string::npos) << advertiser->closeReason();

  auto publisher = connect();
  publisher->send(std::string("\x01\x01\x00\x00\x00payload", 12), true);
  EXPECT_EQ(publisher->closeCode(), web_close::kPolicy);
  EXPECT_NE(publisher->closeReason().find("may not publish"), std::string::npos) << publisher->closeReason();
}

TEST_F(FoxgloveProtocolTest, AnUnknownChannelGetsAnErrorStatusAndTheClientStays) {
  const std::uint32_t tf = foxglove.advertise(channel("/tf"));
  auto client = connect();
  subscribe(*client, 1, tf + 100);
  const json status = client->nextJson();
  EXPECT_EQ(status["op"], "status");
  EXPECT_EQ(status["level"], 2);
  subscribe(*client, 1, tf);
  ASSERT_TRUE(waitSubscribers(tf, 1));
  foxglove.publish(tf, "/sim", 1, "still served");
  const auto frame = nextBinary(*client);
  ASSERT_TRUE(frame);
  EXPECT_EQ(decodeMessageData(*frame).message, "still served");
}
