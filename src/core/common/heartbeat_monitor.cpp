#include "xpersif/core/common/heartbeat_monitor.h"

#include <stdexcept>

namespace xpersif::core {

HeartbeatMonitor::HeartbeatMonitor(double timeout_s) : timeout_(timeout_s) {
  if (!(timeout_s > 0)) throw std::invalid_argument("heartbeat timeout must be a positive number of seconds");
}

void HeartbeatMonitor::expect(const std::string& name, double now, double grace_s) {
  Entry entry;
  entry.last_beat = now;
  entry.deadline = now + timeout_ + (grace_s > 0 ? grace_s : 0);
  entries_[name] = entry;
}

void HeartbeatMonitor::forget(const std::string& name) { entries_.erase(name); }

void HeartbeatMonitor::beat(const std::string& name, double now) {
  auto it = entries_.find(name);
  if (it == entries_.end()) return;
  Entry& entry = it->second;
  if (entry.lost) {
    entry.lost = false;
    entry.came_back = true;
  }
  entry.last_beat = now;
  entry.deadline = now + timeout_;
}

std::vector<HeartbeatMonitor::Change> HeartbeatMonitor::poll(double now) {
  std::vector<Change> changes;
  for (auto& [name, entry] : entries_) {
    if (entry.came_back) {
      entry.came_back = false;
      changes.push_back({name, false, 0.0});
    }
    if (!entry.lost && now > entry.deadline) {
      entry.lost = true;
      changes.push_back({name, true, now - entry.last_beat});
    }
  }
  return changes;
}

bool HeartbeatMonitor::isLost(const std::string& name) const {
  auto it = entries_.find(name);
  return it != entries_.end() && it->second.lost;
}

}  // namespace xpersif::core
