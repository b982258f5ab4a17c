// xpersif: the console client of the paper. It finds every component by its ~status topic and shows or
// changes its state. Later issues add the loop's commands (configure a run, start, pause, resume, stop).
#include <ros/master.h>
#include <ros/ros.h>

#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "xpersif/ComponentStatus.h"
#include "xpersif/GetContracts.h"
#include "xpersif/Transition.h"

namespace {

const char* kUsage = R"(usage: xpersif <command> [arguments]

  status [--timeout S]                 show every component's state, health, heartbeat and parts
  wait [--timeout S] COMPONENT...      wait until the components (and all their parts) are ACTIVE;
                                       exit 1 with the reason when they are not within S seconds
  configure|activate|deactivate|shutdown COMPONENT
                                       ask a component for a lifecycle transition
  contracts COMPONENT [NAME]           show the preconditions and effects of its commands and operations

COMPONENT is a node name such as /loop/supervisor. Default timeout: 3 s for status, 60 s for wait.
)";

using StatusMap = std::map<std::string, xpersif::ComponentStatus>;

std::vector<std::string> statusTopics() {
  ros::master::V_TopicInfo topics;
  ros::master::getTopics(topics);
  std::vector<std::string> out;
  for (const auto& t : topics) {
    if (t.datatype == "xpersif/ComponentStatus") out.push_back(t.name);
  }
  return out;
}

// Collect the latest status of every component until all have spoken once or the time is up.
StatusMap collectStatus(double timeout) {
  ros::NodeHandle nh;
  StatusMap latest;
  std::vector<ros::Subscriber> subscribers;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  std::vector<std::string> topics = statusTopics();
  for (const auto& topic : topics) {
    subscribers.push_back(nh.subscribe<xpersif::ComponentStatus>(
        topic, 10, [&latest](const xpersif::ComponentStatus::ConstPtr& s) { latest[s->component] = *s; }));
  }
  while (ros::ok() && ros::WallTime::now() < end && latest.size() < topics.size()) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
  return latest;
}

const char* healthName(std::uint8_t health) {
  switch (health) {
    case xpersif::ComponentStatus::HEALTH_OK: return "ok";
    case xpersif::ComponentStatus::HEALTH_WARN: return "warn";
    case xpersif::ComponentStatus::HEALTH_ERROR: return "error";
    case xpersif::ComponentStatus::HEALTH_STALE: return "stale";
  }
  return "?";
}

void printStatus(const StatusMap& statuses) {
  std::cout << std::left << std::setw(34) << "COMPONENT" << std::setw(14) << "STATE" << std::setw(8) << "HEALTH"
            << std::setw(10) << "HEARTBEAT" << "TYPE / NOTE\n";
  for (const auto& [name, s] : statuses) {
    std::cout << std::setw(34) << name << std::setw(14) << s.state_name << std::setw(8) << healthName(s.health)
              << std::setw(10) << s.heartbeat << s.type;
    if (!s.running_commands.empty()) {
      std::cout << "  running:";
      for (const auto& c : s.running_commands) std::cout << " " << c;
    }
    if (!s.last_error.empty()) std::cout << "  error: " << s.last_error;
    std::cout << "\n";
    for (const auto& p : s.parts) {
      std::cout << "  - " << std::setw(30) << p.name << std::setw(14) << p.state_name << std::setw(8)
                << healthName(p.health) << std::setw(10) << "" << p.message << "\n";
    }
  }
  if (statuses.empty()) std::cout << "(no component answered)\n";
}

// "" when the component and all its parts are ACTIVE, else what is not.
std::string notReady(const StatusMap& statuses, const std::string& name) {
  auto it = statuses.find(name);
  if (it == statuses.end()) return name + " has not reported its status";
  const auto& s = it->second;
  if (s.state != xpersif::ComponentStatus::ACTIVE) {
    return name + " is " + s.state_name + (s.last_error.empty() ? "" : " (" + s.last_error + ")");
  }
  for (const auto& p : s.parts) {
    if (p.state != xpersif::ComponentStatus::ACTIVE) {
      return name + ": part " + p.name + " is " + p.state_name + (p.message.empty() ? "" : " (" + p.message + ")");
    }
  }
  return "";
}

int waitActive(const std::vector<std::string>& names, double timeout) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  std::string reason = "nothing heard";
  while (ros::ok()) {
    const StatusMap statuses = collectStatus(0.5);
    reason.clear();
    for (const auto& n : names) {
      reason = notReady(statuses, n);
      if (!reason.empty()) break;
    }
    if (reason.empty()) {
      printStatus(statuses);
      return 0;
    }
    if (ros::WallTime::now() > end) break;
    ros::WallDuration(0.2).sleep();
  }
  std::cerr << "xpersif: not ACTIVE within " << timeout << " s: " << reason << "\n";
  return 1;
}

int transition(const std::string& verb, const std::string& component) {
  const std::string service = component + "/" + verb;
  if (!ros::service::waitForService(service, ros::Duration(5.0))) {
    std::cerr << "xpersif: " << component << " offers no " << service << " service (is it running?)\n";
    return 1;
  }
  xpersif::Transition call;
  if (!ros::service::call(service, call)) {
    std::cerr << "xpersif: the call to " << service << " failed\n";
    return 1;
  }
  if (!call.response.success) {
    std::cerr << "xpersif: " << call.response.message << "\n";
    return 1;
  }
  std::cout << component << ": " << call.response.state_name << "\n";
  return 0;
}

int contracts(const std::string& component, const std::string& name) {
  xpersif::GetContracts call;
  call.request.name = name;
  if (!ros::service::call(component + "/get_contracts", call)) {
    std::cerr << "xpersif: " << component << "/get_contracts did not answer\n";
    return 1;
  }
  if (!call.response.success) {
    std::cerr << "xpersif: " << call.response.message << "\n";
    return 1;
  }
  for (const auto& c : call.response.contracts) {
    std::cout << c.kind << " " << c.name << " (" << c.interface_type << "): " << c.description << "\n";
    if (!c.parameters.empty()) {
      std::cout << "  parameters:";
      for (const auto& p : c.parameters) std::cout << " " << p;
      std::cout << "\n";
    }
    for (const auto& p : c.preconditions) std::cout << "  requires " << p.literal << "  -- " << p.description << "\n";
    for (const auto& e : c.effects) std::cout << "  effect   " << e << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "-h" || args[0] == "--help") {
    std::cout << kUsage;
    return args.empty() ? 2 : 0;
  }
  const std::string command = args[0];
  double timeout = -1;
  std::vector<std::string> rest;
  for (std::size_t i = 1; i < args.size(); ++i) {
    if (args[i] == "--timeout" && i + 1 < args.size()) {
      std::istringstream in(args[++i]);
      if (!(in >> timeout) || !(timeout > 0)) {
        std::cerr << "xpersif: --timeout needs a positive number of seconds, not '" << args[i] << "'\n";
        return 2;
      }
    } else {
      rest.push_back(args[i]);
    }
  }
  ros::init(argc, argv, "xpersif_console", ros::init_options::AnonymousName | ros::init_options::NoSigintHandler);
  if (command == "wait") {
    // The system may still be starting: give the master the same time as the components.
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout > 0 ? timeout : 60.0);
    while (!ros::master::check() && ros::WallTime::now() < end) ros::WallDuration(0.2).sleep();
  }
  if (!ros::master::check()) {
    std::cerr << "xpersif: no ROS master at " << ros::master::getURI() << " (start the system first)\n";
    return 1;
  }
  // Keep the node up for the whole command: the helpers' short-lived NodeHandles would otherwise
  // shut it down when the first of them goes away.
  ros::start();
  if (command == "status") {
    printStatus(collectStatus(timeout > 0 ? timeout : 3.0));
    return 0;
  }
  if (command == "wait" && !rest.empty()) return waitActive(rest, timeout > 0 ? timeout : 60.0);
  if ((command == "configure" || command == "activate" || command == "deactivate" || command == "shutdown") &&
      rest.size() == 1) {
    return transition(command, rest[0]);
  }
  if (command == "contracts" && (rest.size() == 1 || rest.size() == 2)) {
    return contracts(rest[0], rest.size() == 2 ? rest[1] : "");
  }
  std::cerr << "xpersif: cannot understand '" << command << "' with " << rest.size() << " argument(s)\n" << kUsage;
  return 2;
}
