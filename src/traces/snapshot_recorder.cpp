#include "xpersif/traces/snapshot_recorder.h"

#include "xpersif/component/parameter_reader.h"

#include <rosbag/bag.h>
#include <std_msgs/String.h>
#include <std_srvs/Trigger.h>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace xpersif {

namespace fs = std::filesystem;

SnapshotRecorder::SnapshotRecorder(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/SnapshotRecorderNodelet") {
  core::Contract snapshot;
  snapshot.name = "snapshot";
  snapshot.kind = core::Contract::Kind::Operation;
  snapshot.interface_type = "std_srvs/Trigger";
  snapshot.description = "write the last ~seconds of the buffered topics to run_dir/snapshot_<time>.bag now";
  snapshot.effects = {"queued(snapshot)"};
  addOperation<std_srvs::Trigger>(ContractChecker<std_srvs::Trigger::Request>(snapshot), nullptr,
                                  [this](const std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
                                    response.message = queueSnapshot("snapshot");
                                  });
}

SnapshotRecorder::~SnapshotRecorder() { stopWorker(); }

const core::ParameterTable& SnapshotRecorder::parameters() {
  static const core::ParameterTable table(
      "snapshot_recorder",
      {core::namesParameter("topics",
                            {"/tf", "/xpersif/knowledge_base/experiments", "/xpersif/motivation/motivation",
                             "/xpersif/vision/features", "/xpersif/observation/features",
                             "/xpersif/machine_learning/notions"},
                            256, "the topics kept in the ring buffer"),
       core::numberParameter("seconds", 10.0, 1e-3, 86400.0, "s of simulated time kept before a surprise"),
       core::numberParameter("max_bytes", 200.0 * 1024 * 1024, 1024.0, 1e12, "bytes the ring buffer holds at most"),
       core::numberParameter("threshold", 0.05, -1e9, 1e9, "m: a surprise above this writes a snapshot"),
       core::derivedParameter(core::ParameterSpec::Type::Double, "min_interval", "~seconds", 0.0, 1e9,
                              "s of simulated time between two snapshots"),
       core::textParameter("run_dir", ".", "the directory the snapshots are written to"),
       core::textParameter("motivation_topic", "/xpersif/motivation/motivation", "MOTIVATION's surprise")});
  return table;
}

void SnapshotRecorder::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, SnapshotRecorder::parameters());
  const std::vector<std::string> topics = parameters.get<std::vector<std::string>>("topics");
  const double seconds = parameters.get<double>("seconds");
  const double max_bytes = parameters.get<double>("max_bytes");
  const double threshold = parameters.get<double>("threshold");
  const double min_interval = parameters.get<double>("min_interval", seconds);
  const std::string run_dir = parameters.get<std::string>("run_dir");
  const std::string motivation_topic = parameters.get<std::string>("motivation_topic");
  std::error_code ec;
  fs::create_directories(run_dir, ec);
  if (!fs::is_directory(run_dir, ec)) throw core::ValidationError("~run_dir '" + run_dir + "' cannot be created");
  topics_ = topics;
  seconds_ = seconds;
  max_bytes_ = static_cast<std::size_t>(max_bytes);
  threshold_ = threshold;
  min_interval_ = min_interval;
  run_dir_ = run_dir;
  motivation_topic_ = motivation_topic;
  if (!snapshots_pub_) snapshots_pub_ = pnh.advertise<std_msgs::String>("snapshots", 10);
  std::lock_guard<std::mutex> lock(jobs_mutex_);
  if (!worker_.joinable()) {
    stop_ = false;
    worker_ = std::thread([this] { work(); });
  }
}

void SnapshotRecorder::onActivate() {
  ros::NodeHandle& nh = nodeHandle();
  for (const auto& topic : topics_) {
    boost::function<void(const ros::MessageEvent<topic_tools::ShapeShifter const>&)> cb =
        [this, topic](const ros::MessageEvent<topic_tools::ShapeShifter const>& e) { onMessage(topic, e); };
    subscribers_.push_back(nh.subscribe<topic_tools::ShapeShifter>(topic, 1000, cb));
  }
  motivation_sub_ = nh.subscribe(motivation_topic_, 10, &SnapshotRecorder::onMotivation, this);
}

void SnapshotRecorder::onDeactivate() {
  // Not under mutex_: a running callback may be waiting for it.
  motivation_sub_.shutdown();
  for (auto& s : subscribers_) s.shutdown();
  subscribers_.clear();
  std::lock_guard<std::mutex> lock(mutex_);
  buffer_.clear();
  bytes_ = 0;
}

void SnapshotRecorder::onShutdown() {
  onDeactivate();
  stopWorker();  // writes the snapshots still queued first
}

void SnapshotRecorder::stopWorker() {
  {
    std::lock_guard<std::mutex> lock(jobs_mutex_);
    stop_ = true;
  }
  jobs_cv_.notify_all();
  if (worker_.joinable() && worker_.get_id() != std::this_thread::get_id()) worker_.join();
}

void SnapshotRecorder::fillStatus(ComponentStatus& status) {
  PartStatus part;
  part.name = "buffer";
  part.state = status.state;
  part.state_name = status.state_name;
  part.health = ComponentStatus::HEALTH_OK;
  std::lock_guard<std::mutex> lock(mutex_);
  const double span = buffer_.empty() ? 0.0 : (buffer_.back().time - buffer_.front().time).toSec();
  char text[160];
  std::snprintf(text, sizeof text, "%zu messages, %zu bytes, %.1f s; %" PRIu64 " snapshots written", buffer_.size(),
                bytes_, span, written_);
  part.message = text;
  status.parts.push_back(part);
}

void SnapshotRecorder::onMessage(const std::string& topic,
                                 const ros::MessageEvent<topic_tools::ShapeShifter const>& event) {
  Entry e;
  e.topic = topic;
  e.time = event.getReceiptTime();
  if (e.time < ros::TIME_MIN) e.time = ros::TIME_MIN;  // before /clock started: rosbag refuses time 0
  e.message = event.getConstMessage();
  e.connection_header = event.getConnectionHeaderPtr();
  e.bytes = e.message->size() + topic.size() + 64;
  std::lock_guard<std::mutex> lock(mutex_);
  // (seconds as doubles: ros::Time - Duration throws below zero, and an exception here would end the process)
  if (!buffer_.empty() && e.time.toSec() < buffer_.back().time.toSec() - 1.0) {
    buffer_.clear();  // time jumped back (simulation restarted, bag replayed again): the old buffer is another past
    bytes_ = 0;
  }
  buffer_.push_back(std::move(e));
  bytes_ += buffer_.back().bytes;
  trimLocked(buffer_.back().time);
}

void SnapshotRecorder::trimLocked(const ros::Time& now) {
  const double oldest = now.toSec() - seconds_;
  while (!buffer_.empty() && (buffer_.front().time.toSec() < oldest || bytes_ > max_bytes_)) {
    bytes_ -= buffer_.front().bytes;
    buffer_.pop_front();
  }
}

void SnapshotRecorder::onMotivation(const Motivation::ConstPtr& motivation) {
  if (!(motivation->surprise > threshold_)) return;
  const ros::Time now = ros::Time::now();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!last_auto_.isZero() && now >= last_auto_ && (now - last_auto_).toSec() < min_interval_) return;
    last_auto_ = now;
  }
  const std::string path = queueSnapshot("surprise");
  ROS_INFO("%s: surprise %.3f m > %.3f m: writing %s", name().c_str(), motivation->surprise, threshold_, path.c_str());
}

std::string SnapshotRecorder::queueSnapshot(const std::string& prefix) {
  Job job;
  char stamp[64];
  std::snprintf(stamp, sizeof stamp, "%.3f", ros::Time::now().toSec());
  job.path = run_dir_ + "/" + prefix + "_" + stamp + ".bag";
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job.entries.assign(buffer_.begin(), buffer_.end());  // shared pointers: no message is copied
  }
  const std::string path = job.path;
  {
    std::lock_guard<std::mutex> lock(jobs_mutex_);
    jobs_.push_back(std::move(job));
  }
  jobs_cv_.notify_one();
  return path;
}

void SnapshotRecorder::work() {
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(jobs_mutex_);
      jobs_cv_.wait(lock, [this] { return stop_ || !jobs_.empty(); });
      if (jobs_.empty()) return;  // stop_ and nothing left to write
      job = std::move(jobs_.front());
      jobs_.pop_front();
    }
    std::string path = job.path;
    std::error_code ec;
    for (int i = 1; fs::exists(path, ec); ++i) path = job.path.substr(0, job.path.size() - 4) + "_" + std::to_string(i) + ".bag";
    const std::string writing = path + ".writing";  // renamed when closed: a .bag is always complete
    ComponentEvent event;
    try {
      rosbag::Bag bag(writing, rosbag::bagmode::Write);
      bag.setCompression(rosbag::compression::LZ4);
      for (const auto& e : job.entries) {
        bag.write(e.topic, e.time, *e.message,
                  boost::const_pointer_cast<ros::M_string>(e.connection_header));
      }
      bag.close();
      fs::rename(writing, path);  // throws filesystem_error (a std::exception) on failure
      event = events().make(ComponentEvent::OPERATION, "write_snapshot", "ok");
      event.response = "path: " + path + "\nmessages: " + std::to_string(job.entries.size());
      {
        std::lock_guard<std::mutex> lock(mutex_);
        ++written_;
      }
      std_msgs::String msg;
      msg.data = path;
      snapshots_pub_.publish(msg);
    } catch (const std::exception& e) {
      fs::remove(writing, ec);
      event = events().make(ComponentEvent::OPERATION, "write_snapshot", "failed",
                            "cannot write '" + path + "': " + e.what());
      ROS_ERROR("%s: cannot write snapshot '%s': %s", name().c_str(), path.c_str(), e.what());
    }
    events().publish(event);
  }
}

}  // namespace xpersif
