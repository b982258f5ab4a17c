#include <gtest/gtest.h>

#include "xpersif/core/common/heartbeat_monitor.h"

using xpersif::core::HeartbeatMonitor;

TEST(HeartbeatMonitor, ReportsASilentComponentOnceAndItsReturn) {
  HeartbeatMonitor m(1.0);
  m.expect("a", 0.0);
  m.beat("a", 0.5);
  EXPECT_TRUE(m.poll(1.4).empty());
  auto changes = m.poll(1.6);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].name, "a");
  EXPECT_TRUE(changes[0].lost);
  EXPECT_NEAR(changes[0].silent_for, 1.1, 1e-9);
  EXPECT_TRUE(m.isLost("a"));
  EXPECT_TRUE(m.poll(5.0).empty()) << "a lost component is reported once";
  m.beat("a", 5.1);
  changes = m.poll(5.2);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_FALSE(changes[0].lost);
  EXPECT_FALSE(m.isLost("a"));
}

TEST(HeartbeatMonitor, GraceDelaysTheFirstVerdict) {
  HeartbeatMonitor m(1.0);
  m.expect("slow", 0.0, 5.0);
  EXPECT_TRUE(m.poll(5.9).empty());
  EXPECT_EQ(m.poll(6.1).size(), 1u);
}

TEST(HeartbeatMonitor, IgnoresUnwatchedAndForgotten) {
  HeartbeatMonitor m(1.0);
  m.beat("stranger", 0.0);
  EXPECT_FALSE(m.isWatched("stranger"));
  m.expect("b", 0.0);
  m.forget("b");
  EXPECT_TRUE(m.poll(10).empty());
  EXPECT_THROW(HeartbeatMonitor(0.0), std::invalid_argument);
}
