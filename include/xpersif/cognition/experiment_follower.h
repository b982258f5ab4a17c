/**
 * @file experiment_follower.h
 * @brief How MACHINELEARNING and MOTIVATION follow the KNOWLEDGEBASE's experiments: every stored record
 *        exactly once, in order, per run, restoring from the KB after a restart, a new run or a lost message.
 *
 * It subscribes to the KB's `experiments` (every committed record) and its latched `run` (the current run id)
 * and hands both to its own worker thread, so that callbacks never block and the blocking get_experiments
 * call is made from a thread of its own, as the loop's architecture requires (the KB lives in another
 * manager). The worker keeps the current run id and the seqs it has handed on:
 *  - a record of the current run whose seq was seen is dropped (a duplicate);
 *  - with restore on, a record of another run, an announced run different from the current one, or a gap in
 *    the seqs makes it fetch the run's records from the KB and call `reset(run, records)`; the record that
 *    triggered it is among them (the KB publishes after committing);
 *  - with restore off, another run calls `reset(run, {})` and then `add(record)`;
 *  - otherwise it calls `add(record)`.
 * A KB that does not answer within `restore_timeout` seconds leaves the follower empty on that run (logged).
 */
#pragma once

#include "xpersif/core/common/parameters.h"

#include <ros/ros.h>
#include <std_msgs/UInt64.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "xpersif/ExperimentRecord.h"

namespace xpersif {

class ExperimentFollower {
 public:
  struct Options {
    std::string experiments_topic = "knowledge_base/experiments";
    std::string run_topic = "knowledge_base/run";
    std::string knowledge_base = "knowledge_base";  ///< namespace of the KB's operations
    bool restore = true;
    double restore_timeout = 30.0;  ///< s of wall time to wait for the KB
    std::string who;                ///< for log lines, e.g. the component's name

    /// From `~restore`, `~restore_timeout`, `~experiments_topic`, `~run_topic`, `~knowledge_base` (throws
    /// with the parameter's name for a bad value).
    static Options fromParameters(const ros::NodeHandle& private_nh, const std::string& who);
    /// The parameters fromParameters reads, for the tables of the components that follow experiments.
    static const core::ParameterTable& parameters();
  };
  /// Replace all state by that of @p run_id, built from @p records (the run's records in seq order).
  using Reset = std::function<void(std::uint64_t run_id, const std::vector<ExperimentRecord>& records)>;
  using Add = std::function<void(const ExperimentRecord& record)>;

  ExperimentFollower(ros::NodeHandle nh, Options options, Reset reset, Add add);
  ~ExperimentFollower();
  ExperimentFollower(const ExperimentFollower&) = delete;
  ExperimentFollower& operator=(const ExperimentFollower&) = delete;

  /// Subscribe and start the worker; with restore on, the next run announcement restores the state.
  void start();
  /// Unsubscribe and join the worker (a restore in progress gives up). Idempotent.
  void stop();

  std::uint64_t runId() const { return run_id_; }
  /// Records handed on (add, or in a reset) since the last reset.
  std::size_t seen() const;

 private:
  struct Event {
    bool is_run = false;
    std::uint64_t run_id = 0;
    ExperimentRecord::ConstPtr record;
  };
  void work();
  void handle(const Event& event);
  void restore(std::uint64_t run_id);

  ros::NodeHandle nh_;
  Options options_;
  Reset reset_;
  Add add_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Event> queue_;
  bool stopping_ = false;
  std::atomic<bool> abort_restore_{false};
  std::set<std::uint32_t> seqs_;  // worker thread only, except seen()
  std::atomic<std::uint64_t> run_id_{0};
  std::thread worker_;

  // ROS handles last (destroyed first).
  ros::Subscriber experiments_sub_, run_sub_;
};

}  // namespace xpersif
