#include "xpersif/perception/camera_clock.h"

#include <cmath>

namespace xpersif {

void CameraClock::start(const ros::NodeHandle& nh, ros::NodeHandle& private_nh, double rate, const CameraPart& camera,
                        std::function<bool(const ros::Time&)> render) {
  stop();
  lockstep_ = std::make_unique<LockstepClient>(nh, private_nh, private_nh.getNamespace(), true);
  if (!lockstep_->enabled()) {
    timer_ = private_nh.createTimer(ros::Duration(1.0 / rate), [render](const ros::TimerEvent&) { render(ros::Time()); });
    return;
  }
  next_due_ = 0;
  lockstep_->onTick([this, rate, &camera, render](const LockstepClient::Tick& t) {
    // The clock waits for a camera only at its frames (the same rule, core::LockstepCoordinator::startTick).
    if (!t.idle && t.physics_time + 1e-9 < next_due_) return;
    bool published = false;
    auto rendered = camera.camera();
    // Render from the tick's own /tf frame, waiting for it well within the clock's patience.
    if (rendered && rendered->tracker().waitForStamp(t.stamp, 2.0)) published = render(t.stamp);
    if (!t.idle) next_due_ = (std::floor(t.physics_time * rate + 1e-6) + 1) / rate;
    lockstep_->report(t, false, published, {}, next_due_);
  });
  lockstep_->join();
}

void CameraClock::stop() {
  timer_.stop();
  lockstep_.reset();  // leaves the clock
}

}  // namespace xpersif
