// Cameras rendered on the client side: images where the cubes are, camera info, zero copy inside a
// manager, and telesim_view rendering headless from tf.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/UInt64MultiArray.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <map>

#include "test_helpers.h"
#include "xpersif/BodyPoses.h"

using xpersif_test::Recorder;
using xpersif_test::waitFor;

namespace {

std::string besideThisTest(const std::string& program) {
  char self[4096] = {0};
  const ssize_t length = readlink("/proc/self/exe", self, sizeof self - 1);
  std::string directory(self, length > 0 ? static_cast<std::size_t>(length) : 0);
  return directory.substr(0, directory.rfind('/') + 1) + program;
}

}  // namespace

TEST(Cameras, OverheadImageShowsTheCubesWhereTheyAre) {
  ros::NodeHandle nh;
  Recorder<sensor_msgs::Image> images(nh, "/overhead_camera/image_raw");
  Recorder<sensor_msgs::CameraInfo> infos(nh, "/overhead_camera/camera_info");
  Recorder<xpersif::BodyPoses> truth(nh, "/xpersim/ground_truth");
  sensor_msgs::Image image;
  ASSERT_TRUE(images.waitForMatch([](const sensor_msgs::Image&) { return true; }, 60.0, &image));
  EXPECT_EQ(image.width, 600u);
  EXPECT_EQ(image.height, 416u);
  EXPECT_EQ(image.encoding, "bgr8");
  EXPECT_EQ(image.header.frame_id, "overhead_optical");
  sensor_msgs::CameraInfo info;
  ASSERT_TRUE(infos.waitForMatch([](const sensor_msgs::CameraInfo&) { return true; }, 10.0, &info));
  EXPECT_DOUBLE_EQ(info.K[0], 650.0);
  xpersif::BodyPoses poses;
  ASSERT_TRUE(truth.waitForMatch([](const xpersif::BodyPoses&) { return true; }, 10.0, &poses));

  // The camera looks straight down from z = 1.2 with image x along world x and image y along -y.
  struct Expected {
    std::string name;
    int b, g, r;  // which channel dominates
  };
  for (const Expected& e : {Expected{"red_cube", 0, 0, 1}, Expected{"green_cube", 0, 1, 0}, Expected{"blue_cube", 1, 0, 0}}) {
    const auto it = std::find(poses.names.begin(), poses.names.end(), e.name);
    ASSERT_NE(it, poses.names.end());
    const auto& p = poses.poses[it - poses.names.begin()].position;
    const double depth = 1.2 - 0.04;  // to the cube's top face
    const int u = static_cast<int>(650.0 * p.x / depth + 300.0);
    const int v = static_cast<int>(650.0 * -p.y / depth + 208.0);
    ASSERT_TRUE(u >= 0 && u < 600 && v >= 0 && v < 416) << e.name;
    const std::uint8_t* pixel = &image.data[static_cast<std::size_t>(v) * image.step + 3 * static_cast<std::size_t>(u)];
    const int channel = e.b ? 0 : e.g ? 1 : 2;
    for (int c = 0; c < 3; ++c) {
      if (c != channel) {
        EXPECT_GT(pixel[channel], pixel[c] + 40) << e.name << " at (" << u << ", " << v << "): " << int(pixel[0]) << ","
                                                 << int(pixel[1]) << "," << int(pixel[2]);
      }
    }
  }
}

TEST(Cameras, RobotCameraPublishesToo) {
  ros::NodeHandle nh;
  Recorder<sensor_msgs::Image> images(nh, "/robot_camera/image_raw");
  sensor_msgs::Image image;
  ASSERT_TRUE(images.waitForMatch([](const sensor_msgs::Image&) { return true; }, 60.0, &image));
  EXPECT_EQ(image.width, 160u);
  EXPECT_EQ(image.height, 120u);
}

TEST(Cameras, NodeletsInTheSameManagerGetTheImageWithoutACopy) {
  ros::NodeHandle nh;
  Recorder<std_msgs::UInt64MultiArray> sent(nh, "/overhead_camera/buffer_address");
  Recorder<std_msgs::UInt64MultiArray> received(nh, "/image_probe/received_address");
  ASSERT_TRUE(waitFor([&] { return received.messages().size() >= 5 && sent.messages().size() >= 5; }, 60.0));
  // Paired by image sequence number: the probe's buffer is the very buffer the camera rendered into
  // (a copy would live at another address while the original is still held).
  std::map<std::uint64_t, std::uint64_t> camera_buffer;
  for (const auto& s : sent.messages()) camera_buffer[s.data.at(0)] = s.data.at(1);
  int paired = 0;
  for (const auto& r : received.messages()) {
    const auto it = camera_buffer.find(r.data.at(0));
    if (it == camera_buffer.end()) continue;
    EXPECT_EQ(it->second, r.data.at(1)) << "image " << r.data.at(0) << " was copied";
    ++paired;
  }
  EXPECT_GE(paired, 3);
}

TEST(Cameras, TelesimViewRendersFromTfHeadless) {
  const std::string dir = "/tmp/telesim_view_test_" + std::to_string(getpid());
  ASSERT_EQ(system(("mkdir -p " + dir).c_str()), 0);
  const std::string command = besideThisTest("telesim_view") + " _xpersim:=/xpersim _camera:=overhead _duration:=3 _output_dir:=" + dir +
                              " _max_fps:=20 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  char buffer[512];
  while (fgets(buffer, sizeof buffer, pipe)) output += buffer;
  const int status = pclose(pipe);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << output;
  EXPECT_NE(output.find("telesim_view: camera overhead"), std::string::npos) << output;
  EXPECT_EQ(output.find(" 0 tf frames"), std::string::npos) << output;
  std::ifstream png(dir + "/overhead_last.png");
  EXPECT_TRUE(png.good()) << "the last rendered image was written";
  std::ifstream csv(dir + "/telesim_view_inter_frame_ms.csv");
  EXPECT_TRUE(csv.good());
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_cameras");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
