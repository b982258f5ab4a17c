/**
 * @file command.h
 * @brief A command of the paper's component model: an actionlib action server with a contract.
 *
 * When a goal arrives it is checked, in this order, against: the component being ACTIVE, no other goal
 * running, the goal's validation, and the contract's preconditions. A goal that fails a check is
 * REJECTED with a sentence naming what failed. An accepted goal runs in the command's own thread (never
 * in a callback thread of the nodelet manager); a client's cancel ends it PREEMPTED, a failure ABORTED
 * with a reason, success SUCCEEDED with the contract's grounded effects on ~events. Deactivating the
 * component while a goal runs ends the goal ABORTED ("component deactivated"), never PREEMPTED, so that
 * a client can tell its own cancel from a stop it did not ask for.
 */
#pragma once

#include <actionlib/server/action_server.h>
#include <ros/ros.h>

#include <atomic>
#include <functional>
#include <type_traits>
#include <vector>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "xpersif/ResultCode.h"
#include "xpersif/component/events.h"
#include "xpersif/core/common/contract.h"
#include "xpersif/core/common/validation.h"

namespace xpersif {

namespace detail {
template <class Response, class = void>
struct HasCode : std::false_type {};
template <class Response>
struct HasCode<Response, std::void_t<decltype(std::declval<Response&>().code)>> : std::true_type {};
/// Sets response.code where the message has one (ours do; std_srvs' do not).
template <class Response>
void setCode(Response& response, std::uint8_t code) {
  if constexpr (HasCode<Response>::value) response.code = code;
}
}  // namespace detail

/// Why a goal or request is refused: a ResultCode and a sentence (no refusal when the sentence is empty).
struct Refusal {
  std::uint8_t code = ResultCode::OK;
  std::string reason;
  explicit operator bool() const { return !reason.empty(); }
};

using core::ContractChecker;
using core::ContractError;

/// What every command offers its component, whatever its action type.
class CommandServerBase {
 public:
  virtual ~CommandServerBase() = default;
  virtual const core::Contract& contract() const = 0;
  virtual void start() = 0;
  /// End a running goal ABORTED with @p reason and wait until its thread has finished.
  virtual void stopRunning(const std::string& reason) = 0;
  virtual bool busy() const = 0;
};

/// How an executor ends a goal.
struct CommandOutcome {
  enum class Code { Succeeded, Aborted, Preempted };
  Code code = Code::Succeeded;
  std::string reason;

  static CommandOutcome succeeded(std::string note = "") { return {Code::Succeeded, std::move(note)}; }
  static CommandOutcome aborted(std::string reason) { return {Code::Aborted, std::move(reason)}; }
  static CommandOutcome preempted(std::string note = "cancelled on request") { return {Code::Preempted, std::move(note)}; }
};

template <class ActionSpec>
class CommandServer : public CommandServerBase {
 public:
  ACTION_DEFINITION(ActionSpec);
  using Server = actionlib::ActionServer<ActionSpec>;
  using GoalHandle = typename Server::GoalHandle;

  /// What an executor sees of its goal while it runs.
  class Context {
   public:
    const Goal& goal() const { return *goal_; }
    /// True once the client cancelled or the component is stopping: the executor should return soon.
    bool stopRequested() const { return cancel_requested_ || halt_requested_ || !ros::ok(); }
    bool cancelRequested() const { return cancel_requested_; }
    void publishFeedback(const Feedback& feedback) { handle_.publishFeedback(feedback); }
    ros::Time started() const { return started_; }
    /// Wait @p duration of ROS time (simulated time when /clock runs); false if a stop came first.
    bool sleepFor(const ros::Duration& duration) const {
      const ros::Time end = ros::Time::now() + duration;
      while (ros::Time::now() < end) {
        if (stopRequested()) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
      return !stopRequested();
    }

   private:
    friend class CommandServer;
    GoalHandle handle_;
    GoalConstPtr goal_;
    ros::Time started_;
    std::atomic<bool> cancel_requested_{false};
    std::atomic<bool> halt_requested_{false};
    std::string halt_reason_;  // guarded by the server's mutex_
  };

  using Validate = std::function<void(const Goal&)>;
  using Execute = std::function<CommandOutcome(Context&, Result&)>;
  /// Returns "" when the component accepts goals, else the sentence why not.
  using Readiness = std::function<std::string()>;

  CommandServer(ros::NodeHandle pnh, ContractChecker<Goal> contract, Validate validate, Execute execute,
                EventSink& events, Readiness readiness)
      : contract_(std::move(contract)),
        validate_(std::move(validate)),
        execute_(std::move(execute)),
        events_(events),
        readiness_(std::move(readiness)),
        server_(pnh, contract_.contract().name, [this](GoalHandle gh) { onGoal(gh); },
                [this](GoalHandle gh) { onCancel(gh); }, false) {
    if (contract_.contract().kind != core::Contract::Kind::Command) {
      throw ContractError("contract '" + contract_.contract().name + "' is registered as a command but declared as an operation");
    }
  }

  ~CommandServer() override { stopRunning("the component is being unloaded"); }

  const core::Contract& contract() const override { return contract_.contract(); }
  void start() override { server_.start(); }

  bool busy() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return running_ && !finished_;
  }

  /// The checks a goal would meet if it arrived now (as onGoal makes them), with the refusal's code.
  Refusal check(const Goal& goal) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return checkLocked(goal);
  }
  /// The contract's effects grounded from @p goal's bindings.
  std::vector<std::string> groundEffects(const Goal& goal) const { return contract_.groundEffects(goal); }

  void stopRunning(const std::string& reason) override {
    std::unique_lock<std::mutex> lock(mutex_);
    if (running_ && !finished_) {
      running_->halt_reason_ = reason;
      running_->halt_requested_ = true;
    }
    joinWorker(lock);
  }

 private:
  const std::string& name() const { return contract_.contract().name; }

  // Waits for the worker thread without holding the lock (the worker takes it when it finishes).
  void joinWorker(std::unique_lock<std::mutex>& lock) {
    std::thread worker = std::move(worker_);
    lock.unlock();
    if (worker.joinable()) worker.join();
    lock.lock();
  }

  /// The checks a goal meets on arrival, in order (mutex_ held): readiness, busy, validation, preconditions.
  Refusal checkLocked(const Goal& goal) const {
    if (std::string reason = readiness_ ? readiness_() : ""; !reason.empty()) return {ResultCode::NOT_ACTIVE, reason};
    if (running_ && !finished_) {
      return {ResultCode::UNAVAILABLE, "'" + name() + "' is busy with goal " + running_->handle_.getGoalID().id +
                                           "; it runs one goal at a time, so cancel that goal or wait for it"};
    }
    if (validate_) {
      try {
        validate_(goal);
      } catch (const std::exception& e) {
        return {ResultCode::INVALID, std::string("invalid goal: ") + e.what()};
      }
    }
    if (std::string reason = contract_.firstUnmet(goal); !reason.empty()) return {ResultCode::PRECONDITION_FAILED, reason};
    return {};
  }

  void reject(GoalHandle& gh, const Refusal& refusal) {
    const std::string& reason = refusal.reason;
    Result result;
    detail::setCode(result, refusal.code);
    gh.setRejected(result, reason);
    ComponentEvent event = events_.make(ComponentEvent::COMMAND, name(), "rejected", reason);
    event.goal_id = gh.getGoalID().id;
    event.request = toYaml(*gh.getGoal());
    events_.publish(event);
    ROS_DEBUG_STREAM(events_.component() << ": rejected '" << name() << "' goal: " << reason);
  }

  void onGoal(GoalHandle gh) {
    std::unique_lock<std::mutex> lock(mutex_);
    const Goal& goal = *gh.getGoal();
    const Refusal refusal = checkLocked(goal);
    if (refusal) {
      lock.unlock();
      reject(gh, refusal);
      return;
    }
    joinWorker(lock);  // the previous goal has finished; reap its thread
    auto context = std::make_shared<Context>();
    context->handle_ = gh;
    context->goal_ = gh.getGoal();
    context->started_ = ros::Time::now();
    running_ = context;
    finished_ = false;
    gh.setAccepted();
    ComponentEvent event = events_.make(ComponentEvent::COMMAND, name(), "accepted");
    event.goal_id = gh.getGoalID().id;
    event.request = toYaml(goal);
    events_.publish(event);
    worker_ = std::thread([this, context] { run(context); });
  }

  void onCancel(GoalHandle gh) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (running_ && !finished_ && running_->handle_.getGoalID().id == gh.getGoalID().id) {
      running_->cancel_requested_ = true;
    }
  }

  void run(std::shared_ptr<Context> context) {
    Result result;
    CommandOutcome outcome;
    try {
      outcome = execute_(*context, result);
    } catch (const std::exception& e) {
      outcome = CommandOutcome::aborted(std::string("'") + name() + "' failed: " + e.what());
    }
    std::string halt_reason;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (context->halt_requested_) halt_reason = context->halt_reason_;
      // Free before the result goes out: a client that sends its next goal the moment it has this one's result
      // must not find the command busy. A goal that comes now waits in onGoal (joinWorker) until this thread has
      // published the result and the event, so the events stay in order.
      finished_ = true;
    }
    GoalHandle& gh = context->handle_;
    ComponentEvent event;
    if (!halt_reason.empty() && outcome.code != CommandOutcome::Code::Succeeded) {
      // A stop the client did not ask for is a failure from the client's point of view.
      gh.setAborted(result, halt_reason);
      event = events_.make(ComponentEvent::COMMAND, name(), "aborted", halt_reason);
    } else if (outcome.code == CommandOutcome::Code::Succeeded) {
      gh.setSucceeded(result, outcome.reason);
      event = events_.make(ComponentEvent::COMMAND, name(), "succeeded", outcome.reason);
      event.effects = contract_.groundEffects(context->goal());
    } else if (outcome.code == CommandOutcome::Code::Preempted && context->cancelRequested()) {
      gh.setCanceled(result, outcome.reason);  // an accepted goal that is cancelled ends PREEMPTED
      event = events_.make(ComponentEvent::COMMAND, name(), "preempted", outcome.reason);
    } else {
      const std::string reason = outcome.code == CommandOutcome::Code::Preempted
                                     ? "'" + name() + "' stopped early although nobody cancelled it"
                                     : outcome.reason;
      gh.setAborted(result, reason);
      event = events_.make(ComponentEvent::COMMAND, name(), "aborted", reason);
    }
    event.goal_id = gh.getGoalID().id;
    event.request = toYaml(context->goal());
    event.response = toYaml(result);
    event.duration = (ros::Time::now() - context->started()).toSec();
    events_.publish(event);
  }

  ContractChecker<Goal> contract_;
  Validate validate_;
  Execute execute_;
  EventSink& events_;
  Readiness readiness_;
  Server server_;

  mutable std::mutex mutex_;
  std::shared_ptr<Context> running_;  // the current or last goal
  bool finished_ = true;
  std::thread worker_;
};

}  // namespace xpersif
