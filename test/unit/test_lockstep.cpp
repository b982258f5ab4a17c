// The lockstep clock's bookkeeping (core/lockstep.h): who owes a report, when a tick is complete, when time may
// go on, and what happens to a participant that does not answer.
#include <gtest/gtest.h>

#include "xpersif/core/lockstep.h"
#include "xpersif/core/validation.h"

using xpersif::core::LockstepCoordinator;
using Phase = LockstepCoordinator::Phase;
using Role = LockstepCoordinator::Role;

TEST(Lockstep, SensorsThenActorsThenTimeGoesOnOnlyIfWanted) {
  LockstepCoordinator c(5.0);
  c.join("camera", Role::Sensor);
  c.join("controller", Role::Actor);
  EXPECT_FALSE(c.phaseComplete());  // an actor joining between ticks is waited for before any tick
  EXPECT_EQ(c.report("controller", 0, Phase::Act, false, false), "");
  EXPECT_TRUE(c.phaseComplete());
  c.startTick(1, 0.0);
  EXPECT_EQ(c.phase(), Phase::Sense);
  EXPECT_EQ(c.owed(), std::vector<std::string>{"camera"});
  EXPECT_EQ(c.report("controller", 1, Phase::Act, true, false), "'controller' reported tick 1 (act) while tick 1 (sense) runs");
  EXPECT_EQ(c.report("camera", 1, Phase::Sense, false, true), "");
  EXPECT_TRUE(c.phaseComplete());
  EXPECT_EQ(c.startAct(0.0), std::vector<std::string>{"camera"});  // the camera published at this tick
  EXPECT_EQ(c.owed(), std::vector<std::string>{"controller"});
  EXPECT_FALSE(c.wantsTime());
  EXPECT_EQ(c.report("controller", 1, Phase::Act, true, false, {true, 0.1, -0.5}), "");
  EXPECT_TRUE(c.phaseComplete());
  EXPECT_TRUE(c.wantsTime());
  EXPECT_TRUE(c.command().drives);
  EXPECT_DOUBLE_EQ(c.command().angular, -0.5);
  // The next tick: nobody wants time any more, so it stays where it is.
  c.startTick(2, 0.0);
  c.report("camera", 2, Phase::Sense, false, false);
  EXPECT_TRUE(c.startAct(0.0).empty());
  c.report("controller", 2, Phase::Act, false, false, {true, 0, 0});
  EXPECT_TRUE(c.phaseComplete());
  EXPECT_FALSE(c.wantsTime());
  c.requestTicks(2);  // the step operation
  EXPECT_TRUE(c.wantsTime());
  c.consumeRequest();
  c.consumeRequest();
  EXPECT_FALSE(c.wantsTime());
}

TEST(Lockstep, ReportsThatDoNotFitChangeNothing) {
  LockstepCoordinator c(5.0);
  c.join("a", Role::Actor);
  c.startTick(3, 0.0);
  c.startAct(0.0);
  EXPECT_NE(c.report("stranger", 3, Phase::Act, true, false), "");
  EXPECT_NE(c.report("a", 2, Phase::Act, true, false), "");  // an old tick
  EXPECT_FALSE(c.phaseComplete());
  EXPECT_FALSE(c.wantsTime());
  EXPECT_EQ(c.report("a", 3, Phase::Act, false, false), "");
  EXPECT_EQ(c.report("a", 3, Phase::Act, true, false), "");  // twice: it may still ask for time
  EXPECT_TRUE(c.wantsTime());
  EXPECT_THROW(c.join("", Role::Actor), xpersif::core::ValidationError);
  EXPECT_THROW(LockstepCoordinator(0.0), xpersif::core::ValidationError);
}

TEST(Lockstep, AParticipantThatHangsIsDroppedAfterTheTimeoutAndTheRobotStops) {
  LockstepCoordinator c(2.0);
  c.join("camera", Role::Sensor);
  c.join("controller", Role::Actor);
  c.startTick(1, 10.0);
  c.report("camera", 1, Phase::Sense, false, false);
  c.startAct(10.0);
  c.report("controller", 1, Phase::Act, true, false, {true, 0.2, 0});
  c.startTick(2, 11.0);
  c.report("camera", 2, Phase::Sense, false, false);
  c.startAct(11.0);
  EXPECT_TRUE(c.dropLate(12.9).empty());  // within its 2 s
  EXPECT_EQ(c.dropLate(13.1), std::vector<std::string>{"controller"});
  EXPECT_TRUE(c.phaseComplete());  // the run goes on without it
  EXPECT_FALSE(c.has("controller"));
  EXPECT_TRUE(c.command().drives);  // a dropped controller commands nothing: the robot stops
  EXPECT_EQ(c.command().linear, 0.0);
}

TEST(Lockstep, AnActorJoiningBetweenTicksIsWaitedForBeforeAnyTick) {
  LockstepCoordinator c(5.0);
  c.join("camera", Role::Sensor);
  c.startTick(1, 0.0);
  c.report("camera", 1, Phase::Sense, false, true);
  c.startAct(0.0);
  EXPECT_TRUE(c.phaseComplete());  // idle: an idle tick could start now
  c.join("controller", Role::Actor, 1.0);
  EXPECT_FALSE(c.phaseComplete()) << "its first command must not miss the tick it joined at";
  EXPECT_EQ(c.report("controller", 1, Phase::Act, true, false, {true, 0.1, 0}), "");
  EXPECT_TRUE(c.phaseComplete());
  EXPECT_TRUE(c.wantsTime());
}

TEST(Lockstep, ALeavingDriverStopsTheRobotAndFreesThePhase) {
  LockstepCoordinator c(5.0);
  c.join("controller", Role::Actor);
  c.join("other", Role::Actor);
  c.startTick(1, 0.0);
  c.startAct(0.0);
  c.report("controller", 1, Phase::Act, true, false, {true, 0.1, 0});
  EXPECT_FALSE(c.phaseComplete());
  EXPECT_FALSE(c.leave("other"));  // never drove
  EXPECT_TRUE(c.phaseComplete());
  EXPECT_TRUE(c.leave("controller"));
}

TEST(Lockstep, AnActorJoiningALongPhaseGetsItsWholeTimeoutFromItsJoin) {
  LockstepCoordinator c(2.0);
  c.join("slow", Role::Actor);
  c.startTick(1, 10.0);
  c.startAct(10.0);                   // "slow" owes from 10.0
  c.join("late", Role::Actor, 11.5);  // "late" owes from its join, not from the phase's start
  EXPECT_EQ(c.report("slow", 1, Phase::Act, true, false), "");
  EXPECT_TRUE(c.dropLate(12.5).empty()) << "'late' has been owing for 1 s of its 2";
  EXPECT_TRUE(c.has("late"));
  EXPECT_EQ(c.dropLate(13.5), std::vector<std::string>{"late"});
  // Each participant its own deadline: one owing since the phase started goes, one that joined later stays.
  LockstepCoordinator d(2.0);
  d.join("a", Role::Actor);
  d.startTick(1, 20.0);
  d.startAct(20.0);
  d.join("b", Role::Actor, 21.0);
  EXPECT_EQ(d.dropLate(22.0), std::vector<std::string>{"a"});
  EXPECT_EQ(d.owed(), std::vector<std::string>{"b"});
  EXPECT_EQ(d.dropLate(23.0), std::vector<std::string>{"b"});
  EXPECT_TRUE(d.phaseComplete());
}
