// The browser bridge's pacing and limits (core/web_stream.h), without ROS or sockets: newest-only queues,
// the client's rate, the send window, a client that stops reading, client messages, frames and the scene.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>

#include "xpersif/core/common/validation.h"
#include "xpersif/core/web/web_stream.h"

using namespace xpersif::core;

namespace {

WebPayload text(const std::string& s) { return {std::make_shared<const std::string>(s), false}; }
WebPayload bytes(std::size_t n, char c = 'f') { return {std::make_shared<const std::string>(n, c), true}; }

WebClientLimits limits() {
  WebClientLimits l;
  l.default_rate = 10;
  l.max_rate = 1000;
  l.send_window = 1000;
  l.stall_timeout = 5;
  return l;
}

}  // namespace

TEST(WebClientQueue, SceneFirstThenStateThenFrame) {
  WebClientQueue q(limits());
  q.offerFrame(bytes(10));
  q.offer("progress", text("p"));
  q.offer("scene", text("s"));  // drops the frame offered before it (another scene's node order)
  EXPECT_EQ(q.stats().frames_dropped, 1u);
  q.offerFrame(bytes(10, 'g'));
  auto out = q.take(0, 0);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(*out[0].data, "s");
  EXPECT_EQ(*out[1].data, "p");
  EXPECT_EQ(*out[2].data, std::string(10, 'g'));
  EXPECT_TRUE(q.take(0.5, 0).empty());
  EXPECT_EQ(q.pendingMessages(), 0u);
}

TEST(WebClientQueue, NoFrameBeforeTheScene) {
  WebClientQueue q(limits());
  q.offerFrame(bytes(10));
  EXPECT_TRUE(q.take(0, 0).empty());
  EXPECT_LT(q.nextDue(0), 0);  // nothing waits for time: it waits for the scene
  q.offer("scene", text("s"));
  q.offerFrame(bytes(10));
  EXPECT_EQ(q.take(0, 0).size(), 2u);
}

TEST(WebClientQueue, KeepsOnlyTheNewestPerKey) {
  WebClientQueue q(limits());
  q.offer("scene", text("s"));
  q.take(0, 0);
  for (int i = 0; i < 100; ++i) {
    q.offer("notions", text("n" + std::to_string(i)));
    q.offerFrame(bytes(20, static_cast<char>('a' + i % 26)));
  }
  EXPECT_EQ(q.pendingMessages(), 2u);
  EXPECT_EQ(q.pendingBytes(), 3u + 20u);
  EXPECT_EQ(q.stats().frames_dropped, 99u);
  EXPECT_EQ(q.stats().state_replaced, 99u);
  auto out = q.take(1, 0);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(*out[0].data, "n99");
  EXPECT_EQ(*out[1].data, std::string(20, static_cast<char>('a' + 99 % 26)));
}

TEST(WebClientQueue, FramesAtTheClientsRate) {
  WebClientQueue q(limits());
  q.offer("scene", text("s"));
  q.take(0, 0);
  // 1 kHz of frames for 10 s at the default 10 Hz: about 100 go, the rest are dropped.
  int sent = 0;
  for (int i = 0; i < 10000; ++i) {
    const double now = i * 0.001;
    q.offerFrame(bytes(8));
    sent += static_cast<int>(q.take(now, 0).size());
  }
  EXPECT_NEAR(sent, 100, 2);
  q.setRate(30);
  sent = 0;
  for (int i = 10000; i < 20000; ++i) {
    q.offerFrame(bytes(8));
    sent += static_cast<int>(q.take(i * 0.001, 0).size());
  }
  EXPECT_NEAR(sent, 300, 3);
  q.setRate(0);  // every frame (up to max_rate)
  sent = 0;
  for (int i = 20000; i < 21000; ++i) {
    q.offerFrame(bytes(8));
    sent += static_cast<int>(q.take(i * 0.001, 0).size());
  }
  EXPECT_GE(sent, 990);
  EXPECT_EQ(q.stats().frames_offered, 21000u);
  EXPECT_EQ(q.stats().frames_sent + q.stats().frames_dropped, 21000u);
}

TEST(WebClientQueue, FramesThatComeAtTheRateWithJitterAllGo) {
  WebClientQueue q(limits());
  q.setRate(30);
  q.offer("scene", text("s"));
  q.take(0, 0);
  int sent = 0;
  for (int i = 1; i <= 300; ++i) {
    const double now = i / 30.0 + ((i % 2) ? 0.003 : -0.003);
    q.offerFrame(bytes(8));
    sent += static_cast<int>(q.take(now, 0).size());
  }
  EXPECT_EQ(sent, 300);
}

TEST(WebClientQueue, NextDueTellsWhenAWaitingFrameMayGo) {
  WebClientQueue q(limits());  // 10 Hz
  q.offer("scene", text("s"));
  q.offerFrame(bytes(8));
  EXPECT_EQ(q.nextDue(0), 0);
  EXPECT_EQ(q.take(0, 0).size(), 2u);
  q.offerFrame(bytes(8));
  EXPECT_TRUE(q.take(0.01, 0).empty());
  EXPECT_NEAR(q.nextDue(0.01), 0.1 - 0.025 - 0.01, 1e-9);
  EXPECT_EQ(q.take(0.08, 0).size(), 1u);
  EXPECT_LT(q.nextDue(0.08), 0);
}

TEST(WebClientQueue, TheSendWindowBoundsWhatWaitsInTheSocket) {
  WebClientQueue q(limits());  // window 1000 bytes
  q.setRate(0);
  q.offer("scene", text("s"));
  q.offer("curve", {std::make_shared<const std::string>(600, 'c'), false});
  q.offer("notions", {std::make_shared<const std::string>(600, 'n'), false});
  q.offerFrame(bytes(100));
  auto out = q.take(0, 0);  // the scene and the curve fit; the notions would pass 1000 bytes
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1].data->front(), 'c');
  EXPECT_TRUE(q.take(0.1, 601).empty());   // the socket still holds them
  out = q.take(0.2, 350);                  // it drained some: the notions fit (950), the frame does not
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].data->front(), 'n');
  EXPECT_EQ(q.take(0.3, 0).size(), 1u);    // the frame
  // A message larger than the window still goes once the socket is empty.
  q.offer("image", bytes(5000));
  EXPECT_TRUE(q.take(0.4, 1).empty());
  EXPECT_EQ(q.take(0.5, 0).size(), 1u);
}

TEST(WebClientQueue, MemoryStaysBoundedForAClientThatNeverReads) {
  WebClientQueue q(limits());
  q.setRate(0);
  q.offer("scene", text("s"));
  std::size_t socket = 0;  // the socket never drains: what was taken stays there
  std::size_t max_pending = 0;
  for (int i = 0; i < 100000; ++i) {
    q.offerFrame(bytes(300));
    q.offer("progress", text(std::string(50, 'p')));
    for (const auto& p : q.take(i * 0.001, socket)) socket += p.size();
    max_pending = std::max(max_pending, q.pendingBytes());
  }
  EXPECT_LE(socket, limits().send_window + 300);
  EXPECT_LE(max_pending, 300u + 50u);
}

TEST(WebClientQueue, AClientThatStopsReadingIsStalled) {
  WebClientQueue q(limits());  // stall_timeout 5 s
  EXPECT_EQ(q.stalled(0, 0), "");
  EXPECT_EQ(q.stalled(1, 500), "");
  EXPECT_EQ(q.stalled(4, 800), "");  // growing, never drained: the clock runs from t = 0
  const std::string why = q.stalled(5.5, 800);
  EXPECT_NE(why.find("stopped reading"), std::string::npos) << why;
  EXPECT_NE(why.find("800 bytes"), std::string::npos) << why;
}

TEST(WebClientQueue, AClientThatReadsSlowlyIsNotStalled) {
  WebClientQueue q(limits());
  for (int t = 0; t < 60; ++t) {
    // The queue shrinks every other second, as a client that reads now and then makes it.
    EXPECT_EQ(q.stalled(t, (t % 2) ? 900 : 400), "") << "at " << t;
  }
}

TEST(WebClientQueue, RateOutOfRangeIsRefusedAndChangesNothing) {
  WebClientQueue q(limits());
  EXPECT_THROW(q.setRate(-1), ValidationError);
  EXPECT_THROW(q.setRate(std::numeric_limits<double>::quiet_NaN()), ValidationError);
  EXPECT_THROW(q.setRate(1e6), ValidationError);
  EXPECT_EQ(q.rate(), 10);
  q.setRate(0.01);  // below 0.1 rounds up
  EXPECT_EQ(q.rate(), 0.1);
}

TEST(WebClientQueue, IncomingMessagesAreRateLimited) {
  WebClientQueue q(limits());  // 20/s, burst 40
  int allowed = 0;
  for (int i = 0; i < 100; ++i) allowed += q.allowIncoming(0.0) ? 1 : 0;
  EXPECT_EQ(allowed, 40);
  allowed = 0;
  for (int i = 0; i < 100; ++i) allowed += q.allowIncoming(1.0 + i * 0.01) ? 1 : 0;  // 1 s later, 100/s for 1 s
  EXPECT_NEAR(allowed, 40, 2);  // 20 refilled at first plus 20 during the second
}

// ---- client messages ----

TEST(ClientMessages, GoodOnesParse) {
  WebClientLimits l = limits();
  WebClientRequest r;
  EXPECT_EQ(parseClientMessage(R"({"type":"config","rate":30})", false, l, r).code, 0);
  EXPECT_TRUE(r.has_rate);
  EXPECT_EQ(r.rate, 30);
  EXPECT_EQ(parseClientMessage(R"({"type":"config","rate":"full","id":7})", false, l, r).code, 0);
  EXPECT_EQ(r.rate, 0);
  EXPECT_EQ(r.id, "7");
  EXPECT_EQ(parseClientMessage(R"({"type":"config"})", false, l, r).code, 0);
  EXPECT_FALSE(r.has_rate);
  EXPECT_EQ(parseClientMessage(R"({"type":"command","command":"pause","token":"abc"})", false, l, r).code, 0);
  EXPECT_EQ(r.kind, WebClientRequest::Kind::Command);
  EXPECT_EQ(r.command, "pause");
  EXPECT_EQ(r.token, "abc");
  EXPECT_EQ(parseClientMessage(R"({"type":"ping","id":"x1"})", false, l, r).code, 0);
  EXPECT_EQ(r.kind, WebClientRequest::Kind::Ping);
}

TEST(ClientMessages, BadOnesGetACloseCodeAndASentence) {
  WebClientLimits l = limits();
  l.max_client_message = 100;
  struct Case {
    std::string text;
    bool binary;
    std::uint16_t code;
    std::string words;
  };
  const std::vector<Case> cases = {
      {"{\"type\":\"config\"}", true, 1003, "binary"},
      {std::string(101, ' '), false, 1009, "101 bytes"},
      {"{\"type\":", false, 1007, "not JSON"},
      {"\xff\xfe", false, 1007, "not JSON"},
      {"[1,2]", false, 1007, "JSON object"},
      {"{}", false, 1007, "\"type\""},
      {"{\"type\":3}", false, 1007, "\"type\""},
      {"{\"type\":\"shutdown\"}", false, 1008, "unknown message type \"shutdown\""},
      {"{\"type\":\"config\",\"rate\":-5}", false, 1007, "out of range"},
      {"{\"type\":\"config\",\"rate\":1e9}", false, 1007, "out of range"},
      {"{\"type\":\"config\",\"rate\":\"fast\"}", false, 1007, "\"full\""},
      {"{\"type\":\"config\",\"rate\":null}", false, 1007, "\"rate\""},
      {"{\"type\":\"config\",\"extra\":1}", false, 1008, "unexpected key \"extra\""},
      {"{\"type\":\"command\"}", false, 1007, "\"command\""},
      {"{\"type\":\"command\",\"command\":\"reset\"}", false, 1008, "unknown command \"reset\""},
      {"{\"type\":\"command\",\"command\":\"pause\",\"token\":5}", false, 1007, "\"token\""},
      {"{\"type\":\"ping\",\"id\":[1]}", false, 1007, "\"id\""},
  };
  for (const auto& c : cases) {
    WebClientRequest r;
    const WebClientError e = parseClientMessage(c.text, c.binary, l, r);
    EXPECT_EQ(e.code, c.code) << c.text;
    EXPECT_NE(e.reason.find(c.words), std::string::npos) << c.text << " -> " << e.reason;
  }
}

TEST(ClientMessages, CommandsNeedTheOptionAndTheToken) {
  WebClientRequest r;
  ASSERT_EQ(parseClientMessage(R"({"type":"command","command":"resume","token":"s3cret"})", false, limits(), r).code, 0);
  EXPECT_EQ(checkCommandAllowed(r, false, "s3cret").code, web_close::kPolicy);
  EXPECT_NE(checkCommandAllowed(r, false, "s3cret").reason.find("read-only"), std::string::npos);
  EXPECT_EQ(checkCommandAllowed(r, true, "s3cret").code, 0);
  EXPECT_EQ(checkCommandAllowed(r, true, "s3creT").code, web_close::kPolicy);
  EXPECT_EQ(checkCommandAllowed(r, true, "s3cret!").code, web_close::kPolicy);
  EXPECT_EQ(checkCommandAllowed(r, true, "").code, web_close::kPolicy);  // no token configured: no commands
  WebClientRequest ping;
  ping.kind = WebClientRequest::Kind::Ping;
  EXPECT_EQ(checkCommandAllowed(ping, false, "").code, 0);
}

// ---- frames and the scene ----

TEST(WebFrames, RoundTrip) {
  WebFrame f;
  f.generation = 3;
  f.seq = 1234567890123ull;
  f.sim_time = 12.345;
  f.wall_time = 1.7e9 + 0.25;
  f.poses = {0.1f, -0.2f, 0.02f, 0, 0, 0.38268343f, 0.9238795f, 1, 2, 3, 0, 0, 0, 1};
  const std::string b = encodeFrame(f);
  EXPECT_EQ(b.size(), 36u + 2 * 28u);
  const WebFrame g = decodeFrame(b);
  EXPECT_EQ(g.generation, 3u);
  EXPECT_EQ(g.seq, f.seq);
  EXPECT_EQ(g.sim_time, f.sim_time);
  EXPECT_EQ(g.wall_time, f.wall_time);
  EXPECT_EQ(g.poses, f.poses);
  EXPECT_THROW(decodeFrame(b.substr(0, b.size() - 1)), ValidationError);
  EXPECT_THROW(decodeFrame("nonsense"), ValidationError);
  f.poses.push_back(1);
  EXPECT_THROW(encodeFrame(f), ValidationError);
}

TEST(WebScene, JsonHasEveryNodeShapeAndCamera) {
  SceneDescription s;
  s.world_file = "/some/where/worlds/mixed.yaml";
  s.robot_root = "base_link";
  s.objects = {"ball"};
  s.arena_size_x = 1.5;
  s.arena_size_y = 1.0;
  SceneNode arena;
  arena.name = "arena";
  arena.parent = "world";
  Visual floor;
  floor.shape.type = Shape::Type::Box;
  floor.shape.box_size = {1.5, 1.0, 0.01};
  floor.color = {0.2f, 0.3f, 0.4f, 1};
  arena.visuals.push_back(floor);
  SceneNode base;
  base.name = "base_link";
  base.parent = "world";
  base.dynamic = true;
  base.parent_from_node.translation() = Eigen::Vector3d(0.1, 0.2, 0.03);
  SceneNode ball;
  ball.name = "ball";
  ball.parent = "world";
  ball.dynamic = true;
  Visual sphere;
  sphere.shape.type = Shape::Type::Sphere;
  sphere.shape.radius = 0.03;
  sphere.color = {1, 0.5f, 0, 1};
  ball.visuals.push_back(sphere);
  SceneNode cam;
  cam.name = "overhead_optical";
  cam.parent = "world";
  s.nodes = {arena, base, ball, cam};
  CameraModel c;
  c.name = "overhead";
  c.frame = "overhead_optical";
  s.cameras.push_back(c);

  const auto j = nlohmann::json::parse(sceneToJson(s, 4));
  EXPECT_EQ(j["type"], "scene");
  EXPECT_EQ(j["generation"], 4);
  EXPECT_EQ(j["world_file"], "mixed.yaml");  // no server paths
  EXPECT_EQ(j["nodes"].size(), 4u);
  EXPECT_EQ(j["frame_nodes"], nlohmann::json({"base_link", "ball"}));
  EXPECT_EQ(j["nodes"][0]["visuals"][0]["type"], "box");
  EXPECT_DOUBLE_EQ(j["nodes"][0]["visuals"][0]["size"][0].get<double>(), 1.5);
  EXPECT_NEAR(j["nodes"][0]["visuals"][0]["color"][2].get<double>(), 0.4, 1e-6);
  EXPECT_DOUBLE_EQ(j["nodes"][1]["t"][1].get<double>(), 0.2);
  EXPECT_DOUBLE_EQ(j["nodes"][1]["q"][3].get<double>(), 1.0);
  EXPECT_EQ(j["nodes"][2]["visuals"][0]["type"], "sphere");
  EXPECT_DOUBLE_EQ(j["nodes"][2]["visuals"][0]["radius"].get<double>(), 0.03);
  EXPECT_EQ(j["cameras"][0]["frame"], "overhead_optical");
  EXPECT_EQ(j["arena"], nlohmann::json({1.5, 1.0}));
}

TEST(WebScene, JsonStringsSurviveBadBytes) {
  EXPECT_EQ(jsonString("a\"b"), "\"a\\\"b\"");
  EXPECT_NO_THROW(jsonString("bad \xff byte"));
}
