#include "xpersif/component/events.h"

#include <ros/names.h>

namespace xpersif {

EventSink::EventSink(ros::NodeHandle& pnh, std::string component) : component_(std::move(component)) {
  // Events are rare (one per call), so a deep queue costs nothing and keeps bursts for slow recorders.
  publisher_ = pnh.advertise<ComponentEvent>("events", 100);
  // The namespace the component lives in (the parent of its private one), where its peers publish theirs.
  ros::NodeHandle common(ros::names::parentNamespace(pnh.getNamespace()));
  shared_publisher_ = common.advertise<ComponentEvent>(kSharedEventsTopic, 100);
}

ComponentEvent EventSink::make(std::uint8_t kind, const std::string& name, const std::string& outcome,
                               const std::string& reason) const {
  ComponentEvent event;
  event.header.stamp = ros::Time::now();
  event.component = component_;
  event.kind = kind;
  event.name = name;
  event.outcome = outcome;
  event.reason = reason;
  event.code = ComponentEvent::NO_CODE;  // operations set theirs
  return event;
}

void EventSink::publish(const ComponentEvent& event) {
  publisher_.publish(event);
  shared_publisher_.publish(event);
}

}  // namespace xpersif
