/**
 * @file web_bridge.h
 * @brief WEBBRIDGE (issue 18): the running system in a web browser. One WebSocket and HTTP server
 *        (core::WebServer, ROS-free: websocketpp on Boost.Asio, one network thread) serves the page
 *        (`http://ADDRESS:PORT/`, web/) and, per client, the scene once, then XPERSim's frames (every dynamic
 *        node's pose, binary) at the rate the client asks for, and the loop's state (LOOPMODEL's progress, the
 *        experiment runner's progress, MOTIVATION, MACHINELEARNING's notions, the learning curve from the
 *        knowledge base's experiments) as it changes.
 *
 * Per client a core::WebClientQueue keeps only the newest message per kind (the newest frame: a slow client
 * loses old frames, never gets a backlog), paces frames at its rate, and stops handing out messages while its
 * socket holds `~send_window` bytes; a client whose socket does not drain for `~stall_timeout` s is
 * disconnected. So a client's memory is bounded whatever it does. Client messages (JSON, see core/web_stream.h)
 * that are binary, oversized, malformed or unexpected close the connection with a close code and a log line.
 * This class only turns topics into the page's messages (core::WebServer::publish) and a client's command into
 * a LOOPMODEL service call; the page's protocol is core::WebStreamProtocol.
 *
 * On the same port, clients that ask for the subprotocol `foxglove.websocket.v1` (Foxglove, Lichtblick) speak the
 * Foxglove WebSocket protocol instead (core::FoxgloveProtocol; the topics as channels: FoxgloveTopics, issue 40;
 * doc/foxglove.md): `~foxglove_topics` as they are, `~foxglove_cameras` as JPEG, /clock as Time. That protocol is
 * read-only whatever `~allow_commands` says: it offers no publishing, services or parameters.
 *
 * Read-only by default: it only listens to topics. With `~allow_commands` and a `~token`, a client may call
 * LOOPMODEL's pause, resume and confirm (the console client's sliding-autonomy operations).
 *
 * Parameters (read on configure): `~address` [127.0.0.1], `~port` [8765; 0: any free port], `~ns` (the job's
 * namespace) [this node handle's namespace], `~rate` [30] (a client's frames per second until it asks for
 * another), `~max_rate` [1000], `~send_window` bytes [262144], `~socket_send_buffer` bytes (the kernel's
 * SO_SNDBUF per client) [65536], `~stall_timeout` s [10], `~max_clients` [128], `~max_client_message` bytes
 * [4096], `~client_messages_per_second` [20], `~curve_points` [2000], `~allow_commands` [false], `~token` [""],
 * `~web_root` [$(find xpersif)/web], `~experiment_progress_topic` [/experiment/progress], `~foxglove_topics`,
 * `~foxglove_cameras`, `~foxglove_image_rate` [5], `~foxglove_jpeg_quality` [80] (doc/parameters.md).
 * Once listening it sets `~bound_port` (the port, useful with `~port` 0). `GET /stats` answers JSON counters.
 */
#pragma once

#include <ros/ros.h>

#include <memory>

#include "xpersif/component/component.h"

namespace xpersif {

class WebBridge : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  WebBridge(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~WebBridge() override;

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;
  void fillStatus(ComponentStatus& status) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace xpersif
