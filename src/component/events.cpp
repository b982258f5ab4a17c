#include "xpersif/component/events.h"

namespace xpersif {

EventSink::EventSink(ros::NodeHandle& pnh, std::string component) : component_(std::move(component)) {
  // Events are rare (one per call), so a deep queue costs nothing and keeps bursts for slow recorders.
  publisher_ = pnh.advertise<ComponentEvent>("events", 100);
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
  return event;
}

void EventSink::publish(const ComponentEvent& event) { publisher_.publish(event); }

}  // namespace xpersif
