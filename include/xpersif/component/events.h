/**
 * @file events.h
 * @brief The ~events topic: one ComponentEvent per lifecycle transition, operation call, command goal
 *        outcome and supervision change, so that rosbag can record what services did.
 */
#pragma once

#include <ros/message_operations.h>
#include <ros/ros.h>

#include <sstream>
#include <string>
#include <vector>

#include "xpersif/ComponentEvent.h"

namespace xpersif {

/// Longest request/response text kept in an event; longer ones are cut (images would flood the topic).
constexpr std::size_t kMaxEventTextLength = 4096;

/// A message as the YAML text `rosmsg show`-style printers produce, cut to kMaxEventTextLength.
template <class Message>
std::string toYaml(const Message& message) {
  std::ostringstream out;
  ros::message_operations::Printer<Message>::stream(out, "", message);
  std::string text = out.str();
  if (text.size() > kMaxEventTextLength) {
    text.resize(kMaxEventTextLength);
    text += "\n... (cut)";
  }
  return text;
}

/// The topic, in the components' common namespace, on which every component also publishes its events, so that
/// KNOWLEDGEBASE stores the calls of all components with one subscription and no list of their names.
constexpr const char* kSharedEventsTopic = "component_events";

/// Publishes a component's events on <component>/events and on the shared kSharedEventsTopic of its namespace.
class EventSink {
 public:
  EventSink(ros::NodeHandle& pnh, std::string component);

  ComponentEvent make(std::uint8_t kind, const std::string& name, const std::string& outcome,
                      const std::string& reason = "") const;
  void publish(const ComponentEvent& event);
  const std::string& component() const { return component_; }

 private:
  std::string component_;
  ros::Publisher publisher_, shared_publisher_;
};

}  // namespace xpersif
