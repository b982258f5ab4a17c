// The clock a camera hears in /tf follows XPERSim's clock when it is set back, even when a lockstep tick of the new
// clock comes before its frames.
#include <gtest/gtest.h>

#include "xpersif/core/common/frame_clock.h"

using xpersif::core::FrameClock;

namespace {
constexpr std::uint64_t kSecond = 1000000000;
}

TEST(FrameClock, FollowsTheFramesAndGoesBackWithThem) {
  FrameClock clock;
  EXPECT_FALSE(clock.reached(1));
  EXPECT_FALSE(clock.observeFrame(2 * kSecond));
  EXPECT_FALSE(clock.observeFrame(2 * kSecond + 1));  // a repeated frame, moved on by 1 ns
  EXPECT_TRUE(clock.reached(2 * kSecond));
  EXPECT_EQ(clock.latest(), 2 * kSecond + 1);
  // xpersim/reset: the next frame is stamped at 0, and the newest stamp is that one, not the old clock's.
  EXPECT_TRUE(clock.observeFrame(0));
  EXPECT_EQ(clock.latest(), 0u);
  EXPECT_EQ(clock.setBacks(), 1u);
  EXPECT_FALSE(clock.reached(kSecond / 100));
  clock.observeFrame(kSecond / 100);
  EXPECT_TRUE(clock.reached(kSecond / 100));
}

TEST(FrameClock, ATickThatWentBackWaitsForTheFramesToGoBackToo) {
  FrameClock clock;
  for (std::uint64_t t = 1; t <= 50; ++t) {
    clock.observeFrame(t * kSecond / 10);
    clock.observeTick(t * kSecond / 10);
    EXPECT_TRUE(clock.reached(t * kSecond / 10));
  }
  // The first tick after a reset, heard before the reset's frames: the old clock's frames are ahead of it but are
  // not its frame.
  clock.observeTick(kSecond / 100);
  EXPECT_FALSE(clock.reached(kSecond / 100));
  clock.observeFrame(5 * kSecond + kSecond / 10);  // a frame of the old clock still on its way
  EXPECT_FALSE(clock.reached(kSecond / 100));
  clock.observeFrame(0);  // the reset's own frame
  EXPECT_FALSE(clock.reached(kSecond / 100));
  clock.observeFrame(kSecond / 100);  // the tick's frame
  EXPECT_TRUE(clock.reached(kSecond / 100));
}

TEST(FrameClock, ATickThatWentBackAfterTheFramesDidIsServedAtOnce) {
  FrameClock clock;
  clock.observeFrame(3 * kSecond);
  clock.observeTick(3 * kSecond);
  clock.observeFrame(0);
  clock.observeFrame(kSecond / 100);
  clock.observeTick(kSecond / 100);
  EXPECT_TRUE(clock.reached(kSecond / 100));
}

TEST(FrameClock, FramesMovedOnByNanosecondsAreNotASetBack) {
  // A pose set between two ticks publishes a frame 1 ns after the tick's stamp: the next tick is not "back".
  FrameClock clock;
  clock.observeTick(kSecond);
  clock.observeFrame(kSecond);
  clock.observeFrame(kSecond + 1);
  clock.observeTick(kSecond);
  EXPECT_TRUE(clock.reached(kSecond));
  EXPECT_EQ(clock.setBacks(), 0u);
}
