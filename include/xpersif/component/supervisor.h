/**
 * @file supervisor.h
 * @brief The paper's organizational component: it starts, parametrizes, monitors and exits other
 *        components. LOOPMODEL (the loop) and ROBOTMODEL (the embodiment) are organizational.
 *
 * Activating it starts supervision: in its own thread it loads, configures and activates the components
 * in order (a component that cannot be started puts the supervisor in ERROR, with the reason; one whose manager
 * died and came back meanwhile is started again, up to kBringUpAttempts times), then watches them. A command
 * that needs the components waits for that bring-up first (waitUntilUp). It loads its components into nodelet managers through their `load_nodelet` / `unload_nodelet`
 * services, sets their parameters, drives their lifecycle services, and watches their `~status`
 * heartbeats: a component (or its whole manager) that goes silent for `~heartbeat_timeout` seconds is
 * reported lost on `~events` and in `~status`; with `~restart` set, it is loaded and started again once
 * its manager answers again (a respawned manager, for instance).
 *
 * Parameters: Supervisor::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md).
 * The list, e.g.:
 * @code
 * components:                      # started in this order, exited in the reverse order
 *   - name: counter                # resolved in the supervisor's namespace
 *     type: xpersif/ExampleCounterNodelet
 *     manager: loop_manager        # resolved in the supervisor's namespace
 *     activate: true               # default true; false leaves it INACTIVE
 *     params: {limit: 100.0}       # set under the component's private namespace before configure
 * @endcode
 */
#pragma once

#include <xmlrpcpp/XmlRpcValue.h>

#include <atomic>
#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "xpersif/component/component.h"
#include "xpersif/core/common/heartbeat_monitor.h"

namespace xpersif {

/// One supervised component, as configured.
struct SupervisedComponent {
  std::string name;     ///< fully resolved node name
  std::string type;     ///< nodelet plugin type
  std::string manager;  ///< fully resolved manager node name
  bool activate = true;
  XmlRpc::XmlRpcValue params;  ///< a struct, or invalid when there are none
};

class Supervisor : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  Supervisor(ros::NodeHandle nh, ros::NodeHandle private_nh, std::string type = "xpersif/SupervisorNodelet");
  ~Supervisor() override;

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;
  void fillStatus(ComponentStatus& status) override;

  /// Called from the monitor thread when a component goes silent or comes back.
  virtual void onComponentLost(const SupervisedComponent& component, const std::string& reason) {
    (void)component;
    (void)reason;
  }
  virtual void onComponentRestarted(const SupervisedComponent& component) { (void)component; }
  /// Every status heard from a supervised component (subscriber thread; keep it short).
  virtual void onComponentStatus(const std::string& name, const ComponentStatus& status) {
    (void)name;
    (void)status;
  }

  const std::vector<SupervisedComponent>& supervised() const { return components_; }
  /// Last state heard from @p name (UNCONFIGURED if never heard).
  LifecycleState lastKnownState(const std::string& name) const;
  /// The supervised components that are lost now (silent, not yet back or restarted).
  std::vector<std::string> lostComponents() const;
  double heartbeatTimeout() const { return heartbeat_timeout_; }

  /// Call a supervised component's lifecycle service; throws std::runtime_error with the reason on failure.
  void requestTransition(const SupervisedComponent& component, LifecycleTransition transition) const;
  /// Wait up to ~startup_timeout for one of @p component's lifecycle services; throws at once when its manager
  /// answers without it (respawned), and after ~startup_timeout otherwise.
  void waitForTransitionService(const SupervisedComponent& component, const std::string& service) const;
  /// Load a component into its manager (unless it is already loaded there) and set its parameters.
  void load(const SupervisedComponent& component) const;
  /// Whether its manager lists it as loaded; nullopt when the manager's list does not answer (asked three times):
  /// an unanswered list is no evidence that the component is gone.
  std::optional<bool> loadedIn(const SupervisedComponent& component) const;
  /// Whether @p component's manager answers without it (the manager was restarted, and the component not yet loaded).
  bool respawnedWithout(const SupervisedComponent& component) const;
  /// Unload a component from its manager; returns false (and says why) if that did not work.
  bool unload(const SupervisedComponent& component, std::string* why) const;
  /// Load, configure and (if asked) activate one component, waiting for it to answer.
  void bringUp(const SupervisedComponent& component);
  /// Waits until the bring-up that activation began has passed every component, and every component says it is up
  /// (a supervised supervisor's components too): "" then; otherwise why not (a component could not be started or
  /// failed, supervision stopped, @p stop said so, or @p patience s of wall time passed, naming the component still
  /// starting). A command that needs the components calls it first: a supervisor just
  /// (re)started is asked for work as soon as it is ACTIVE, while its components are still starting.
  std::string waitUntilUp(double patience, const std::function<bool()>& stop) const;
  /// The first supervised component in ERROR, or whose own part is (ROBOTMODEL's MANIPULATION), as a sentence with
  /// its last error; "" if none. Waiting will not mend it (only a configure does); a lost one is being restarted.
  std::string failedComponent() const;
  double startupTimeout() const { return startup_timeout_; }

 private:
  struct Observed {
    LifecycleState state = LifecycleState::Unconfigured;
    std::uint8_t health = ComponentStatus::HEALTH_OK;
    std::string message;
    std::uint64_t heartbeat = 0;
    bool lost = false;
    double next_restart = 0;  // wall time of the next restart attempt
    std::string part_not_up;  // its first part not up (a nested supervisor's bring-up), e.g. "/relocation (UNCONFIGURED)"
    bool part_failed = false;  // that part is in ERROR
  };
  struct NotUp {
    std::string what;     ///< "" when every component is up; else the first that is not, e.g. "/robot_model's /relocation"
    bool failed = false;  ///< it is in ERROR: waiting longer will not help
  };
  /// Whether every supervised component is up as its last status says (not UNCONFIGURED, ERROR or lost, and none of
  /// its parts so, nor STARTING: a supervised supervisor's own bring-up counts, a second one too). Under mutex_.
  NotUp notUpLocked() const;
  /// The same for one component. Under mutex_.
  NotUp notUpLocked(const std::string& name) const;

  static std::vector<SupervisedComponent> parseComponents(const XmlRpc::XmlRpcValue& list, const ros::NodeHandle& nh);
  void watch(const SupervisedComponent& component);
  void onStatus(const std::string& name, const ComponentStatus::ConstPtr& status);
  void monitorLoop();
  void stopMonitor();
  bool managerAnswers(const std::string& manager) const;
  /// True (and said in the log) when @p component's manager is gone, or answers without it (respawned): nothing to
  /// ask it, and no ~startup_timeout to wait for its services (deactivate, shutdown).
  bool wentWithItsManager(const SupervisedComponent& component) const;
  void supervisionEvent(const std::string& name, const std::string& outcome, const std::string& reason);
  enum class BringUp { Idle, Running, Done, Failed };
  static constexpr int kBringUpAttempts = 3;  // per component, when its manager dies while it is being started
  /// @p index: while Running, the component under way (those from it on are reported STARTING).
  void setBringUp(BringUp state, const std::string& note, std::size_t index = 0);

  std::vector<SupervisedComponent> components_;
  double heartbeat_timeout_ = 1.0;
  double startup_timeout_ = 10.0;
  bool restart_ = true;

  mutable std::mutex mutex_;  // guards monitor_, observed_
  core::HeartbeatMonitor monitor_{1.0};
  std::map<std::string, Observed> observed_;
  std::vector<ros::Subscriber> status_subscribers_;

  std::thread monitor_thread_;
  std::atomic<bool> monitoring_{false};
  BringUp bring_up_ = BringUp::Idle;  // guarded by mutex_, like bring_up_note_
  std::string bring_up_note_;          // the component being brought up, or why the bring-up failed or stopped
  std::size_t bring_up_index_ = 0;     // while Running: components_ from this index on are not (again) up yet
  mutable std::condition_variable bring_up_changed_;
};

}  // namespace xpersif
