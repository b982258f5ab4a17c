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
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <memory>

namespace xpersif {

/// @p kOwnThread: the component's callbacks (its operations, commands' goals, subscriptions) run on a queue and thread
/// of its own instead of the manager's worker pool. For a component others in its manager call from inside their
/// callbacks (XPERSim's get_scene from RELOCATION's configure): nodelet keeps a single-threaded queue on the worker
/// that already holds one of its callbacks, so a call from that worker's blocked callback would wait for itself.
template <class ComponentClass, bool kOwnThread = false>
class ComponentNodelet : public nodelet::Nodelet {
 public:
  ~ComponentNodelet() override {
    // Stop command threads and run the shutdown hooks while the derived component is still whole (and its own
    // thread still answers), then stop that thread before the component and its handles go.
    if (component_) component_->halt();
    if (spinner_) spinner_->stop();
    component_.reset();
  }

 protected:
  void onInit() override {
    ros::NodeHandle nh = getNodeHandle();
    ros::NodeHandle private_nh = getPrivateNodeHandle();
    if (kOwnThread) {
      queue_ = std::make_unique<ros::CallbackQueue>();
      nh.setCallbackQueue(queue_.get());
      private_nh.setCallbackQueue(queue_.get());
      spinner_ = std::make_unique<ros::AsyncSpinner>(1, queue_.get());
    }
    component_ = std::make_unique<ComponentClass>(nh, private_nh);
    if (spinner_) spinner_->start();
    component_->start();
  }

  ComponentClass& component() { return *component_; }

 private:
  std::unique_ptr<ros::CallbackQueue> queue_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
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
