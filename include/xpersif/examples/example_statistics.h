/**
 * @file example_statistics.h
 * @brief An example aggregate component (the template for PERCEPTION and OBSERVATION): two parts, one
 *        facade. Part "sum" keeps a scaled sum (`~sum/scale`), part "extremes" the minimum and maximum of
 *        the last `~extremes/history` values; the facade operations `~add_values` and `~get_summary` are
 *        the only way in.
 */
#pragma once

#include <algorithm>
#include <deque>

#include "xpersif/AddValues.h"
#include "xpersif/GetSummary.h"
#include "xpersif/component/aggregate.h"

namespace xpersif {
namespace example {

class SumPart : public ComponentPart {
 public:
  SumPart() : ComponentPart("sum") {}
  void configure(const ros::NodeHandle& parameters) override {
    double scale = 1.0;
    parameters.param("scale", scale, scale);
    core::requireFinite(parameters.getNamespace() + "/scale", scale);
    scale_ = scale;
  }
  void add(double value) {
    sum_ += scale_ * value;
    ++count_;
  }
  double sum() const { return sum_; }
  std::uint32_t count() const { return count_; }

 private:
  double scale_ = 1.0;
  double sum_ = 0;
  std::uint32_t count_ = 0;
};

class ExtremesPart : public ComponentPart {
 public:
  ExtremesPart() : ComponentPart("extremes") {}
  void configure(const ros::NodeHandle& parameters) override {
    int history = 100;
    parameters.param("history", history, history);
    core::requireInRange(parameters.getNamespace() + "/history", history, 1, 1e6);
    history_ = static_cast<std::size_t>(history);
    while (window_.size() > history_) window_.pop_front();
  }
  void add(double value) {
    window_.push_back(value);
    if (window_.size() > history_) window_.pop_front();
  }
  double min() const { return window_.empty() ? 0.0 : *std::min_element(window_.begin(), window_.end()); }
  double max() const { return window_.empty() ? 0.0 : *std::max_element(window_.begin(), window_.end()); }

 private:
  std::size_t history_ = 100;
  std::deque<double> window_;
};

}  // namespace example

class ExampleStatistics : public AggregateComponent {
 public:
  ExampleStatistics(ros::NodeHandle nh, ros::NodeHandle private_nh)
      : AggregateComponent(std::move(nh), std::move(private_nh), "xpersif/ExampleStatisticsNodelet"),
        sum_(addPart<example::SumPart>()),
        extremes_(addPart<example::ExtremesPart>()) {
    core::Contract add_values;
    add_values.name = "add_values";
    add_values.interface_type = "xpersif/AddValues";
    add_values.description = "feed finite numbers to every part";
    add_values.effects = {"increased(count)"};
    addOperation<AddValues>(
        ContractChecker<AddValues::Request>(add_values),
        [](const AddValues::Request& request) {
          core::requireMaxSize("values", request.values.size(), 10000);
          core::requireAllFinite("values", request.values);
        },
        [this](const AddValues::Request& request, AddValues::Response& response) {
          std::lock_guard<std::mutex> lock(mutex_);
          for (double v : request.values) {
            sum_.add(v);
            extremes_.add(v);
          }
          response.total = sum_.sum();
          response.count = sum_.count();
        });

    core::Contract get_summary;
    get_summary.name = "get_summary";
    get_summary.interface_type = "xpersif/GetSummary";
    get_summary.description = "count, scaled sum, minimum and maximum of the values seen";
    addOperation<GetSummary>(ContractChecker<GetSummary::Request>(get_summary), nullptr,
                             [this](const GetSummary::Request&, GetSummary::Response& response) {
                               std::lock_guard<std::mutex> lock(mutex_);
                               response.count = sum_.count();
                               response.sum = sum_.sum();
                               response.min = extremes_.min();
                               response.max = extremes_.max();
                             });
  }

 protected:
  void onConfigure() override {
    std::lock_guard<std::mutex> lock(mutex_);
    AggregateComponent::onConfigure();
  }

 private:
  std::mutex mutex_;
  example::SumPart& sum_;
  example::ExtremesPart& extremes_;
};

}  // namespace xpersif
