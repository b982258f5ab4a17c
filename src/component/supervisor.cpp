#include "xpersif/component/supervisor.h"

#include <cmath>

#include "xpersif/component/parameter_reader.h"

#include <nodelet/NodeletList.h>
#include <nodelet/NodeletLoad.h>
#include <nodelet/NodeletUnload.h>

#include <algorithm>
#include <chrono>
#include <future>
#include <memory>
#include <thread>
#include <set>
#include <stdexcept>

namespace xpersif {

namespace {

double wallNow() { return ros::WallTime::now().toSec(); }

enum class CallOutcome { Answered, Failed, NoAnswer };

// roscpp's service calls have no timeout: a component whose transition never returns (its callback blocked: seen with
// RELOCATION's configure waiting for a service whose queue was pinned to the same thread) would hold the bring-up for
// good. The call runs in a thread of its own, which is left behind if no answer comes within @p seconds.
CallOutcome callWithin(const std::string& service, Transition& call, double seconds) {
  struct Pending {
    Transition call;
    std::promise<bool> answered;
  };
  auto pending = std::make_shared<Pending>();
  pending->call = call;
  std::future<bool> answer = pending->answered.get_future();
  std::thread([pending, service] { pending->answered.set_value(ros::service::call(service, pending->call)); }).detach();
  if (answer.wait_for(std::chrono::duration<double>(seconds)) != std::future_status::ready) return CallOutcome::NoAnswer;
  if (!answer.get()) return CallOutcome::Failed;
  call.response = pending->call.response;
  return CallOutcome::Answered;
}

// The first part a component's status names that is not up: UNCONFIGURED (not yet configured, or not yet heard of),
// ERROR or LOST; null if none. For a supervised supervisor, its own components still starting.
const PartStatus* firstPartNotUp(const ComponentStatus& status) {
  for (const auto& part : status.parts) {
    if (part.state_name == "LOST" || part.state_name == "STARTING" || part.state == ComponentStatus::UNCONFIGURED ||
        part.state == ComponentStatus::ERROR) {
      return &part;
    }
  }
  return nullptr;
}

std::string memberString(const XmlRpc::XmlRpcValue& entry, const char* key, const std::string& where) {
  if (!entry.hasMember(key)) {
    throw std::runtime_error(where + " has no '" + key + "'; every supervised component needs name, type and manager");
  }
  XmlRpc::XmlRpcValue value = entry[key];
  if (value.getType() != XmlRpc::XmlRpcValue::TypeString) {
    throw std::runtime_error(where + "." + key + " must be a string");
  }
  return static_cast<std::string>(value);
}

}  // namespace

Supervisor::Supervisor(ros::NodeHandle nh, ros::NodeHandle private_nh, std::string type)
    : Component(std::move(nh), std::move(private_nh), std::move(type)) {}

Supervisor::~Supervisor() { stopMonitor(); }

std::vector<SupervisedComponent> Supervisor::parseComponents(const XmlRpc::XmlRpcValue& list,
                                                             const ros::NodeHandle& nh) {
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray) {
    throw std::runtime_error("~components must be a list of {name, type, manager[, activate, params]}");
  }
  static const std::set<std::string> known_keys = {"name", "type", "manager", "activate", "params"};
  std::vector<SupervisedComponent> components;
  std::set<std::string> names;
  for (int i = 0; i < list.size(); ++i) {
    const std::string where = "~components[" + std::to_string(i) + "]";
    XmlRpc::XmlRpcValue entry = list[i];
    if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct) throw std::runtime_error(where + " must be a dictionary");
    for (auto it = entry.begin(); it != entry.end(); ++it) {
      if (!known_keys.count(it->first)) {
        throw std::runtime_error(where + " has unknown key '" + it->first + "'; known: name, type, manager, activate, params");
      }
    }
    SupervisedComponent c;
    const std::string name = memberString(entry, "name", where);
    core::requireIdentifier(where + ".name", name);
    c.name = nh.resolveName(name);
    c.type = memberString(entry, "type", where);
    core::requireIdentifier(where + ".type", c.type);
    const std::string manager = memberString(entry, "manager", where);
    core::requireIdentifier(where + ".manager", manager);
    c.manager = nh.resolveName(manager);
    if (entry.hasMember("activate")) {
      if (entry["activate"].getType() != XmlRpc::XmlRpcValue::TypeBoolean) {
        throw std::runtime_error(where + ".activate must be true or false");
      }
      c.activate = static_cast<bool>(entry["activate"]);
    }
    if (entry.hasMember("params")) {
      c.params = entry["params"];
      if (c.params.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
        throw std::runtime_error(where + ".params must be a dictionary of parameter names to values");
      }
    }
    if (!names.insert(c.name).second) throw std::runtime_error(where + " repeats the name " + c.name);
    components.push_back(c);
  }
  return components;
}

const core::ParameterTable& Supervisor::parameters() {
  static const core::ParameterTable table(
      "supervisor",
      {core::ParameterSpec{"components", core::ParameterSpec::Type::Structure, {}, "[]", -INFINITY, INFINITY, {},
                           "the supervised components in start order: a list of {name, type, manager, activate, "
                           "params} (doc/components.md)"},
       core::namesParameter("omit", {}, 256, "components of ~components to leave out (a launch file's switch)"),
       core::numberParameter("heartbeat_timeout", 1.0, 0.05, 600.0,
                             "s of wall time without a status before a component counts as lost"),
       core::numberParameter("startup_timeout", 10.0, 0.1, 3600.0,
                             "s of wall time a component may take to load and send its first status, and each lifecycle call to answer"),
       core::flagParameter("restart", true, "restart a lost component (its manager respawned by roslaunch)")});
  return table;
}

void Supervisor::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, Supervisor::parameters());
  XmlRpc::XmlRpcValue list;
  std::vector<SupervisedComponent> components;
  if (pnh.getParam("components", list)) components = parseComponents(list, nodeHandle());
  const std::vector<std::string> omit = parameters.get<std::vector<std::string>>("omit");
  for (const std::string& name : omit) {
    const std::string resolved = nodeHandle().resolveName(name);
    const auto it = std::find_if(components.begin(), components.end(),
                                 [&](const SupervisedComponent& c) { return c.name == resolved; });
    if (it == components.end()) throw std::runtime_error("~omit names " + name + ", which is not in ~components");
    components.erase(it);
  }
  const double heartbeat_timeout = parameters.get<double>("heartbeat_timeout");
  const double startup_timeout = parameters.get<double>("startup_timeout");
  const bool restart = parameters.get<bool>("restart");
  // Everything is checked before anything changes: a bad configuration leaves the old one in place.
  stopMonitor();
  components_ = std::move(components);
  heartbeat_timeout_ = heartbeat_timeout;
  startup_timeout_ = startup_timeout;
  restart_ = restart;
  std::lock_guard<std::mutex> lock(mutex_);
  monitor_ = core::HeartbeatMonitor(heartbeat_timeout_);
  observed_.clear();
  status_subscribers_.clear();
}

void Supervisor::watch(const SupervisedComponent& component) {
  std::lock_guard<std::mutex> lock(mutex_);
  monitor_.expect(component.name, wallNow(), startup_timeout_);
  observed_[component.name];
  const std::string name = component.name;
  status_subscribers_.push_back(nodeHandle().subscribe<ComponentStatus>(
      name + "/status", 10, [this, name](const ComponentStatus::ConstPtr& status) { onStatus(name, status); },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
}

void Supervisor::onActivate() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_subscribers_.clear();
  }
  for (const auto& component : components_) watch(component);
  // Bring-up runs in the supervisor's own thread, never in a manager's callback thread: the components
  // may live in the supervisor's own manager and need its threads to answer the calls.
  monitoring_ = true;
  setBringUp(BringUp::Running, "", 0);
  monitor_thread_ = std::thread([this] {
    const ros::WallTime began = ros::WallTime::now();
    for (std::size_t index = 0; index < components_.size(); ++index) {
      const SupervisedComponent& component = components_[index];
      if (!monitoring_) {
        setBringUp(BringUp::Failed, "supervision stopped while " + component.name + " was still to start");
        return;
      }
      setBringUp(BringUp::Running, component.name, index);
      for (int attempt = 1;; ++attempt) {
        try {
          bringUp(component);
          break;
        } catch (const std::exception& e) {
          // Its manager died while it was being started (a crash battery's kill; a crash the transition itself
          // caused): once the respawned manager answers without it, it is started again, from loading.
          if (attempt < kBringUpAttempts && monitoring_ && restart_ && respawnedWithout(component)) {
            ROS_WARN_STREAM(name() << ": " << component.name << " went with its manager while it was being started ("
                                   << e.what() << "); starting it again");
            continue;
          }
          monitoring_ = false;
          const std::string why = "could not start " + component.name + ": " + e.what();
          setBringUp(BringUp::Failed, why);
          reportError(why);
          return;
        }
      }
    }
    setBringUp(BringUp::Done, "");
    ROS_INFO_STREAM(name() << ": " << components_.size() << " components up in "
                           << core::describeNumber((ros::WallTime::now() - began).toSec()) << " s");
    monitorLoop();
  });
}

void Supervisor::setBringUp(BringUp state, const std::string& note, std::size_t index) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    bring_up_ = state;
    bring_up_note_ = note;
    if (state == BringUp::Running) bring_up_index_ = index;
  }
  bring_up_changed_.notify_all();
}

std::string Supervisor::waitUntilUp(double patience, const std::function<bool()>& stop) const {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(patience);
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    if (bring_up_ == BringUp::Failed) return bring_up_note_;
    if (bring_up_ == BringUp::Idle) return name() + " is not supervising (not ACTIVE)";
    const bool started = bring_up_ == BringUp::Done;
    const NotUp not_up = started ? notUpLocked() : NotUp{bring_up_note_, false};
    if (started && not_up.what.empty()) return "";
    if (not_up.failed) return not_up.what;  // a component that failed after it was started: nothing to wait for
    const std::string waiting = not_up.what.empty() ? "the first component" : not_up.what;
    if (stop && stop()) return "stopped while " + waiting + " was starting";
    if (std::chrono::steady_clock::now() >= until) {
      return waiting + " is still starting after " + core::describeNumber(patience) + " s";
    }
    bring_up_changed_.wait_for(lock, std::chrono::milliseconds(100));
  }
}

Supervisor::NotUp Supervisor::notUpLocked() const {
  for (const auto& component : components_) {
    NotUp not_up = notUpLocked(component.name);
    if (!not_up.what.empty()) return not_up;
  }
  return {};
}

Supervisor::NotUp Supervisor::notUpLocked(const std::string& name) const {
  auto it = observed_.find(name);
  if (it == observed_.end()) return {name, false};
  const Observed& observed = it->second;
  if (observed.state == LifecycleState::Error) return {name + " is in ERROR: " + observed.message, true};
  if (observed.lost || observed.state == LifecycleState::Unconfigured) return {name, false};
  if (!observed.part_not_up.empty()) return {name + "'s " + observed.part_not_up, observed.part_failed};
  return {};
}

std::string Supervisor::failedComponent() const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& component : components_) {
    const NotUp not_up = notUpLocked(component.name);  // unseen or lost: not failed (it is being restarted)
    if (not_up.failed) return not_up.what;
  }
  return "";
}

void Supervisor::onDeactivate() {
  stopMonitor();
  for (auto it = components_.rbegin(); it != components_.rend(); ++it) {
    if (lastKnownState(it->name) != LifecycleState::Active) continue;
    if (wentWithItsManager(*it)) continue;
    try {
      requestTransition(*it, LifecycleTransition::Deactivate);
    } catch (const std::exception& e) {
      ROS_WARN_STREAM(name() << ": " << e.what());
    }
  }
}

void Supervisor::onShutdown() {
  stopMonitor();
  // When the supervisor's own process or nodelet is going away, its manager may be the one that
  // would have to answer; the components are left to their managers.
  if (halting() || !ros::ok()) return;
  for (auto it = components_.rbegin(); it != components_.rend(); ++it) {
    if (wentWithItsManager(*it)) continue;
    try {
      requestTransition(*it, LifecycleTransition::Shutdown);
    } catch (const std::exception& e) {
      ROS_WARN_STREAM(name() << ": " << e.what());
    }
    std::string why;
    if (unload(*it, &why)) {
      supervisionEvent(it->name, "unloaded", "");
    } else {
      ROS_WARN_STREAM(name() << ": " << why);
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  status_subscribers_.clear();
}

void Supervisor::stopMonitor() {
  monitoring_ = false;
  if (monitor_thread_.joinable()) monitor_thread_.join();
  setBringUp(BringUp::Idle, "");
}

bool Supervisor::wentWithItsManager(const SupervisedComponent& component) const {
  if (!managerAnswers(component.manager)) {
    ROS_WARN_STREAM(name() << ": manager " << component.manager << " is gone; " << component.name << " went with it");
    return true;
  }
  // A respawned manager answers without it (a crash battery's take: asking a lost ACTIVE component to deactivate
  // waited ~startup_timeout for a service that never came, once per component, and the caller gave up).
  if (loadedIn(component) != false) return false;  // (its manager answers: checked above)
  ROS_WARN_STREAM(name() << ": " << component.name << " is not loaded in " << component.manager
                         << " (the manager was restarted without it); nothing to ask it");
  return true;
}

bool Supervisor::managerAnswers(const std::string& manager) const {
  return ros::service::exists(manager + "/load_nodelet", false);
}

void Supervisor::load(const SupervisedComponent& component) const {
  const std::string list_service = component.manager + "/list";
  if (!ros::service::waitForService(list_service, ros::Duration(startup_timeout_))) {
    throw std::runtime_error("manager " + component.manager + " does not answer (no " + list_service + " within " +
                             core::describeNumber(startup_timeout_) + " s)");
  }
  if (component.params.valid()) {
    XmlRpc::XmlRpcValue params = component.params;
    for (auto it = params.begin(); it != params.end(); ++it) {
      ros::param::set(component.name + "/" + it->first, it->second);
    }
  }
  if (loadedIn(component) == true) return;
  nodelet::NodeletLoad load;
  load.request.name = component.name;
  load.request.type = component.type;
  if (!ros::service::call(component.manager + "/load_nodelet", load) || !load.response.success) {
    // Refused because one of that name exists: the list before did not show it (a crash battery's take lost ROBOTMODEL's
    // whole re-bring-up to this). It is loaded; configure and activate follow.
    if (loadedIn(component) == true) return;
    throw std::runtime_error("manager " + component.manager + " could not load " + component.type + " as " +
                             component.name + " (is the type in a nodelet_plugins.xml? see the manager's log)");
  }
}

bool Supervisor::respawnedWithout(const SupervisedComponent& component) const {
  return managerAnswers(component.manager) && loadedIn(component) == false;
}

std::optional<bool> Supervisor::loadedIn(const SupervisedComponent& component) const {
  // roscpp's non-persistent calls fail now and then in transport (ros/ros_comm#1976): asked again.
  for (int attempt = 1; attempt <= 3; ++attempt) {
    nodelet::NodeletList list;
    if (ros::service::call(component.manager + "/list", list)) {
      const auto& loaded = list.response.nodelets;
      return std::find(loaded.begin(), loaded.end(), component.name) != loaded.end();
    }
    if (attempt < 3 && ros::ok()) ros::WallDuration(0.1).sleep();
  }
  return std::nullopt;
}

bool Supervisor::unload(const SupervisedComponent& component, std::string* why) const {
  nodelet::NodeletUnload unload;
  unload.request.name = component.name;
  if (!managerAnswers(component.manager)) {
    if (why) *why = "manager " + component.manager + " is gone; " + component.name + " went with it";
    return false;
  }
  if (!ros::service::call(component.manager + "/unload_nodelet", unload) || !unload.response.success) {
    if (why) *why = "manager " + component.manager + " could not unload " + component.name;
    return false;
  }
  return true;
}

void Supervisor::waitForTransitionService(const SupervisedComponent& component, const std::string& service) const {
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(startup_timeout_);
  // In slices, so that a manager that came back without the component ends the wait at once.
  for (;;) {
    const double left = (until - ros::WallTime::now()).toSec();
    if (ros::service::waitForService(service, ros::Duration(std::clamp(left, 0.01, 1.0)))) return;
    if (respawnedWithout(component)) {
      throw std::runtime_error(component.name + " is not loaded in " + component.manager +
                               " (the manager was restarted without it); no " + service + " to ask");
    }
    if (left <= 1.0 || !ros::ok()) {
      throw std::runtime_error(component.name + " offers no " + service + " service within " +
                               core::describeNumber(startup_timeout_) + " s");
    }
  }
}

void Supervisor::requestTransition(const SupervisedComponent& component, LifecycleTransition transition) const {
  const std::string service = component.name + "/" + toString(transition);
  if (!ros::ok()) throw std::runtime_error(service + " not asked: this process is shutting down");
  waitForTransitionService(component, service);
  // A call that fails in transport (no answer: a manager just respawned, a loaded machine) is asked again until
  // ~startup_timeout has passed: one such failure during a restart made a crash-battery take's whole run abort.
  // Asking again is safe: a transition already reached is accepted below.
  Transition call;
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(startup_timeout_);
  for (;;) {
    const CallOutcome outcome = callWithin(service, call, startup_timeout_);
    if (outcome == CallOutcome::Answered) break;
    // A process that is shutting down can no longer hear an answer: asking again until ~startup_timeout held a
    // manager's exit (the supervisor's nodelet deactivating the others from its destructor) until roslaunch's
    // SIGTERM, 15 s after its SIGINT, at the end of about a third of runs.
    if (!ros::ok()) {
      throw std::runtime_error("call to " + service + " failed and this process is shutting down; not asked again");
    }
    if (outcome == CallOutcome::NoAnswer) {  // asking again would only queue behind the call still running
      throw std::runtime_error(component.name + " did not answer its " + toString(transition) + " within " +
                               core::describeNumber(startup_timeout_) + " s (the transition is still running or stuck)");
    }
    if (respawnedWithout(component)) {
      throw std::runtime_error(component.name + " is no longer loaded in " + component.manager +
                               " (the manager was restarted)");
    }
    if (ros::WallTime::now() >= until) {
      throw std::runtime_error("call to " + service + " failed (asked again for " +
                               core::describeNumber(startup_timeout_) + " s)");
    }
    ros::WallDuration(0.2).sleep();
    // In slices, so that a manager that comes back without it is noticed above.
    ros::service::waitForService(service,
                                 ros::Duration(std::clamp((until - ros::WallTime::now()).toSec(), 0.01, 1.0)));
  }
  // An already reached state (e.g. configure on an INACTIVE component re-reads parameters) is fine.
  if (!call.response.success && call.response.state != static_cast<std::uint8_t>(core::targetOf(transition))) {
    throw std::runtime_error(component.name + " refused to " + toString(transition) + ": " + call.response.message);
  }
}

void Supervisor::bringUp(const SupervisedComponent& component) {
  load(component);
  supervisionEvent(component.name, "loaded", "");
  // An already running component (e.g. after the supervisor itself was restarted) is re-parametrized:
  // configure is only legal from INACTIVE, so it is deactivated first.
  GetState state;
  if (ros::service::waitForService(component.name + "/get_state", ros::Duration(startup_timeout_)) &&
      ros::service::call(component.name + "/get_state", state) && state.response.state == ComponentStatus::ACTIVE) {
    requestTransition(component, LifecycleTransition::Deactivate);
  }
  requestTransition(component, LifecycleTransition::Configure);
  supervisionEvent(component.name, "configured", "");
  if (component.activate) {
    requestTransition(component, LifecycleTransition::Activate);
    supervisionEvent(component.name, "activated", "");
  }
}

void Supervisor::onStatus(const std::string& name, const ComponentStatus::ConstPtr& status) {
  std::string newly_failed;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = observed_.find(name);
    if (it == observed_.end()) return;
    Observed& observed = it->second;
    // A latched status from before a crash repeats an old heartbeat; only a new one counts as alive.
    if (status->heartbeat != observed.heartbeat || status->state == ComponentStatus::FINALIZED) {
      monitor_.beat(name, wallNow());
    }
    const auto state = static_cast<LifecycleState>(status->state);
    if (state == LifecycleState::Error && observed.state != LifecycleState::Error) newly_failed = status->last_error;
    observed.state = state;
    observed.health = status->health;
    observed.heartbeat = status->heartbeat;
    const PartStatus* part = firstPartNotUp(*status);
    observed.part_not_up =
        part ? part->name + " (" + part->state_name + (part->message.empty() ? "" : ": " + part->message) + ")" : "";
    observed.part_failed = part && part->state == ComponentStatus::ERROR;
    if (!observed.lost) observed.message = status->last_error;
  }
  if (!newly_failed.empty()) supervisionEvent(name, "failed", name + " is in ERROR: " + newly_failed);
  onComponentStatus(name, *status);
}

void Supervisor::monitorLoop() {
  while (monitoring_ && ros::ok()) {
    std::vector<core::HeartbeatMonitor::Change> changes;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      changes = monitor_.poll(wallNow());
    }
    for (const auto& change : changes) {
      const auto spec = std::find_if(components_.begin(), components_.end(),
                                     [&](const SupervisedComponent& c) { return c.name == change.name; });
      if (spec == components_.end()) continue;
      std::string reason;
      if (change.lost) {
        reason = spec->name + " sent no status for " + core::describeNumber(change.silent_for) + " s; ";
        if (lastKnownState(spec->name) == LifecycleState::Finalized) {
          reason += "it was shut down (FINALIZED) by a request that did not come from " + name();
        } else if (managerAnswers(spec->manager)) {
          reason += "its manager " + spec->manager + " still answers, so it hung or was unloaded";
        } else {
          reason += "its manager " + spec->manager + " is gone";
        }
        ROS_ERROR_STREAM(name() << ": " << reason);
        {
          std::lock_guard<std::mutex> lock(mutex_);
          Observed& observed = observed_[spec->name];
          observed.lost = true;
          observed.health = ComponentStatus::HEALTH_STALE;
          observed.message = reason;
          observed.next_restart = wallNow() + heartbeat_timeout_;
        }
        supervisionEvent(spec->name, "lost", reason);
        onComponentLost(*spec, reason);
      } else {
        std::lock_guard<std::mutex> lock(mutex_);
        observed_[spec->name].lost = false;
        observed_[spec->name].message.clear();
      }
      if (!change.lost) supervisionEvent(spec->name, "back", spec->name + " sends its status again");
    }
    if (restart_) {
      for (const auto& component : components_) {
        bool due = false;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          Observed& observed = observed_[component.name];
          // A component somebody shut down on purpose stays down.
          due = observed.lost && observed.state != LifecycleState::Finalized && wallNow() >= observed.next_restart;
          if (due) observed.next_restart = wallNow() + std::max(2.0, heartbeat_timeout_);
        }
        if (!due || !managerAnswers(component.manager)) continue;
        try {
          std::string ignored;
          unload(component, &ignored);  // a hung instance must go before a new one can take its name
          {
            std::lock_guard<std::mutex> lock(mutex_);
            monitor_.expect(component.name, wallNow(), startup_timeout_);
          }
          bringUp(component);
          {
            std::lock_guard<std::mutex> lock(mutex_);
            observed_[component.name].lost = false;
            observed_[component.name].message.clear();
          }
          supervisionEvent(component.name, "restarted", "loaded again into " + component.manager);
          onComponentRestarted(component);
        } catch (const std::exception& e) {
          supervisionEvent(component.name, "failed", std::string("restart failed: ") + e.what());
        }
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

std::vector<std::string> Supervisor::lostComponents() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> lost;
  for (const auto& [name, observed] : observed_) {
    if (observed.lost) lost.push_back(name);
  }
  return lost;
}

LifecycleState Supervisor::lastKnownState(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = observed_.find(name);
  return it == observed_.end() ? LifecycleState::Unconfigured : it->second.state;
}

void Supervisor::supervisionEvent(const std::string& component, const std::string& outcome, const std::string& reason) {
  events().publish(events().make(ComponentEvent::SUPERVISION, component, outcome, reason));
}

void Supervisor::fillStatus(ComponentStatus& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (std::size_t index = 0; index < components_.size(); ++index) {
    const SupervisedComponent& component = components_[index];
    PartStatus part;
    part.name = component.name;
    auto it = observed_.find(component.name);
    if (it != observed_.end()) {
      part.state = static_cast<std::uint8_t>(it->second.state);
      part.health = it->second.health;
      part.message = it->second.message;
    }
    part.state_name = it != observed_.end() && it->second.lost ? "LOST" : toString(static_cast<LifecycleState>(part.state));
    // A bring-up again (this supervisor reconfigured) finds its components ACTIVE or INACTIVE from before: until it
    // has passed them they are not up, whatever their state says (a run resumed into ROBOTMODEL's re-bring-up once).
    const bool still_to_start = bring_up_ == BringUp::Running && index >= bring_up_index_;
    const bool looks_up = part.state == ComponentStatus::INACTIVE || part.state == ComponentStatus::ACTIVE;
    if (still_to_start && looks_up && part.state_name != "LOST") part.state_name = "STARTING";
    if (part.health != ComponentStatus::HEALTH_OK && status.health == ComponentStatus::HEALTH_OK) {
      status.health = ComponentStatus::HEALTH_WARN;
    }
    status.parts.push_back(part);
  }
}

}  // namespace xpersif
