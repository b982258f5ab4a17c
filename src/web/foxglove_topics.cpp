#include "xpersif/web/foxglove_topics.h"

#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/CompressedImage.h>

#include "xpersif/core/web/jpeg_image.h"

namespace xpersif {

namespace {

double wallNow() { return ros::WallTime::now().toSec(); }

template <class M>
std::string serialize(const M& message) {
  std::string bytes(ros::serialization::serializationLength(message), '\0');
  ros::serialization::OStream stream(reinterpret_cast<std::uint8_t*>(bytes.data()),
                                     static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::serialize(stream, message);
  return bytes;
}

}  // namespace

FoxgloveTopics::FoxgloveTopics(core::FoxgloveProtocol& protocol, std::string name)
    : protocol_(protocol), name_(std::move(name)) {}

FoxgloveTopics::~FoxgloveTopics() { stop(); }

void FoxgloveTopics::start(ros::NodeHandle& nh, const Options& options) {
  std::lock_guard<std::mutex> lock(mutex_);
  nh_ = nh;
  options_ = options;
  started_ = true;
  const auto hints = ros::TransportHints().tcpNoDelay();
  for (const auto& name : options.topics) {
    topics_.push_back(std::make_unique<Topic>());
    Topic& topic = *topics_.back();
    topic.name = name;
    // A MessageEvent: the connection header says whether the topic is latched, and who published.
    const boost::function<void(const ros::MessageEvent<const topic_tools::ShapeShifter>&)> callback =
        [this, &topic](const ros::MessageEvent<const topic_tools::ShapeShifter>& e) { onMessage(topic, e); };
    subscribers_.push_back(nh.subscribe<topic_tools::ShapeShifter>(name, 10, callback, ros::VoidConstPtr(), hints));
  }
  // The clients' Time frames: the clock the message stamps come from.
  subscribers_.push_back(nh.subscribe<rosgraph_msgs::Clock>(
      "/clock", 1, [this](const rosgraph_msgs::Clock::ConstPtr& c) { protocol_.publishTime(c->clock.toNSec()); },
      ros::VoidConstPtr(), hints));
  advertiseCameras();
}

void FoxgloveTopics::advertiseCameras() {
  for (const auto& raw : options_.cameras) {
    cameras_.push_back(std::make_unique<Camera>());
    Camera& camera = *cameras_.back();
    camera.raw_topic = raw;
    core::FoxgloveChannel channel;
    channel.topic = raw + "/compressed";
    channel.schema_name = ros::message_traits::datatype<sensor_msgs::CompressedImage>();
    channel.schema = ros::message_traits::definition<sensor_msgs::CompressedImage>();
    camera.channel = protocol_.advertise(channel);
    // A client may have subscribed before a restart of the bridge: it still wants the images.
    if (protocol_.subscribers(camera.channel) > 0) interestChangedLocked(camera.channel, true);
  }
}

void FoxgloveTopics::stop() {
  std::vector<ros::Subscriber> going;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    started_ = false;
    going.swap(subscribers_);
    for (auto& camera : cameras_) going.push_back(std::move(camera->subscriber));
  }
  // Outside the lock: shutdown() waits for a running callback, which may want the lock.
  for (auto& subscriber : going) subscriber.shutdown();
  std::lock_guard<std::mutex> lock(mutex_);
  topics_.clear();
  cameras_.clear();
}

void FoxgloveTopics::interestChanged(std::uint32_t channel, bool wanted) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (started_) interestChangedLocked(channel, wanted);
}

void FoxgloveTopics::interestChangedLocked(std::uint32_t channel, bool wanted) {
  for (auto& camera : cameras_) {
    if (camera->channel != channel) continue;
    if (!wanted) {
      camera->subscriber = ros::Subscriber();  // the last client went: the raw images stop coming here
      continue;
    }
    Camera* c = camera.get();
    camera->subscriber =
        nh_.subscribe<sensor_msgs::Image>(c->raw_topic, 1, [this, c](const sensor_msgs::Image::ConstPtr& image) {
          onImage(*c, *image);
        });
    ROS_INFO("%s: a Foxglove client watches %s/compressed: subscribed to it", name_.c_str(), c->raw_topic.c_str());
  }
}

void FoxgloveTopics::onMessage(Topic& topic, const ros::MessageEvent<const topic_tools::ShapeShifter>& event) {
  const topic_tools::ShapeShifter& message = *event.getConstMessage();
  const auto& header = event.getConnectionHeader();
  auto latching = header.find("latching");
  const bool latched = latching != header.end() && latching->second == "1";
  if (!advertiseOnce(topic, message, latched)) return;
  // Nobody watches: no copy, unless a later client is to get it (a latched topic).
  if (!topic.latched && protocol_.subscribers(topic.channel) == 0) return;
  std::string bytes(message.size(), '\0');
  ros::serialization::OStream stream(reinterpret_cast<std::uint8_t*>(bytes.data()), message.size());
  message.write(stream);
  protocol_.publish(topic.channel, event.getPublisherName(), ros::Time::now().toNSec(), std::move(bytes));
}

bool FoxgloveTopics::advertiseOnce(Topic& topic, const topic_tools::ShapeShifter& message, bool latched) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (topic.channel != 0) {
    if (topic.md5 == message.getMD5Sum()) return true;
    ROS_WARN_THROTTLE(10, "%s: %s carries %s as well as its first type: those messages are not sent to Foxglove",
                      name_.c_str(), topic.name.c_str(), message.getDataType().c_str());
    return false;
  }
  core::FoxgloveChannel channel;
  channel.topic = topic.name;
  channel.schema_name = message.getDataType();
  channel.schema = message.getMessageDefinition();
  channel.latched = latched;
  topic.md5 = message.getMD5Sum();
  topic.latched = latched;
  topic.channel = protocol_.advertise(channel);
  ROS_INFO("%s: Foxglove channel %u: %s (%s)", name_.c_str(), topic.channel, topic.name.c_str(),
           channel.schema_name.c_str());
  return true;
}

void FoxgloveTopics::onImage(Camera& camera, const sensor_msgs::Image& image) {
  const double now = wallNow();
  if (now < camera.next_wall.load() || protocol_.subscribers(camera.channel) == 0) return;
  camera.next_wall = now + 1.0 / options_.image_rate;
  sensor_msgs::CompressedImage compressed;
  compressed.header = image.header;
  compressed.format = "jpeg";
  try {
    compressed.data = core::encodeJpeg(
        {image.width, image.height, image.step, image.encoding, image.data.data(), image.data.size()},
        options_.jpeg_quality);
  } catch (const std::exception& e) {  // never out of a callback
    ROS_ERROR_THROTTLE(10, "%s: %s is not sent to Foxglove: %s", name_.c_str(), camera.raw_topic.c_str(), e.what());
    return;
  }
  protocol_.publish(camera.channel, "jpeg", ros::Time::now().toNSec(), serialize(compressed));
}

}  // namespace xpersif
