// Baseline for the tf fan-out benchmark: a bare roscpp publisher of one tf2_msgs/TFMessage with ~n
// transforms at ~rate Hz, paced by the wall clock (sleep_until on a fixed schedule), stamped with wall
// time. transforms[0].header.seq carries a frame counter so clients can count lost frames.
//
//   tf_raw_publisher _n:=15 _rate:=1000 [_topic:=/tf] [_queue:=100]
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>

#include <chrono>
#include <cmath>
#include <thread>

int main(int argc, char** argv) {
  ros::init(argc, argv, "tf_raw_publisher");
  ros::NodeHandle nh, pnh("~");
  int n = 15, queue = 100;
  double rate = 1000.0;
  std::string topic = "/tf";
  pnh.param("n", n, n);
  pnh.param("rate", rate, rate);
  pnh.param("queue", queue, queue);
  pnh.param("topic", topic, topic);
  if (n < 1 || n > 100000 || !(rate > 0 && rate <= 100000)) {
    ROS_FATAL("~n must lie in 1..100000 and ~rate in (0, 100000]");
    return 1;
  }
  ros::Publisher pub = nh.advertise<tf2_msgs::TFMessage>(topic, queue);

  tf2_msgs::TFMessage msg;
  msg.transforms.resize(n);
  for (int i = 0; i < n; ++i) {
    auto& t = msg.transforms[i];
    t.header.frame_id = i < 3 ? "world" : "base_link";
    t.child_frame_id = "node_" + std::to_string(i);
    t.transform.rotation.w = 1.0;
  }

  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
  auto due = Clock::now();
  std::uint32_t seq = 0;
  std::uint64_t late = 0;
  while (ros::ok()) {
    due += period;
    std::this_thread::sleep_until(due);
    const ros::WallTime now = ros::WallTime::now();
    const ros::Time stamp(now.sec, now.nsec);
    for (int i = 0; i < n; ++i) {
      auto& t = msg.transforms[i];
      t.header.stamp = stamp;
      t.transform.translation.x = 0.001 * i + 1e-6 * (seq % 1000);  // something that changes
    }
    msg.transforms[0].header.seq = seq++;
    pub.publish(msg);
    // If we fell more than 10 periods behind (machine overloaded), restart the schedule instead of
    // bursting to catch up; the client sees the gap as a long inter-frame time, not as a loss.
    if (Clock::now() - due > 10 * period) {
      due = Clock::now();
      ++late;
    }
  }
  if (late) ROS_WARN("tf_raw_publisher: fell behind schedule %lu times", static_cast<unsigned long>(late));
  return 0;
}
