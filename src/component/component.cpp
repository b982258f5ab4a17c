#include "xpersif/component/component.h"

#include "xpersif/Contract.h"
#include "xpersif/component/parameter_reader.h"

namespace xpersif {

Component::Component(ros::NodeHandle nh, ros::NodeHandle private_nh, std::string type)
    : nh_(std::move(nh)),
      pnh_(std::move(private_nh)),
      name_(pnh_.getNamespace()),
      type_(std::move(type)),
      events_(pnh_, name_) {
  lifecycle_.setHooks({
      [this] {
        onConfigure();
        warnUndeclaredParameters();
      },
      [this] { onActivate(); },
      [this] {
        stopCommands("component " + name_ + " was deactivated while the command ran");
        onDeactivate();
      },
      [this] { onShutdown(); },
  });
  core::Contract declared;
  declared.name = "invoke";
  declared.kind = core::Contract::Kind::Command;
  declared.interface_type = "xpersif/InvokeAction";
  declared.description = "run a contracted command or operation from its parameters bound to values as text";
  declared.parameters = {"?operator"};
  ContractChecker<InvokeGoal> invoke_contract(declared);
  invoke_contract.bind([](const InvokeGoal& goal) {
    return core::Bindings{{"?operator", goal.operator_name.substr(0, 128)}};
  });
  // No readiness of its own: the command or operation it runs says whether it needs the component ACTIVE.
  invoke_ = std::make_unique<InvokeServer>(
      pnh_, std::move(invoke_contract), InvokeServer::Validate(),
      [this](InvokeServer::Context& context, InvokeResult& result) { return invoke(context, result); }, events_,
      InvokeServer::Readiness());
}

Component::~Component() { halt(); }

void Component::start() {
  if (started_) return;
  const ParameterReader parameters(pnh_, baseParameters());
  double rate = 5.0;
  try {
    rate = parameters.get<double>("heartbeat_rate");
  } catch (const core::ValidationError& e) {
    ROS_WARN_STREAM(name_ << ": " << e.what() << "; using 5");  // start() cannot fail: the status says the rest
  }
  heartbeat_period_ = 1.0 / rate;
  // Status and heartbeat are latched so a supervisor that subscribes late sees the state at once.
  status_pub_ = pnh_.advertise<ComponentStatus>("status", 10, true);

  const std::pair<const char*, LifecycleTransition> transitions[] = {
      {"configure", LifecycleTransition::Configure},
      {"activate", LifecycleTransition::Activate},
      {"deactivate", LifecycleTransition::Deactivate},
      {"shutdown", LifecycleTransition::Shutdown},
  };
  for (const auto& [service, transition] : transitions) {
    const LifecycleTransition t = transition;
    boost::function<bool(Transition::Request&, Transition::Response&)> callback =
        [this, t](Transition::Request&, Transition::Response& response) { return onTransitionService(t, response); };
    services_.push_back(pnh_.advertiseService<Transition::Request, Transition::Response>(service, callback));
  }
  boost::function<bool(GetState::Request&, GetState::Response&)> get_state =
      [this](GetState::Request&, GetState::Response& response) { return onGetState(response); };
  services_.push_back(pnh_.advertiseService<GetState::Request, GetState::Response>("get_state", get_state));
  services_.push_back(pnh_.advertiseService("get_contracts", &Component::onGetContracts, this));

  {
    std::lock_guard<std::mutex> lock(contracts_mutex_);
    for (auto& command : commands_) command->start();
    invoke_->start();
    started_ = true;
  }
  publishStatus();
  // Wall time: heartbeats must go on while simulated time is paused or stepped.
  ros::NodeHandle heartbeat_nh(pnh_);
  heartbeat_nh.setCallbackQueue(&heartbeat_queue_);
  heartbeat_timer_ = heartbeat_nh.createWallTimer(ros::WallDuration(heartbeat_period_), [this](const ros::WallTimerEvent&) {
    publishStatus();
  });
  heartbeat_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &heartbeat_queue_);
  heartbeat_spinner_->start();

  bool autostart = false;
  try {
    autostart = parameters.get<bool>("autostart");
  } catch (const core::ValidationError& e) {
    ROS_WARN_STREAM(name_ << ": " << e.what() << "; not starting by itself");
  }
  if (autostart) {
    // Deferred to a callback: a nodelet's onInit runs inside the manager's load service, and a
    // component's start-up may itself call that manager (organizational components do).
    autostart_timer_ = pnh_.createWallTimer(ros::WallDuration(0.01), [this](const ros::WallTimerEvent&) {
      if (transition(LifecycleTransition::Configure).success) transition(LifecycleTransition::Activate);
    }, true);
  }
}

const core::ParameterTable& Component::baseParameters() {
  static const core::ParameterTable table(
      "every component",
      {core::numberParameter("heartbeat_rate", 5.0, 0.1, 1000.0,
                             "Hz of wall time at which ~status is published (the supervisor's heartbeat)"),
       core::flagParameter("autostart", false,
                           "configure and activate right after start, for use without a supervisor")});
  return table;
}

void Component::warnUndeclaredParameters() {
  const core::ParameterTable* declared = declaredParameters();
  if (!declared) return;
  std::vector<std::string> set;
  for (const auto& name : parametersSetUnder(pnh_)) {
    if (!baseParameters().find(name)) set.push_back(name);
  }
  for (const auto& unknown : declared->undeclared(set)) {
    ROS_WARN_STREAM(name_ << ": " << unknown << " is set, but " << type_
                          << " does not read it (doc/parameters.md)");
  }
}

void Component::halt() {
  {
    std::lock_guard<std::mutex> lock(status_mutex_);
    if (halted_) return;
    halted_ = true;
  }
  halting_ = true;
  autostart_timer_.stop();
  stopCommands("component " + name_ + " is shutting down");
  if (lifecycle_.state() != LifecycleState::Finalized) transition(LifecycleTransition::Shutdown);
  heartbeat_timer_.stop();
  if (heartbeat_spinner_) heartbeat_spinner_->stop();
  // The last word: FINALIZED, so that supervisors see a deliberate exit rather than silence.
  if (status_pub_) status_pub_.publish(makeStatus(false));
}

void Component::stopCommands(const std::string& reason) {
  std::vector<CommandServerBase*> commands;
  {
    std::lock_guard<std::mutex> lock(contracts_mutex_);
    for (auto& c : commands_) commands.push_back(c.get());
    commands.push_back(invoke_.get());  // last: it waits for the command it runs, which ends first
  }
  for (auto* c : commands) c->stopRunning(reason);
}

TransitionResult Component::transition(LifecycleTransition transition) {
  const ros::Time started = ros::Time::now();
  TransitionResult result = lifecycle_.request(transition);
  const char* outcome = result.success ? "ok" : (result.state == LifecycleState::Error ? "failed" : "refused");
  ComponentEvent event = events_.make(ComponentEvent::LIFECYCLE, toString(transition), outcome, result.message);
  event.response = std::string("state: ") + toString(result.state);
  event.duration = (ros::Time::now() - started).toSec();
  events_.publish(event);
  if (result.success) {
    ROS_INFO_STREAM(name_ << ": " << toString(transition) << " -> " << toString(result.state));
  } else {
    ROS_WARN_STREAM(name_ << ": " << result.message);
  }
  publishStatus();
  return result;
}

bool Component::onTransitionService(LifecycleTransition t, Transition::Response& response) {
  const TransitionResult result = transition(t);
  response.success = result.success;
  response.message = result.message;
  // Refused: the lifecycle does not allow it from this state; failed: the component's hook threw.
  response.code = result.success ? ResultCode::OK
                                 : (result.state == LifecycleState::Error ? ResultCode::FAILED : ResultCode::PRECONDITION_FAILED);
  response.state = static_cast<std::uint8_t>(result.state);
  response.state_name = toString(result.state);
  return true;
}

bool Component::onGetState(GetState::Response& response) {
  const ComponentStatus status = makeStatus(false);
  response.state = status.state;
  response.state_name = status.state_name;
  response.health = status.health;
  response.last_error = status.last_error;
  ComponentEvent event = events_.make(ComponentEvent::OPERATION, "get_state", "ok");
  event.code = ResultCode::OK;
  event.response = toYaml(response);
  events_.publish(event);
  return true;
}

std::vector<core::Contract> Component::contracts() const {
  std::lock_guard<std::mutex> lock(contracts_mutex_);
  std::vector<core::Contract> all;
  for (const auto& c : commands_) all.push_back(c->contract());
  all.insert(all.end(), operation_contracts_.begin(), operation_contracts_.end());
  return all;
}

namespace {

xpersif::Contract toMessage(const core::Contract& contract) {
  xpersif::Contract msg;
  msg.name = contract.name;
  msg.kind = core::toString(contract.kind);
  msg.interface_type = contract.interface_type;
  msg.description = contract.description;
  msg.parameters = contract.parameters;
  for (const auto& c : contract.preconditions) {
    xpersif::Condition condition;
    condition.literal = c.literal;
    condition.description = c.description;
    msg.preconditions.push_back(condition);
  }
  msg.effects = contract.effects;
  return msg;
}

}  // namespace

bool Component::onGetContracts(GetContracts::Request& request, GetContracts::Response& response) {
  std::vector<std::string> names;
  for (const auto& contract : contracts()) {
    names.push_back(contract.name);
    if (request.name.empty() || request.name == contract.name) response.contracts.push_back(toMessage(contract));
  }
  response.success = request.name.empty() || !response.contracts.empty();
  response.code = response.success ? ResultCode::OK : ResultCode::INVALID;
  if (!response.success) {
    response.message = "component " + name_ + " has no command or operation '" + request.name + "'; it has: ";
    for (std::size_t i = 0; i < names.size(); ++i) response.message += (i ? ", " : "") + names[i];
  }
  ComponentEvent event =
      events_.make(ComponentEvent::OPERATION, "get_contracts", response.success ? "ok" : "refused", response.message);
  event.code = response.code;
  event.request = toYaml(request);
  events_.publish(event);
  return true;
}

void Component::addInvocable(const core::Contract& contract, InvokeRunner run) {
  std::lock_guard<std::mutex> lock(contracts_mutex_);
  invocables_[contract.name] = Invocable{contract, std::move(run)};
}

std::vector<std::string> Component::invocable() const {
  std::lock_guard<std::mutex> lock(contracts_mutex_);
  std::vector<std::string> names;
  for (const auto& entry : invocables_) names.push_back(entry.first);
  return names;
}

CommandOutcome Component::invoke(InvokeServer::Context& context, InvokeResult& result) {
  const InvokeGoal& goal = context.goal();
  result.code = ResultCode::INVALID;
  if (const std::string why = core::checkMaxLength("operator_name", goal.operator_name, 128); !why.empty()) {
    return CommandOutcome::aborted(result.message = why);
  }
  Invocable entry;
  {
    std::lock_guard<std::mutex> lock(contracts_mutex_);
    const auto found = invocables_.find(goal.operator_name);
    if (found == invocables_.end()) {
      std::string names;
      for (const auto& e : invocables_) names += (names.empty() ? "" : ", ") + e.first;
      result.message = "operator_name '" + goal.operator_name + "' is no command or operation that component " + name_ +
                       " runs through invoke; it runs: " + (names.empty() ? "none" : names);
      return CommandOutcome::aborted(result.message);
    }
    entry = found->second;
  }
  result.interface_type = entry.contract.interface_type;
  CommandOutcome outcome;
  try {
    const core::Invocation invocation(goal.operator_name, entry.contract.parameters, goal.parameters, goal.values,
                                      goal.settings, goal.setting_values);
    result.code = ResultCode::OK;  // the interface sets its own code when it refuses or fails
    outcome = entry.run(context, invocation, result);
  } catch (const core::ValidationError& e) {  // the binder: bad, missing or unknown values
    result.code = ResultCode::INVALID;
    return CommandOutcome::aborted(result.message = e.what());
  } catch (const std::exception& e) {
    result.code = ResultCode::FAILED;
    return CommandOutcome::aborted(result.message = "'" + goal.operator_name + "' failed: " + e.what());
  }
  if (outcome.code == CommandOutcome::Code::Preempted) result.code = ResultCode::FAILED;
  return outcome;
}

std::string Component::whyNotIn(const std::string& what, bool active_only) const {
  const LifecycleState state = lifecycle_.state();
  if (state == LifecycleState::Active || (!active_only && state == LifecycleState::Inactive)) return "";
  std::string reason = what + " needs component " + name_ + (active_only ? " ACTIVE" : " configured (INACTIVE or ACTIVE)") +
                       ", but it is " + toString(state);
  if (state == LifecycleState::Error) reason += " (" + lifecycle_.lastError() + ")";
  return reason;
}

void Component::reportError(const std::string& error) {
  ROS_ERROR_STREAM(name_ << ": " << error);
  lifecycle_.fail(error);
  stopCommands("component " + name_ + " failed: " + error);
  events_.publish(events_.make(ComponentEvent::LIFECYCLE, "error", "failed", error));
  publishStatus();
}

void Component::publishStatus() {
  ComponentStatus status = makeStatus(true);
  std::lock_guard<std::mutex> lock(status_mutex_);
  if (halted_) return;
  status.heartbeat = ++heartbeat_;
  status_pub_.publish(status);
}

ComponentStatus Component::makeStatus(bool with_details) {
  ComponentStatus status;
  status.header.stamp = ros::Time(ros::WallTime::now().toSec());
  status.component = name_;
  status.type = type_;
  const LifecycleState state = lifecycle_.state();
  status.state = static_cast<std::uint8_t>(state);
  status.state_name = toString(state);
  status.health = state == LifecycleState::Error ? ComponentStatus::HEALTH_ERROR : ComponentStatus::HEALTH_OK;
  status.last_error = lifecycle_.lastError();
  status.heartbeat_period = heartbeat_period_;
  if (!with_details) return status;  // while halting, derived parts may be gone
  {
    std::lock_guard<std::mutex> lock(contracts_mutex_);
    for (const auto& c : commands_) {
      if (c->busy()) status.running_commands.push_back(c->contract().name);
    }
  }
  fillStatus(status);
  return status;
}

}  // namespace xpersif
