/**
 * @file snapshot_recorder.h
 * @brief SNAPSHOTRECORDER: keeps the last `~seconds` of the loop's topics in memory and writes them to a bag
 *        when MOTIVATION's surprise exceeds `~threshold`, so the moments the robot did not expect are kept even
 *        when full recording is off.
 *
 * Parameters (read on configure):
 *  - `~topics` (string list): topics to keep (any type: topic_tools::ShapeShifter); default: /tf,
 *    /xpersif/knowledge_base/experiments, /xpersif/motivation/motivation, /xpersif/vision/features,
 *    /xpersif/observation/features, /xpersif/machine_learning/notions.
 *  - `~seconds` (default 10): how much (ROS time, i.e. simulated time under /clock) the buffer keeps.
 *  - `~max_bytes` (default 200 MB): the buffer also never holds more serialized bytes than this (oldest
 *    messages go first), so images or a flood cannot exhaust memory.
 *  - `~threshold` (m, default 0.05): Motivation.surprise above it triggers a snapshot.
 *  - `~min_interval` (s, default = seconds): no automatic snapshot sooner than this after the last one.
 *  - `~run_dir` (default "."): where `surprise_<time>.bag` and `snapshot_<time>.bag` go (<time>: ROS time
 *    in seconds with milliseconds).
 *  - `~motivation_topic` (default /xpersif/motivation/motivation).
 *
 * Operation `snapshot` (std_srvs/Trigger): queue a snapshot now; the response message is the bag's path.
 * Bags are written by a worker thread (never in a callback); each written bag's path is published on
 * `~snapshots` (std_msgs/String) and reported as an event. Status shows buffered messages and bytes.
 */
#pragma once

#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

#include "xpersif/Motivation.h"
#include "xpersif/component/component.h"

namespace xpersif {

class SnapshotRecorder : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  SnapshotRecorder(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~SnapshotRecorder() override;

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;
  void fillStatus(ComponentStatus& status) override;

 private:
  struct Entry {
    std::string topic;
    ros::Time time;
    topic_tools::ShapeShifter::ConstPtr message;
    boost::shared_ptr<const ros::M_string> connection_header;
    std::size_t bytes = 0;
  };
  struct Job {
    std::string path;
    std::vector<Entry> entries;
  };

  void onMessage(const std::string& topic, const ros::MessageEvent<topic_tools::ShapeShifter const>& event);
  void onMotivation(const Motivation::ConstPtr& motivation);
  /// Copy the buffer into a job for the worker; returns the bag's path. Takes mutex_.
  std::string queueSnapshot(const std::string& prefix);
  void trimLocked(const ros::Time& now);
  void work();
  void stopWorker();

  std::vector<std::string> topics_;
  double seconds_ = 10.0;
  std::size_t max_bytes_ = 200u * 1024 * 1024;
  double threshold_ = 0.05;
  double min_interval_ = 10.0;
  std::string run_dir_ = ".";
  std::string motivation_topic_ = "/xpersif/motivation/motivation";

  std::mutex mutex_;  // buffer_, bytes_, last_auto_
  std::deque<Entry> buffer_;
  std::size_t bytes_ = 0;
  ros::Time last_auto_;
  std::uint64_t written_ = 0;

  std::mutex jobs_mutex_;
  std::condition_variable jobs_cv_;
  std::deque<Job> jobs_;
  bool stop_ = false;
  std::thread worker_;

  // ROS handles last.
  ros::Publisher snapshots_pub_;
  std::vector<ros::Subscriber> subscribers_;
  ros::Subscriber motivation_sub_;
};

}  // namespace xpersif
