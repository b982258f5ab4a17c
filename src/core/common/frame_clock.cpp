#include "xpersif/core/common/frame_clock.h"

namespace xpersif::core {

bool FrameClock::observeFrame(std::uint64_t stamp_ns) {
  const bool set_back = stamp_ns < latest_;
  latest_ = stamp_ns;
  if (set_back) {
    ++set_backs_;
    awaiting_set_back_ = false;
  }
  return set_back;
}

void FrameClock::observeTick(std::uint64_t stamp_ns) {
  const bool tick_went_back = stamp_ns + kSetBackThresholdNs < last_tick_;
  last_tick_ = stamp_ns;
  // The frames already went back too (they came first) unless the newest one is still ahead of this tick.
  if (tick_went_back && latest_ > stamp_ns + kSetBackThresholdNs) awaiting_set_back_ = true;
}

}  // namespace xpersif::core
