#include <gtest/gtest.h>

#include <stdexcept>
#include <thread>

#include "xpersif/core/common/lifecycle.h"

using xpersif::core::Lifecycle;
using xpersif::core::LifecycleState;
using xpersif::core::LifecycleTransition;

TEST(Lifecycle, StartsUnconfiguredAndWalksTheLegalPath) {
  Lifecycle lc;
  EXPECT_EQ(lc.state(), LifecycleState::Unconfigured);
  EXPECT_TRUE(lc.request(LifecycleTransition::Configure).success);
  EXPECT_EQ(lc.state(), LifecycleState::Inactive);
  EXPECT_TRUE(lc.request(LifecycleTransition::Activate).success);
  EXPECT_TRUE(lc.isActive());
  EXPECT_TRUE(lc.request(LifecycleTransition::Deactivate).success);
  EXPECT_EQ(lc.state(), LifecycleState::Inactive);
  EXPECT_TRUE(lc.request(LifecycleTransition::Configure).success) << "re-parametrizing an INACTIVE component is legal";
  EXPECT_TRUE(lc.request(LifecycleTransition::Shutdown).success);
  EXPECT_EQ(lc.state(), LifecycleState::Finalized);
}

TEST(Lifecycle, IllegalTransitionsAreRefusedWithAReasonAndChangeNothing) {
  int hook_calls = 0;
  Lifecycle lc({[&] { ++hook_calls; }, [&] { ++hook_calls; }, [&] { ++hook_calls; }, [&] { ++hook_calls; }});
  auto r = lc.request(LifecycleTransition::Activate);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.state, LifecycleState::Unconfigured);
  EXPECT_NE(r.message.find("configure it first"), std::string::npos) << r.message;
  r = lc.request(LifecycleTransition::Deactivate);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("only an ACTIVE component"), std::string::npos) << r.message;
  EXPECT_EQ(hook_calls, 0);

  ASSERT_TRUE(lc.request(LifecycleTransition::Configure).success);
  ASSERT_TRUE(lc.request(LifecycleTransition::Activate).success);
  r = lc.request(LifecycleTransition::Configure);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.state, LifecycleState::Active);
  EXPECT_NE(r.message.find("deactivate it first"), std::string::npos) << r.message;
  r = lc.request(LifecycleTransition::Activate);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("already ACTIVE"), std::string::npos);
  EXPECT_EQ(hook_calls, 2);
}

TEST(Lifecycle, FinalizedIsFinal) {
  Lifecycle lc;
  ASSERT_TRUE(lc.request(LifecycleTransition::Shutdown).success);
  for (auto t : {LifecycleTransition::Configure, LifecycleTransition::Activate, LifecycleTransition::Deactivate,
                 LifecycleTransition::Shutdown}) {
    auto r = lc.request(t);
    EXPECT_FALSE(r.success);
    EXPECT_EQ(r.state, LifecycleState::Finalized);
    EXPECT_NE(r.message.find("shut down"), std::string::npos) << r.message;
  }
}

TEST(Lifecycle, FailingHookLeadsToErrorAndConfigureRecovers) {
  bool fail = true;
  Lifecycle::Hooks hooks;
  hooks.on_configure = [&] {
    if (fail) throw std::runtime_error("~limit is NaN");
  };
  Lifecycle lc(hooks);
  auto r = lc.request(LifecycleTransition::Configure);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.state, LifecycleState::Error);
  EXPECT_EQ(lc.lastError(), "configure failed: ~limit is NaN");
  r = lc.request(LifecycleTransition::Activate);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("configure it again"), std::string::npos);
  fail = false;
  EXPECT_TRUE(lc.request(LifecycleTransition::Configure).success);
  EXPECT_EQ(lc.state(), LifecycleState::Inactive);
  EXPECT_EQ(lc.lastError(), "");
}

TEST(Lifecycle, ShutdownFromActiveDeactivatesFirst) {
  std::string order;
  Lifecycle lc({[&] { order += "c"; }, [&] { order += "a"; }, [&] { order += "d"; }, [&] { order += "s"; }});
  lc.request(LifecycleTransition::Configure);
  lc.request(LifecycleTransition::Activate);
  lc.request(LifecycleTransition::Shutdown);
  EXPECT_EQ(order, "cads");
}

TEST(Lifecycle, FailWhileActiveIsReported) {
  Lifecycle lc;
  lc.request(LifecycleTransition::Configure);
  lc.request(LifecycleTransition::Activate);
  lc.fail("camera disconnected");
  EXPECT_EQ(lc.state(), LifecycleState::Error);
  EXPECT_EQ(lc.lastError(), "camera disconnected");
}

TEST(Lifecycle, StateCanBeReadWhileAHookRuns) {
  Lifecycle* self = nullptr;
  LifecycleState seen = LifecycleState::Error;
  Lifecycle lc({nullptr, nullptr, [&] { seen = self->state(); }, nullptr});
  self = &lc;
  lc.request(LifecycleTransition::Configure);
  lc.request(LifecycleTransition::Activate);
  lc.request(LifecycleTransition::Deactivate);  // would deadlock if state() waited for the transition
  EXPECT_EQ(seen, LifecycleState::Active);
}

TEST(Lifecycle, AFailureWhileTheActivateHookRunsIsNotOverwrittenByActive) {
  // A supervisor's activate hook starts the bring-up in a thread of its own; when that thread fails before the
  // hook has returned, the component must end in ERROR, not ACTIVE (seen once in CI: test_supervision waited
  // 60 s for a broken supervisor's ERROR that an ACTIVE had replaced).
  Lifecycle* self = nullptr;
  Lifecycle lc({nullptr, [&] {
                  std::thread bring_up([&] { self->fail("could not start /ghost"); });
                  bring_up.join();
                },
                nullptr, nullptr});
  self = &lc;
  ASSERT_TRUE(lc.request(LifecycleTransition::Configure).success);
  const auto r = lc.request(LifecycleTransition::Activate);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.state, LifecycleState::Error);
  EXPECT_EQ(lc.state(), LifecycleState::Error);
  EXPECT_EQ(lc.lastError(), "could not start /ghost");
  EXPECT_EQ(r.message, "activate failed: could not start /ghost");
  // Configure recovers as from any ERROR, and a later failure-free activation succeeds.
  Lifecycle plain;
  ASSERT_TRUE(plain.request(LifecycleTransition::Configure).success);
  EXPECT_TRUE(plain.request(LifecycleTransition::Activate).success);
}
