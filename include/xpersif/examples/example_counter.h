/**
 * @file example_counter.h
 * @brief A complete small component, kept as the template for writing new ones (and used by the
 *        component-model tests): one command with a contract, one operation with validation.
 *
 * - command `~count_to` (xpersif/CountTo): count the total up to a target, one step per period.
 *   Preconditions: the target is above the current total and within `~limit`. Effect: total(counter, ?target).
 * - operation `~add_values` (xpersif/AddValues): add finite numbers, at most `~max_values` per call.
 *
 * Parameters (read on configure): `~limit` (default 1e6), `~max_values` (default 1000),
 * `~step_period` (seconds of ROS time per step, default 0.01).
 */
#pragma once

#include <mutex>

#include "xpersif/AddValues.h"
#include "xpersif/CountToAction.h"
#include "xpersif/component/component.h"

namespace xpersif {

class ExampleCounter : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  ExampleCounter(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;

 private:
  using CountTo = CommandServer<CountToAction>;
  CommandOutcome countTo(CountTo::Context& context, CountToResult& result);
  double total() const;

  mutable std::mutex mutex_;
  double total_ = 0;
  std::uint32_t count_ = 0;
  double limit_ = 1e6;
  int max_values_ = 1000;
  double step_period_ = 0.01;
};

}  // namespace xpersif
