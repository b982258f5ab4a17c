/**
 * @file shells.h
 * @brief The two thin shells around one component class: a nodelet and a stand-alone node.
 *
 * A component's .cpp ends with
 * @code
 *   class ExampleCounterNodelet : public xpersif::ComponentNodelet<ExampleCounter> {};
 *   PLUGINLIB_EXPORT_CLASS(xpersif::ExampleCounterNodelet, nodelet::Nodelet)
 * @endcode
 * and its node's main is `return xpersif::runComponentNode<ExampleCounter>(argc, argv, "example_counter");`.
 */
#pragma once

#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include <memory>

namespace xpersif {

template <class ComponentClass>
class ComponentNodelet : public nodelet::Nodelet {
 public:
  ~ComponentNodelet() override {
    // Stop command threads and run the shutdown hooks while the derived component is still whole.
    if (component_) component_->halt();
  }

 protected:
  void onInit() override {
    component_ = std::make_unique<ComponentClass>(getNodeHandle(), getPrivateNodeHandle());
    component_->start();
  }

  ComponentClass& component() { return *component_; }

 private:
  std::unique_ptr<ComponentClass> component_;
};

/// main() of a component run as its own process.
template <class ComponentClass>
int runComponentNode(int argc, char** argv, const char* default_name) {
  ros::init(argc, argv, default_name);
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  auto component = std::make_unique<ComponentClass>(nh, pnh);
  component->start();
  ros::spin();
  component->halt();
  return 0;
}

}  // namespace xpersif
