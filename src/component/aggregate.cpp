#include "xpersif/component/aggregate.h"

#include <tuple>

namespace xpersif {

template <class Step>
void AggregateComponent::forEachPart(const char* verb, LifecycleState reached, Step step) {
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    try {
      step(*parts_[i]);
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(parts_mutex_);
      part_states_[i] = LifecycleState::Error;
      throw std::runtime_error("part '" + parts_[i]->name() + "' failed to " + verb + ": " + e.what());
    }
    std::lock_guard<std::mutex> lock(parts_mutex_);
    part_states_[i] = reached;
  }
}

void AggregateComponent::onConfigure() {
  forEachPart("configure", LifecycleState::Inactive, [this](ComponentPart& part) {
    part.configure(ros::NodeHandle(privateNodeHandle(), part.name()));
  });
}

void AggregateComponent::onActivate() {
  forEachPart("activate", LifecycleState::Active, [](ComponentPart& part) { part.activate(); });
}

void AggregateComponent::onDeactivate() {
  forEachPart("deactivate", LifecycleState::Inactive, [](ComponentPart& part) { part.deactivate(); });
}

void AggregateComponent::onShutdown() {
  // Every part gets its chance to exit, even when an earlier one fails.
  std::string errors;
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    try {
      parts_[i]->shutdown();
    } catch (const std::exception& e) {
      errors += (errors.empty() ? "" : "; ") + ("part '" + parts_[i]->name() + "': " + e.what());
    }
    std::lock_guard<std::mutex> lock(parts_mutex_);
    part_states_[i] = LifecycleState::Finalized;
  }
  if (!errors.empty()) throw std::runtime_error(errors);
}

void AggregateComponent::fillStatus(ComponentStatus& status) {
  std::lock_guard<std::mutex> lock(parts_mutex_);
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    PartStatus part;
    part.name = parts_[i]->name();
    part.state = static_cast<std::uint8_t>(part_states_[i]);
    part.state_name = toString(part_states_[i]);
    std::tie(part.health, part.message) = parts_[i]->diagnose();
    if (part_states_[i] == LifecycleState::Error) part.health = ComponentStatus::HEALTH_ERROR;
    if (part.health > status.health) status.health = part.health;
    status.parts.push_back(part);
  }
}

}  // namespace xpersif
