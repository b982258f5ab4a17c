// Test-only nodelet: reports the address of every image buffer it receives, so a test can check that a
// camera in the same manager hands over its image without copying it.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/UInt64MultiArray.h>

namespace xpersif_test {

class ImageProbeNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    address_pub_ = getPrivateNodeHandle().advertise<std_msgs::UInt64MultiArray>("received_address", 10);
    image_sub_ = getNodeHandle().subscribe<sensor_msgs::Image>("image", 2, [this](const sensor_msgs::Image::ConstPtr& image) {
      std_msgs::UInt64MultiArray address;  // [image seq, buffer address]
      address.data = {image->header.seq, reinterpret_cast<std::uintptr_t>(image->data.data())};
      address_pub_.publish(address);
    });
  }
  ros::Publisher address_pub_;
  ros::Subscriber image_sub_;
};

}  // namespace xpersif_test

PLUGINLIB_EXPORT_CLASS(xpersif_test::ImageProbeNodelet, nodelet::Nodelet)
