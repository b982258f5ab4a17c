/**
 * @file heartbeat_monitor.h
 * @brief Notices when a supervised component stops sending its status heartbeat.
 *
 * ROS-free: the caller feeds it beats and the current (wall) time. A component that is silent for longer
 * than the timeout is reported lost exactly once, until it beats again (then it is reported back).
 */
#pragma once

#include <map>
#include <string>
#include <vector>

namespace xpersif::core {

class HeartbeatMonitor {
 public:
  /// @param timeout_s silence after which a component counts as lost (seconds, > 0)
  explicit HeartbeatMonitor(double timeout_s);

  /// Start watching @p name at time @p now; it has @p grace_s extra seconds for its first beat.
  void expect(const std::string& name, double now, double grace_s = 0.0);
  void forget(const std::string& name);
  void beat(const std::string& name, double now);

  struct Change {
    std::string name;
    bool lost = false;       ///< true: just went silent; false: came back after being lost
    double silent_for = 0;   ///< seconds since the last beat (or since expect) when it went silent
  };
  /// Changes since the last call: components that just went silent, and lost ones that beat again.
  std::vector<Change> poll(double now);

  bool isLost(const std::string& name) const;
  bool isWatched(const std::string& name) const { return entries_.count(name) > 0; }
  double timeout() const { return timeout_; }

 private:
  struct Entry {
    double deadline = 0;   // time after which silence means lost
    double last_beat = 0;  // or the time watching began
    bool lost = false;
    bool came_back = false;
  };
  double timeout_;
  std::map<std::string, Entry> entries_;
};

}  // namespace xpersif::core
