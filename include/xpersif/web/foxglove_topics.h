/**
 * @file foxglove_topics.h
 * @brief WEBBRIDGE's topics as the Foxglove protocol's channels (issue 40): the ROS side of
 *        core::FoxgloveProtocol.
 *
 * Each topic of `~foxglove_topics` is subscribed as it is (topic_tools::ShapeShifter) and advertised once its first
 * message tells its type and message definition; its messages go out serialized as they came ("ros1"), stamped
 * with ros::Time::now() (simulated time under /clock), and only while a client subscribes to it (latched ones are
 * kept for the clients that come later). /clock also becomes the clients' Time frames.
 *
 * Each raw camera topic of `~foxglove_cameras` is advertised at once as `<topic>/compressed`
 * (sensor_msgs/CompressedImage, JPEG), subscribed only while a client subscribes to that channel, and encoded at
 * most `~foxglove_image_rate` times a (wall) second.
 */
#pragma once

#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <topic_tools/shape_shifter.h>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "xpersif/core/web/foxglove_protocol.h"

namespace xpersif {

class FoxgloveTopics {
 public:
  struct Options {
    std::vector<std::string> topics;   ///< resolved names
    std::vector<std::string> cameras;  ///< resolved raw image topics
    double image_rate = 5;             ///< JPEGs per wall second per camera at most
    int jpeg_quality = 80;
  };

  /// @p name prefixes log lines.
  FoxgloveTopics(core::FoxgloveProtocol& protocol, std::string name);
  ~FoxgloveTopics();

  /// Subscribe the topics and /clock, and advertise the cameras' channels (once: they stay advertised).
  void start(ros::NodeHandle& nh, const Options& options);
  /// Unsubscribe everything.
  void stop();
  /// On the protocol's network thread: a channel got its first client, or lost its last one.
  void interestChanged(std::uint32_t channel, bool wanted);

 private:
  struct Topic {
    std::string name;
    std::uint32_t channel = 0;  ///< 0 until the first message advertised it
    std::string md5;
    bool latched = false;
  };
  struct Camera {
    std::string raw_topic;
    std::uint32_t channel = 0;
    ros::Subscriber subscriber;
    std::atomic<double> next_wall{0};  ///< earliest wall time of the next JPEG
  };

  void onMessage(Topic& topic, const ros::MessageEvent<const topic_tools::ShapeShifter>& event);
  bool advertiseOnce(Topic& topic, const topic_tools::ShapeShifter& message, bool latched);
  void onImage(Camera& camera, const sensor_msgs::Image& image);
  void advertiseCameras();
  void interestChangedLocked(std::uint32_t channel, bool wanted);

  core::FoxgloveProtocol& protocol_;
  std::string name_;
  ros::NodeHandle nh_;
  Options options_;

  std::mutex mutex_;  // topics' channels, cameras' subscribers, started_
  bool started_ = false;
  std::vector<std::unique_ptr<Topic>> topics_;
  std::vector<std::unique_ptr<Camera>> cameras_;
  std::vector<ros::Subscriber> subscribers_;
};

}  // namespace xpersif
