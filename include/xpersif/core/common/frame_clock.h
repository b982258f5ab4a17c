/**
 * @file frame_clock.h
 * @brief The simulator's clock as a client hears it in XPERSim's /tf frames: the stamp of the newest frame,
 *        which goes back when the clock is set back (xpersim/reset, a world configured again, a restarted
 *        simulator).
 *
 * ROS-free. XPERSim stamps the frames of one clock strictly increasing (a repeated stamp is moved on by 1 ns), so a
 * frame stamped earlier than the one before it means the clock was set back. The newest stamp follows it down, as
 * tf2_ros clears its buffer on a jump back in time; kept as a maximum, it would stay ahead of every frame of the
 * new clock until that caught up: images stamped in the future, and a lockstep tick's frame taken as seen before
 * it came.
 *
 * A lockstep tick can be heard before the frames of the clock set back (ticks and /tf are two connections). A tick
 * stamped earlier than the tick before it says the clock was set back; frames stamped more than
 * kSetBackThresholdNs after it are then from the clock before, and no frame counts until one of the new clock comes.
 */
#pragma once

#include <cstdint>

namespace xpersif::core {

class FrameClock {
 public:
  /// XPERSim's own rule (publishFrameLocked): a stamp that goes back by more than this is a clock set back on purpose.
  static constexpr std::uint64_t kSetBackThresholdNs = 1000000;

  /// A frame stamped @p stamp_ns was applied. True when it set the clock back.
  bool observeFrame(std::uint64_t stamp_ns);
  /// A lockstep tick stamped @p stamp_ns was heard (before its frame is waited for).
  void observeTick(std::uint64_t stamp_ns);
  /// A frame of the current clock stamped at least @p stamp_ns has been observed.
  bool reached(std::uint64_t stamp_ns) const { return !awaiting_set_back_ && latest_ >= stamp_ns; }
  /// The newest frame's stamp (0 before the first); after a set back, the new clock's.
  std::uint64_t latest() const { return latest_; }
  /// How many times the frames have set the clock back.
  std::uint64_t setBacks() const { return set_backs_; }

 private:
  std::uint64_t latest_ = 0;
  std::uint64_t last_tick_ = 0;
  std::uint64_t set_backs_ = 0;
  bool awaiting_set_back_ = false;  // a tick went back, the frames have not yet
};

}  // namespace xpersif::core
