/**
 * @file lifecycle.h
 * @brief The component lifecycle of the paper's Operation interface (parametrize, start, stop, exit),
 *        as a small state machine without ROS.
 *
 * States: UNCONFIGURED -> (configure) -> INACTIVE <-> (activate/deactivate) <-> ACTIVE; any state
 * -> (shutdown) -> FINALIZED; a failing transition hook puts the machine in ERROR, from which
 * `configure` recovers and `shutdown` exits. Illegal transitions are refused with a sentence that says
 * why and what to do instead; they never change the state.
 */
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>

namespace xpersif::core {

/// Lifecycle states. The numeric values are those of xpersif/ComponentStatus.msg.
enum class LifecycleState : std::uint8_t {
  Unconfigured = 0,
  Inactive = 1,
  Active = 2,
  Finalized = 3,
  Error = 4,
};

/// The four transitions a caller can ask for.
enum class LifecycleTransition : std::uint8_t { Configure, Activate, Deactivate, Shutdown };

/// The state a successful @p transition ends in.
LifecycleState targetOf(LifecycleTransition transition);

/// "UNCONFIGURED", "INACTIVE", ...
const char* toString(LifecycleState state);
/// "configure", "activate", ...
const char* toString(LifecycleTransition transition);

/// Outcome of one requested transition.
struct TransitionResult {
  bool success = false;
  LifecycleState state = LifecycleState::Unconfigured;  ///< state after the request
  std::string message;                                  ///< why it was refused or failed; empty on success
};

/**
 * @brief Thread-safe lifecycle state machine.
 *
 * Hooks run under a transition lock so transitions are serialized; reading the state never waits
 * for a running hook (a deactivate hook may wait for worker threads that read the state). A hook
 * signals failure by throwing; the exception's text becomes the last error and the state ERROR.
 */
class Lifecycle {
 public:
  /// Work done on each transition. Empty hooks are allowed and succeed.
  struct Hooks {
    std::function<void()> on_configure;
    std::function<void()> on_activate;
    std::function<void()> on_deactivate;
    std::function<void()> on_shutdown;
  };

  Lifecycle() = default;
  explicit Lifecycle(Hooks hooks) : hooks_(std::move(hooks)) {}

  void setHooks(Hooks hooks);

  /// Ask for a transition. Never throws: a refused or failed transition is reported in the result.
  TransitionResult request(LifecycleTransition transition);

  /// Explain why @p transition is illegal from @p from, or return "" if it is legal.
  static std::string whyIllegal(LifecycleTransition transition, LifecycleState from);

  /// Put the component in ERROR from the outside (e.g. a fault detected while ACTIVE). A failure while a
  /// transition's hook runs (a thread the hook started, say) wins over that transition: it ends in ERROR.
  void fail(const std::string& error);

  LifecycleState state() const;
  std::string lastError() const;
  bool isActive() const { return state() == LifecycleState::Active; }

 private:
  void runHook(const std::function<void()>& hook);

  void setError(const std::string& error);

  std::mutex transition_mutex_;   // serializes transitions and guards hooks_
  mutable std::mutex error_mutex_;  // guards last_error_
  Hooks hooks_;
  std::atomic<LifecycleState> state_{LifecycleState::Unconfigured};
  std::atomic<std::uint64_t> failures_{0};  // fail() calls so far: a transition checks none came during its hook
  std::string last_error_;
};

}  // namespace xpersif::core
