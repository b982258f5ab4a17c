// Test-only component: a tank with a level, offering contracted commands and an operation that EXECUTION has
// never heard of (xpersif/CountToAction and xpersif/AddValues under contracts of their own), each with a binder
// for ~invoke. fill_fast fails while ~fast_valve_stuck is set, so that a plan through it must be replanned through
// fill_slow. The level is published on ~level (latched) for tests to observe the effects.
#include <pluginlib/class_list_macros.hpp>
#include <std_msgs/Float64.h>

#include <mutex>

#include "xpersif/AddValues.h"
#include "xpersif/CountToAction.h"
#include "xpersif/component/component.h"
#include "xpersif/component/parameter_reader.h"
#include "xpersif/component/shells.h"

namespace xpersif_test {

using namespace xpersif;

class Tank : public Component {
 public:
  using CountTo = CommandServer<CountToAction>;

  static const core::ParameterTable& parameters() {
    static const core::ParameterTable table(
        "tank (test)",
        {core::numberParameter("capacity", 10.0, 1e-3, 1e6, "the largest level"),
         core::flagParameter("fast_valve_stuck", false, "fill_fast fails (its effects do not hold)")});
    return table;
  }
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  Tank(ros::NodeHandle nh, ros::NodeHandle private_nh)
      : Component(std::move(nh), std::move(private_nh), "xpersif_test/TankNodelet") {
    for (const bool fast : {true, false}) {
      core::Contract declared;
      declared.name = fast ? "fill_fast" : "fill_slow";
      declared.kind = core::Contract::Kind::Command;
      declared.interface_type = "xpersif/CountToAction";
      declared.description = fast ? "fill the tank to a level through the big valve" : "fill the tank to a level, drop by drop";
      declared.parameters = {"?level"};
      declared.preconditions = {{"within_capacity(?level)", "the level must lie in [0, ~capacity]"}};
      declared.effects = {"level(tank, ?level)"};
      ContractChecker<CountToGoal> contract(declared);
      contract.bind([](const CountToGoal& g) { return core::Bindings{{"?level", core::describeNumber(g.target)}}; })
          .check("within_capacity(?level)", [this](const CountToGoal& g) {
            std::lock_guard<std::mutex> lock(mutex_);
            return core::checkInRange("goal.target", g.target, 0.0, capacity_);
          });
      addCommand<CountToAction>(
          contract, [](const CountToGoal& g) { core::requireFinite("goal.target", g.target); },
          [this, fast](CountTo::Context& context, CountToResult& result) { return fill(context, result, fast); },
          {[this](const core::Invocation& invocation) {
             CountToGoal goal;
             double capacity;
             {
               std::lock_guard<std::mutex> lock(mutex_);
               capacity = capacity_;
             }
             goal.target = invocation.number("?level", 0.0, capacity);
             return goal;
           },
           [](const CountToResult& result, InvokeResult& out) {
             addOutput(out, "level", core::describeNumber(result.total));
           }});
    }
    core::Contract drain;
    drain.name = "drain";
    drain.kind = core::Contract::Kind::Operation;
    drain.interface_type = "xpersif/AddValues";
    drain.description = "let an amount out of the tank";
    drain.parameters = {"?amount"};
    drain.effects = {"drained(tank, ?amount)"};
    ContractChecker<AddValues::Request> drain_contract(drain);
    drain_contract.bind([](const AddValues::Request& r) {
      return core::Bindings{{"?amount", r.values.empty() ? "0" : core::describeNumber(-r.values[0])}};
    });
    addOperation<AddValues>(
        drain_contract,
        [](const AddValues::Request& r) {
          core::requireMaxSize("values", r.values.size(), 1);
          core::requireAllFinite("values", r.values);
        },
        [this](const AddValues::Request& r, AddValues::Response& response) {
          std::lock_guard<std::mutex> lock(mutex_);
          for (double v : r.values) level_ = std::max(0.0, level_ + v);
          response.total = level_;
          response.count = static_cast<std::uint32_t>(r.values.size());
          publishLevel();
        },
        true, nullptr,
        {[](const core::Invocation& invocation) {
           AddValues::Request request;
           request.values = {-invocation.number("?amount", 0.0, 1e6)};
           return request;
         },
         nullptr});
  }

 protected:
  void onConfigure() override {
    const ParameterReader parameters(privateNodeHandle(), Tank::parameters());
    const double capacity = parameters.get<double>("capacity");
    const bool stuck = parameters.get<bool>("fast_valve_stuck");
    std::lock_guard<std::mutex> lock(mutex_);
    capacity_ = capacity;
    stuck_ = stuck;
    if (!level_pub_) level_pub_ = privateNodeHandle().advertise<std_msgs::Float64>("level", 1, true);
    publishLevel();
  }

 private:
  CommandOutcome fill(CountTo::Context& context, CountToResult& result, bool fast) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (fast && stuck_) return CommandOutcome::aborted(result.message = "the fast valve is stuck");
    }
    if (!context.sleepFor(ros::Duration(fast ? 0.01 : 0.1))) return CommandOutcome::preempted();
    std::lock_guard<std::mutex> lock(mutex_);
    level_ = result.total = context.goal().target;
    publishLevel();
    return CommandOutcome::succeeded("filled to " + core::describeNumber(level_));
  }

  void publishLevel() {  // mutex_ held
    std_msgs::Float64 level;
    level.data = level_;
    if (level_pub_) level_pub_.publish(level);
  }

  std::mutex mutex_;
  double capacity_ = 10.0;
  bool stuck_ = false;
  double level_ = 0.0;
  ros::Publisher level_pub_;
};

class TankNodelet : public ComponentNodelet<Tank> {};

}  // namespace xpersif_test

PLUGINLIB_EXPORT_CLASS(xpersif_test::TankNodelet, nodelet::Nodelet)
