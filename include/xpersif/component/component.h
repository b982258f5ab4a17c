/**
 * @file component.h
 * @brief The base every XPERSIF component derives from: the paper's component model in ROS 1.
 *
 * A component has, under its private namespace:
 *  - lifecycle services `configure`, `activate`, `deactivate`, `shutdown` (xpersif/Transition) and
 *    `get_state` (xpersif/GetState); illegal transitions are refused with a reason;
 *  - `status` (xpersif/ComponentStatus), published at `~heartbeat_rate` Hz of wall-clock time;
 *  - `events` (xpersif/ComponentEvent), one message per transition, operation call and goal outcome;
 *  - `get_contracts` (xpersif/GetContracts): the contracts of all its commands and operations;
 *  - its commands (actionlib servers) and operations (services), each with a contract;
 *  - `invoke` (xpersif/InvokeAction): runs any of those whose registration gave a binder, from the contract's
 *    parameters bound to values as text (core::Invocation). The binder builds the typed goal or request; the goal
 *    then goes to the command's own action server and the request through the operation's own handling (the
 *    same checks, preconditions, events and effects as a direct call). Bad bindings end the goal ABORTED with
 *    code INVALID and a sentence naming the parameter; a refusal of the command or operation keeps its code
 *    (NOT_ACTIVE, INVALID, PRECONDITION_FAILED, UNAVAILABLE); a failure is FAILED. One invoke goal at a time.
 *    `invoke` is part of the component model, not a contract: get_contracts does not list it.
 *
 * One implementation class runs both as a nodelet and as a node: the class takes (nh, private_nh) and
 * the shells in shells.h construct it, call start(), and call halt() before destroying it.
 *
 * Parameters: Component::baseParameters(), declared once with their defaults, ranges and meanings (doc/parameters.md).
 */
#pragma once

#include <actionlib/client/simple_action_client.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <type_traits>
#include <vector>

#include "xpersif/ComponentStatus.h"
#include "xpersif/GetContracts.h"
#include "xpersif/GetState.h"
#include "xpersif/InvokeAction.h"
#include "xpersif/ResultCode.h"
#include "xpersif/Transition.h"
#include "xpersif/component/command.h"
#include "xpersif/component/events.h"
#include "xpersif/core/common/contract.h"
#include "xpersif/core/common/invocation.h"
#include "xpersif/core/common/lifecycle.h"
#include "xpersif/core/common/parameters.h"
#include "xpersif/core/common/validation.h"

namespace xpersif {

using core::ContractChecker;
using core::ContractError;
using core::Lifecycle;
using core::LifecycleState;
using core::LifecycleTransition;
using core::TransitionResult;

/**
 * @brief How ~invoke runs one command or operation: @p bind builds its typed goal (or request) from an
 *        invocation's bound values, throwing core::ValidationError with a sentence that names the parameter;
 *        @p report (optional) copies what the typed result (or response) says into the invoke result's outputs
 *        and features, e.g. the robot's final pose as output robot_pose "(x, y, yaw)".
 */
template <class Input, class Output>
struct Binder {
  std::function<Input(const core::Invocation&)> bind;
  std::function<void(const Output&, InvokeResult&)> report;
};

/// Add output @p name = @p value to an invoke result (what a binder's report says).
inline void addOutput(InvokeResult& result, const std::string& name, const std::string& value) {
  result.outputs.push_back(name);
  result.output_values.push_back(value);
}

class Component {
 public:
  /// @param type the plugin type shown in status, e.g. "xpersif/ExampleCounterNodelet"
  Component(ros::NodeHandle nh, ros::NodeHandle private_nh, std::string type);
  virtual ~Component();
  Component(const Component&) = delete;
  Component& operator=(const Component&) = delete;

  /// Advertise the lifecycle services, status, contracts and commands. Call once, after construction.
  void start();
  /// Stop running commands and shut down (FINALIZED). Idempotent; call before destruction.
  void halt();

  /// Request a lifecycle transition as the services do (with an event and a fresh status).
  TransitionResult transition(LifecycleTransition transition);

  const std::string& name() const { return name_; }
  const std::string& type() const { return type_; }
  LifecycleState state() const { return lifecycle_.state(); }
  std::vector<core::Contract> contracts() const;

  /// The parameters every component reads: ~heartbeat_rate, ~autostart.
  static const core::ParameterTable& baseParameters();

 protected:
  /// Read parameters and allocate; throw (with a sentence) to fail into ERROR. Runs on every configure.
  virtual void onConfigure() {}
  virtual void onActivate() {}
  /// Running commands have already been stopped (ABORTED) when this runs.
  virtual void onDeactivate() {}
  virtual void onShutdown() {}
  /// The component's declared parameters (its own and its parts'), or nullptr when it declares none. After a
  /// successful configure, parameters set under ~ that neither this table nor baseParameters() declares are
  /// warned about (a misspelt name is otherwise silently ignored).
  virtual const core::ParameterTable* declaredParameters() const { return nullptr; }
  /// Add parts or supervised components to a status message and lower its health. Heartbeat rate.
  virtual void fillStatus(ComponentStatus& status) { (void)status; }

  /// "" when the component is ACTIVE, else the sentence saying that @p what needs it ACTIVE.
  std::string whyNotActive(const std::string& what) const { return whyNotIn(what, true); }
  /// "" when the component is configured (INACTIVE or ACTIVE), else the sentence saying that @p what needs that.
  std::string whyNotConfigured(const std::string& what) const { return whyNotIn(what, false); }

  /// True while halt() runs: the process or nodelet is going away, so skip calls to other nodes.
  bool halting() const { return halting_; }

  /// Put the component in ERROR because of a fault found while running; logs and reports an event.
  void reportError(const std::string& error);

  /**
   * @brief Offer an operation (a service that answers at once) under the component's private namespace.
   *
   * The response type must have `bool success` and `string message`. The call is refused (success false,
   * message says why, code NOT_ACTIVE, nothing changed) when the component is not ACTIVE and @p requires_active is
   * set, or not configured at all (UNCONFIGURED, FINALIZED, ERROR: it would answer from parameters it has not read),
   * when @p validate throws, or when a precondition of @p contract fails. A @p handle that throws reports
   * failure with the exception's text; handlers validate before they change anything. The effects of a call
   * that succeeded are grounded from the request's bindings and, for parameters that only the answer knows (what
   * an operation chose), from @p result_bindings of the request and the response. With @p binder, ~invoke runs
   * the operation too.
   */
  template <class Service>
  void addOperation(ContractChecker<typename Service::Request> contract,
                    std::function<void(const typename Service::Request&)> validate,
                    std::function<void(const typename Service::Request&, typename Service::Response&)> handle,
                    bool requires_active = true,
                    std::function<core::Bindings(const typename Service::Request&, const typename Service::Response&)>
                        result_bindings = nullptr,
                    Binder<typename Service::Request, typename Service::Response> binder = {});

  /// Offer a command (an action); see command.h for the checks and outcomes. With @p binder, ~invoke runs it too.
  template <class ActionSpec>
  void addCommand(ContractChecker<typename CommandServer<ActionSpec>::Goal> contract,
                  typename CommandServer<ActionSpec>::Validate validate,
                  typename CommandServer<ActionSpec>::Execute execute,
                  Binder<typename CommandServer<ActionSpec>::Goal, typename CommandServer<ActionSpec>::Result> binder = {});

  /// The names ~invoke runs (the commands and operations registered with a binder).
  std::vector<std::string> invocable() const;

  ros::NodeHandle& nodeHandle() { return nh_; }
  ros::NodeHandle& privateNodeHandle() { return pnh_; }
  EventSink& events() { return events_; }
  void publishStatus();

 private:
  std::string whyNotIn(const std::string& what, bool active_only) const;
  using InvokeServer = CommandServer<InvokeAction>;
  /// Runs one invocable interface: binds (throwing ValidationError), then calls unless the goal only checks.
  using InvokeRunner = std::function<CommandOutcome(InvokeServer::Context&, const core::Invocation&, InvokeResult&)>;
  struct Invocable {
    core::Contract contract;
    InvokeRunner run;
  };
  void addInvocable(const core::Contract& contract, InvokeRunner run);
  CommandOutcome invoke(InvokeServer::Context& context, InvokeResult& result);
  /// Send @p goal to this component's own command @p command and wait for its end (cancelled when the invoke
  /// goal is stopped); the command's own server checks it, runs it and reports it.
  template <class ActionSpec>
  CommandOutcome invokeCommand(CommandServer<ActionSpec>& server,
                               const Binder<typename CommandServer<ActionSpec>::Goal,
                                            typename CommandServer<ActionSpec>::Result>& binder,
                               InvokeServer::Context& context, const core::Invocation& invocation,
                               InvokeResult& result);

  bool onTransitionService(LifecycleTransition transition, Transition::Response& response);
  bool onGetState(GetState::Response& response);
  bool onGetContracts(GetContracts::Request& request, GetContracts::Response& response);
  void stopCommands(const std::string& reason);
  void warnUndeclaredParameters();
  /// State, health and last error; with @p with_details also running commands and fillStatus().
  ComponentStatus makeStatus(bool with_details);

  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  std::string name_;
  std::string type_;
  Lifecycle lifecycle_;
  EventSink events_;  // declared before commands_: command threads publish events until they are joined

  mutable std::mutex contracts_mutex_;
  std::vector<core::Contract> operation_contracts_;
  std::vector<std::unique_ptr<CommandServerBase>> commands_;
  std::map<std::string, Invocable> invocables_;  // guarded by contracts_mutex_
  std::unique_ptr<InvokeServer> invoke_;

  std::uint64_t heartbeat_ = 0;
  double heartbeat_period_ = 0.2;
  std::mutex status_mutex_;
  bool started_ = false;
  bool halted_ = false;
  std::atomic<bool> halting_{false};

  // Heartbeats have a queue and a thread of their own: a component busy in a long callback of its nodelet's
  // queue (an operation that waits for a model) is busy, not hung, and must not be restarted for it.
  ros::CallbackQueue heartbeat_queue_;
  std::unique_ptr<ros::AsyncSpinner> heartbeat_spinner_;

  // ROS handles last: they are destroyed first, so no callback runs on members already gone.
  std::mutex clients_mutex_;
  std::map<std::string, std::shared_ptr<void>> own_clients_;  // command -> SimpleActionClient to ~command (invoke)
  ros::Publisher status_pub_;
  std::vector<ros::ServiceServer> services_;
  ros::WallTimer heartbeat_timer_;
  ros::WallTimer autostart_timer_;
};

// ---- templates ----------------------------------------------------------------------------------


template <class Service>
void Component::addOperation(ContractChecker<typename Service::Request> contract,
                             std::function<void(const typename Service::Request&)> validate,
                             std::function<void(const typename Service::Request&, typename Service::Response&)> handle,
                             bool requires_active,
                             std::function<core::Bindings(const typename Service::Request&,
                                                          const typename Service::Response&)> result_bindings,
                             Binder<typename Service::Request, typename Service::Response> binder) {
  using Request = typename Service::Request;
  using Response = typename Service::Response;
  if (contract.contract().kind != core::Contract::Kind::Operation) {
    throw ContractError("contract '" + contract.contract().name + "' is registered as an operation but declared as a command");
  }
  {
    std::lock_guard<std::mutex> lock(contracts_mutex_);
    operation_contracts_.push_back(contract.contract());
  }
  auto checker = std::make_shared<ContractChecker<Request>>(std::move(contract));
  const std::string op = checker->contract().name;
  // One call, whoever makes it (the service or ~invoke): checks, handling, the event; returns the code and sets
  // @p effects (grounded) when it succeeded.
  auto call = [this, checker, validate, handle, requires_active, op, result_bindings](
                  const Request& request, Response& response, std::vector<std::string>* effects) {
    const ros::Time started = ros::Time::now();
    const std::string what = "operation '" + op + "'";
    std::string refusal = requires_active ? whyNotActive(what) : whyNotConfigured(what);
    std::uint8_t code = refusal.empty() ? ResultCode::OK : ResultCode::NOT_ACTIVE;
    if (refusal.empty() && validate) {
      try {
        validate(request);
      } catch (const std::exception& e) {
        refusal = std::string("invalid request: ") + e.what();
        code = ResultCode::INVALID;
      }
    }
    if (refusal.empty()) {
      refusal = checker->firstUnmet(request);
      if (!refusal.empty()) code = ResultCode::PRECONDITION_FAILED;
    }
    ComponentEvent event;
    if (!refusal.empty()) {
      response = Response();
      response.success = false;
      response.message = refusal;
      event = events_.make(ComponentEvent::OPERATION, op, "refused", refusal);
    } else {
      // The exception's type is the code (as tf2_ros' buffer server maps TF2Error), never its wording.
      try {
        handle(request, response);
        response.success = true;
        event = events_.make(ComponentEvent::OPERATION, op, "ok");
        event.effects = result_bindings ? checker->groundEffects(request, result_bindings(request, response))
                                        : checker->groundEffects(request);
        if (effects) *effects = event.effects;
      } catch (const core::ValidationError& e) {
        code = ResultCode::INVALID;
        response.success = false;
        response.message = e.what();
      } catch (const core::UnavailableError& e) {
        code = ResultCode::UNAVAILABLE;
        response.success = false;
        response.message = e.what();
      } catch (const std::exception& e) {
        code = ResultCode::FAILED;
        response.success = false;
        response.message = e.what();
      }
      if (!response.success) event = events_.make(ComponentEvent::OPERATION, op, "failed", response.message);
    }
    detail::setCode(response, code);
    event.code = code;
    event.request = toYaml(request);
    event.response = toYaml(response);
    event.duration = (ros::Time::now() - started).toSec();
    events_.publish(event);
    return code;
  };
  boost::function<bool(Request&, Response&)> callback = [call](Request& request, Response& response) {
    call(request, response, nullptr);
    return true;  // the call itself went through; success and message carry the outcome
  };
  services_.push_back(pnh_.advertiseService<Request, Response>(op, callback));
  if (!binder.bind) return;
  addInvocable(checker->contract(), [call, binder](InvokeServer::Context& context, const core::Invocation& invocation,
                                                   InvokeResult& result) {
    const Request request = binder.bind(invocation);
    if (context.goal().check_only) return CommandOutcome::succeeded(result.message = "the bindings are valid");
    Response response;
    result.code = call(request, response, &result.effects);
    result.message = response.message;
    if (!response.success) return CommandOutcome::aborted(result.message);
    if (binder.report) binder.report(response, result);
    return CommandOutcome::succeeded(result.message);
  });
}

template <class ActionSpec>
void Component::addCommand(ContractChecker<typename CommandServer<ActionSpec>::Goal> contract,
                           typename CommandServer<ActionSpec>::Validate validate,
                           typename CommandServer<ActionSpec>::Execute execute,
                           Binder<typename CommandServer<ActionSpec>::Goal, typename CommandServer<ActionSpec>::Result> binder) {
  const std::string command = contract.contract().name;
  const core::Contract declared = contract.contract();
  auto server = std::make_unique<CommandServer<ActionSpec>>(
      pnh_, std::move(contract), std::move(validate), std::move(execute), events_,
      [this, command] { return whyNotActive("command '" + command + "'"); });
  CommandServer<ActionSpec>* raw = server.get();
  {
    std::lock_guard<std::mutex> lock(contracts_mutex_);
    if (started_) server->start();
    commands_.push_back(std::move(server));
  }
  if (!binder.bind) return;
  addInvocable(declared, [this, raw, binder](InvokeServer::Context& context, const core::Invocation& invocation,
                                             InvokeResult& result) {
    return invokeCommand<ActionSpec>(*raw, binder, context, invocation, result);
  });
}

template <class ActionSpec>
CommandOutcome Component::invokeCommand(CommandServer<ActionSpec>& server,
                                        const Binder<typename CommandServer<ActionSpec>::Goal,
                                                     typename CommandServer<ActionSpec>::Result>& binder,
                                        InvokeServer::Context& context, const core::Invocation& invocation,
                                        InvokeResult& result) {
  using Client = actionlib::SimpleActionClient<ActionSpec>;
  const typename CommandServer<ActionSpec>::Goal goal = binder.bind(invocation);
  if (context.goal().check_only) return CommandOutcome::succeeded(result.message = "the bindings are valid");
  const std::string& command = server.contract().name;
  // The command's own checks first, so that a refusal comes with its code; its server checks again on arrival.
  if (const Refusal refusal = server.check(goal)) {
    result.code = refusal.code;
    return CommandOutcome::aborted(result.message = refusal.reason);
  }
  std::shared_ptr<Client> client;
  {
    std::lock_guard<std::mutex> lock(clients_mutex_);
    auto& slot = own_clients_[command];
    // Its own callback thread: results arrive whatever the component's queue is busy with.
    if (!slot) slot = std::make_shared<Client>(pnh_, command, true);
    client = std::static_pointer_cast<Client>(slot);
  }
  const ros::WallTime connect_deadline = ros::WallTime::now() + ros::WallDuration(10.0);
  while (!client->isServerConnected()) {
    if (context.stopRequested()) return CommandOutcome::preempted("stopped before the command started");
    if (ros::WallTime::now() > connect_deadline) {
      result.code = ResultCode::UNAVAILABLE;
      return CommandOutcome::aborted(result.message = "the command " + pnh_.resolveName(command) +
                                                       " did not connect within 10 s of wall time");
    }
    client->waitForServer(ros::Duration(0.02));
  }
  client->sendGoal(goal);
  bool cancelled = false;
  while (!client->getState().isDone()) {
    if (context.stopRequested() && !cancelled) {
      client->cancelGoal();
      cancelled = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const actionlib::SimpleClientGoalState state = client->getState();
  result.message = state.getText();
  const auto typed = client->getResult();
  if (state == actionlib::SimpleClientGoalState::SUCCEEDED) {
    result.code = ResultCode::OK;
    result.effects = server.groundEffects(goal);
    if (binder.report && typed) binder.report(*typed, result);
    return CommandOutcome::succeeded(result.message);
  }
  if (state == actionlib::SimpleClientGoalState::PREEMPTED || state == actionlib::SimpleClientGoalState::RECALLED) {
    return CommandOutcome::preempted(result.message);
  }
  if (state == actionlib::SimpleClientGoalState::REJECTED) {
    // Something changed between the check and the arrival: the same check says what.
    const Refusal refusal = server.check(goal);
    result.code = ResultCode::FAILED;
    if (refusal) result.code = refusal.code;
    return CommandOutcome::aborted(result.message);
  }
  result.code = ResultCode::FAILED;
  return CommandOutcome::aborted(result.message.empty() ? command + " ended " + state.toString() : result.message);
}

}  // namespace xpersif
