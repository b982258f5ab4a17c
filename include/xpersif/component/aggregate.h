/**
 * @file aggregate.h
 * @brief The paper's aggregate component: one component that owns its parts and shows one interface
 *        (a facade). PERCEPTION and OBSERVATION, each with its own feature-extraction instance, are
 *        aggregates.
 *
 * Parts are plain objects owned by the aggregate; nobody but the aggregate calls them. Their
 * lifecycle follows the aggregate's (configured, activated, deactivated and shut down in order, each
 * part reading its parameters from `~<part name>/...`); a part that fails to configure or activate
 * puts the whole aggregate in ERROR with a sentence naming the part. The aggregate's status lists its
 * parts.
 */
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "xpersif/component/component.h"

namespace xpersif {

/// One part of an aggregate. Hooks throw (with a sentence) to fail.
class ComponentPart {
 public:
  explicit ComponentPart(std::string name) : name_(std::move(name)) {}
  virtual ~ComponentPart() = default;

  const std::string& name() const { return name_; }
  /// @param parameters the part's parameter namespace, `~<part name>`
  virtual void configure(const ros::NodeHandle& parameters) { (void)parameters; }
  virtual void activate() {}
  virtual void deactivate() {}
  virtual void shutdown() {}
  /// "" while the part is healthy, else what is wrong (shown in the aggregate's status).
  virtual std::string problem() const { return ""; }
  /// problem() with its health, read together: HEALTH_WARN by default (waiting for something that will come);
  /// a part that refuses to work with what it was given (FEATUREEXTRACTION refusing a scene it cannot perceive)
  /// says HEALTH_ERROR, which its aggregate's status carries, so that a supervisor can tell the two apart by code.
  virtual std::pair<std::uint8_t, std::string> diagnose() const {
    std::string message = problem();
    return {message.empty() ? ComponentStatus::HEALTH_OK : ComponentStatus::HEALTH_WARN, std::move(message)};
  }

 private:
  std::string name_;
};

class AggregateComponent : public Component {
 public:
  using Component::Component;

 protected:
  /// Add a part; call from the constructor, in the order the parts should start.
  template <class Part, class... Args>
  Part& addPart(Args&&... args) {
    auto part = std::make_shared<Part>(std::forward<Args>(args)...);
    Part& ref = *part;
    parts_.push_back(std::move(part));
    part_states_.push_back(LifecycleState::Unconfigured);
    return ref;
  }
  const std::vector<std::shared_ptr<ComponentPart>>& parts() const { return parts_; }

  /// Aggregates that override these must call the base versions.
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;
  void fillStatus(ComponentStatus& status) override;

 private:
  template <class Step>
  void forEachPart(const char* verb, LifecycleState reached, Step step);

  std::vector<std::shared_ptr<ComponentPart>> parts_;
  std::vector<LifecycleState> part_states_;
  std::mutex parts_mutex_;
};

}  // namespace xpersif
