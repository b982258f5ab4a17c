// The lockstep protocol's floor: one actor that computes nothing, in its own process, against XPERSim in
// lockstep (bench/run_lockstep_floor.sh). Each tick is one SENSE and one ACT message out, one report back, and
// the physics of the world's ~tick_period. Prints wall milliseconds per tick over N ticks.
//   lockstep_floor [TICKS (2000)]     (XPERSim under the namespace given by ~xpersim, default "xpersim")
#include <ros/ros.h>

#include <cstdlib>
#include <iostream>

#include "xpersif/component/lockstep_client.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "lockstep_floor");
  const int ticks = argc > 1 ? std::atoi(argv[1]) : 2000;
  ros::NodeHandle nh, pnh("~");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  xpersif::LockstepClient client(nh, pnh, pnh.getNamespace(), false);
  if (!client.enabled()) {
    std::cerr << "lockstep_floor: XPERSim does not run in lockstep\n";
    return 1;
  }
  auto tick = client.join();
  for (int i = 0; i < 20; ++i) tick = *client.reportAndWait(tick, {}, {});  // warm up the connections
  const ros::WallTime start = ros::WallTime::now();
  const double physics_start = tick.physics_time;
  for (int i = 0; i < ticks; ++i) {
    auto next = client.reportAndWait(tick, {}, {});
    if (!next) {
      std::cerr << "lockstep_floor: left the clock after " << i << " ticks\n";
      return 1;
    }
    tick = *next;
  }
  const double wall = (ros::WallTime::now() - start).toSec();
  std::cout << "lockstep_floor: " << ticks << " ticks in " << wall << " s: " << 1000 * wall / ticks
            << " ms per tick, " << (tick.physics_time - physics_start) / wall << " x real time\n";
  client.leave();
  return 0;
}
