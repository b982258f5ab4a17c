#include "xpersif/core/common/lifecycle.h"

#include <exception>

namespace xpersif::core {

const char* toString(LifecycleState state) {
  switch (state) {
    case LifecycleState::Unconfigured: return "UNCONFIGURED";
    case LifecycleState::Inactive: return "INACTIVE";
    case LifecycleState::Active: return "ACTIVE";
    case LifecycleState::Finalized: return "FINALIZED";
    case LifecycleState::Error: return "ERROR";
  }
  return "UNKNOWN";
}

const char* toString(LifecycleTransition transition) {
  switch (transition) {
    case LifecycleTransition::Configure: return "configure";
    case LifecycleTransition::Activate: return "activate";
    case LifecycleTransition::Deactivate: return "deactivate";
    case LifecycleTransition::Shutdown: return "shutdown";
  }
  return "unknown";
}

void Lifecycle::setHooks(Hooks hooks) {
  std::lock_guard<std::mutex> lock(transition_mutex_);
  hooks_ = std::move(hooks);
}

LifecycleState targetOf(LifecycleTransition transition) {
  switch (transition) {
    case LifecycleTransition::Configure: return LifecycleState::Inactive;
    case LifecycleTransition::Activate: return LifecycleState::Active;
    case LifecycleTransition::Deactivate: return LifecycleState::Inactive;
    case LifecycleTransition::Shutdown: return LifecycleState::Finalized;
  }
  return LifecycleState::Error;
}

std::string Lifecycle::whyIllegal(LifecycleTransition transition, LifecycleState from) {
  const std::string prefix = std::string("cannot ") + toString(transition) + " from " + toString(from) + ": ";
  if (from == LifecycleState::Finalized) {
    return prefix + "the component has been shut down; unload and load it again";
  }
  switch (transition) {
    case LifecycleTransition::Configure:
      // Re-configuring an INACTIVE component re-reads its parameters (the paper's "parametrize").
      if (from == LifecycleState::Active) return prefix + "deactivate it first";
      return "";
    case LifecycleTransition::Activate:
      if (from == LifecycleState::Inactive) return "";
      if (from == LifecycleState::Active) return prefix + "it is already ACTIVE";
      if (from == LifecycleState::Error) return prefix + "configure it again to recover first";
      return prefix + "configure it first";
    case LifecycleTransition::Deactivate:
      if (from == LifecycleState::Active) return "";
      return prefix + "only an ACTIVE component can be deactivated";
    case LifecycleTransition::Shutdown:
      return "";
  }
  return prefix + "unknown transition";
}

void Lifecycle::runHook(const std::function<void()>& hook) {
  if (hook) hook();
}

TransitionResult Lifecycle::request(LifecycleTransition transition) {
  std::lock_guard<std::mutex> lock(transition_mutex_);
  TransitionResult result;
  const LifecycleState from = state_;
  const std::string illegal = whyIllegal(transition, from);
  if (!illegal.empty()) {
    result.state = from;
    result.message = illegal;
    return result;
  }
  const std::uint64_t failures_before = failures_;
  try {
    switch (transition) {
      case LifecycleTransition::Configure: runHook(hooks_.on_configure); break;
      case LifecycleTransition::Activate: runHook(hooks_.on_activate); break;
      case LifecycleTransition::Deactivate: runHook(hooks_.on_deactivate); break;
      case LifecycleTransition::Shutdown:
        // An ACTIVE component stops its work before it exits.
        if (from == LifecycleState::Active) runHook(hooks_.on_deactivate);
        runHook(hooks_.on_shutdown);
        break;
    }
  } catch (const std::exception& e) {
    const std::string error = std::string(toString(transition)) + " failed: " + e.what();
    // A component that fails while exiting is still gone; anything else lands in ERROR.
    setError(error);
    state_ = transition == LifecycleTransition::Shutdown ? LifecycleState::Finalized : LifecycleState::Error;
    result.state = state_;
    result.message = error;
    return result;
  }
  // A failure reported while the hook ran (e.g. by a bring-up thread it started) must not be overwritten by
  // the transition's target state: the component would claim to be ACTIVE with its work already failed.
  if (failures_ != failures_before &&
      (transition == LifecycleTransition::Configure || transition == LifecycleTransition::Activate)) {
    state_ = LifecycleState::Error;
    result.state = state_;
    result.message = std::string(toString(transition)) + " failed: " + lastError();
    return result;
  }
  state_ = targetOf(transition);
  if (transition == LifecycleTransition::Configure) setError("");
  result.success = true;
  result.state = state_;
  return result;
}

void Lifecycle::setError(const std::string& error) {
  std::lock_guard<std::mutex> lock(error_mutex_);
  last_error_ = error;
}

void Lifecycle::fail(const std::string& error) {
  if (state_ == LifecycleState::Finalized) return;
  setError(error);
  state_ = LifecycleState::Error;
  ++failures_;
}

LifecycleState Lifecycle::state() const { return state_; }

std::string Lifecycle::lastError() const {
  std::lock_guard<std::mutex> lock(error_mutex_);
  return last_error_;
}

}  // namespace xpersif::core
