#include "xpersif/examples/example_counter.h"

#include "xpersif/component/parameter_reader.h"

#include <pluginlib/class_list_macros.hpp>

#include "xpersif/component/shells.h"

namespace xpersif {

ExampleCounter::ExampleCounter(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/ExampleCounterNodelet") {
  core::Contract count_to;
  count_to.name = "count_to";
  count_to.kind = core::Contract::Kind::Command;
  count_to.interface_type = "xpersif/CountToAction";
  count_to.description = "count the total up to a target, one step per period";
  count_to.parameters = {"?target"};
  count_to.preconditions = {{"above(?target, total)", "the target must exceed the current total"},
                            {"within_limit(?target)", "the target must not exceed ~limit"}};
  // The counter is the subject (first argument): a later total replaces an earlier one in the knowledge base.
  count_to.effects = {"total(counter, ?target)"};
  ContractChecker<CountToGoal> count_contract(count_to);
  count_contract
      .bind([](const CountToGoal& goal) { return core::Bindings{{"?target", core::describeNumber(goal.target)}}; })
      .check("above(?target, total)",
             [this](const CountToGoal& goal) {
               const double now = total();
               return goal.target > now ? "" : "the total is already " + core::describeNumber(now);
             })
      .check("within_limit(?target)", [this](const CountToGoal& goal) {
        std::lock_guard<std::mutex> lock(mutex_);
        return goal.target <= limit_ ? "" : "~limit is " + core::describeNumber(limit_);
      });
  addCommand<CountToAction>(
      count_contract,
      [](const CountToGoal& goal) {
        core::requireFinite("goal.target", goal.target);
        core::requirePositive("goal.step", goal.step);
        core::requireInRange("goal.deadline", goal.deadline, 0.0, 86400.0);
      },
      [this](CountTo::Context& context, CountToResult& result) { return countTo(context, result); });

  core::Contract add_values;
  add_values.name = "add_values";
  add_values.kind = core::Contract::Kind::Operation;
  add_values.interface_type = "xpersif/AddValues";
  add_values.description = "add finite numbers to the total";
  add_values.effects = {"increased(total)"};
  addOperation<AddValues>(
      ContractChecker<AddValues::Request>(add_values),
      [this](const AddValues::Request& request) {
        std::lock_guard<std::mutex> lock(mutex_);
        core::requireMaxSize("values", request.values.size(), static_cast<std::size_t>(max_values_));
        core::requireAllFinite("values", request.values);
      },
      [this](const AddValues::Request& request, AddValues::Response& response) {
        std::lock_guard<std::mutex> lock(mutex_);
        for (double v : request.values) total_ += v;
        count_ += static_cast<std::uint32_t>(request.values.size());
        response.total = total_;
        response.count = count_;
      });
}

const core::ParameterTable& ExampleCounter::parameters() {
  static const core::ParameterTable table(
      "example_counter",
      {core::numberParameter("limit", 1e6, -1e300, 1e300, "the total the command count_to refuses to pass"),
       core::intParameter("max_values", 1000, 1, 10000000, "values an add call may carry at most"),
       core::numberParameter("step_period", 0.01, 1e-6, 60.0, "s between count_to's steps")});
  return table;
}

void ExampleCounter::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, ExampleCounter::parameters());
  const double limit = parameters.get<double>("limit");
  const int max_values = parameters.get<int>("max_values");
  const double step_period = parameters.get<double>("step_period");
  (void)pnh;
  std::lock_guard<std::mutex> lock(mutex_);
  limit_ = limit;
  max_values_ = max_values;
  step_period_ = step_period;
}

double ExampleCounter::total() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return total_;
}

CommandOutcome ExampleCounter::countTo(CountTo::Context& context, CountToResult& result) {
  const CountToGoal& goal = context.goal();
  double period;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    period = step_period_;
  }
  while (true) {
    double now;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      total_ = std::min(goal.target, total_ + goal.step);
      now = result.total = total_;
    }
    if (now >= goal.target) return CommandOutcome::succeeded("reached " + core::describeNumber(now));
    CountToFeedback feedback;
    feedback.total = now;
    context.publishFeedback(feedback);
    const double elapsed = (ros::Time::now() - context.started()).toSec();
    if (goal.deadline > 0 && elapsed > goal.deadline) {
      result.message = "deadline of " + core::describeNumber(goal.deadline) + " s passed at total " +
                       core::describeNumber(now) + " of " + core::describeNumber(goal.target);
      return CommandOutcome::aborted(result.message);
    }
    if (!context.sleepFor(ros::Duration(period))) {
      result.message = "stopped at total " + core::describeNumber(now);
      return CommandOutcome::preempted(result.message);
    }
  }
}

class ExampleCounterNodelet : public ComponentNodelet<ExampleCounter> {};

}  // namespace xpersif

PLUGINLIB_EXPORT_CLASS(xpersif::ExampleCounterNodelet, nodelet::Nodelet)
