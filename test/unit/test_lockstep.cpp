// The lockstep clock's bookkeeping (core/lockstep.h): who owes a report, when a tick is complete, when time may
// go on, and what happens to a participant that does not answer.
#include <gtest/gtest.h>

#include <limits>

#include "xpersif/core/common/lockstep.h"
#include "xpersif/core/common/validation.h"

using xpersif::core::LockstepTiming;
using xpersif::core::LockstepCoordinator;
using Phase = LockstepCoordinator::Phase;
using Role = LockstepCoordinator::Role;

TEST(Lockstep, SensorsThenActorsThenTimeGoesOnOnlyIfWanted) {
  LockstepCoordinator c(5.0);
  c.join("camera", Role::Sensor);
  c.join("controller", Role::Actor);
  EXPECT_TRUE(c.phaseComplete());  // it first acts after a SENSE phase
  EXPECT_TRUE(c.awaitsTick());
  c.startTick(1, 0.0);
  EXPECT_FALSE(c.awaitsTick());
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

TEST(Lockstep, AnActorJoiningBetweenTicksFirstActsAfterAFreshSensePhase) {
  LockstepCoordinator c(5.0);
  c.join("camera", Role::Sensor);
  c.startTick(1, 0.0, 0.0, false);
  c.report("camera", 1, Phase::Sense, false, true, {}, 0.1);  // its next frame is due at 0.1 s of physics
  c.startAct(0.0);
  EXPECT_TRUE(c.phaseComplete());  // nobody wants time: an idle tick could start after an idle pause
  EXPECT_FALSE(c.awaitsTick());
  c.join("controller", Role::Actor);
  EXPECT_TRUE(c.phaseComplete()) << "it must not act on the camera's last frame";
  EXPECT_EQ(c.report("controller", 1, Phase::Act, false, false), "");  // allowed, but not owed
  EXPECT_TRUE(c.awaitsTick()) << "the next tick starts without the idle pause";
  EXPECT_FALSE(c.wantsTime());
  c.startTick(2, 0.0, 0.02, true);  // idle: every sensor renders the standing world, due or not
  EXPECT_EQ(c.owed(), std::vector<std::string>{"camera"});
  c.report("camera", 2, Phase::Sense, false, true, {}, 0.1);
  EXPECT_EQ(c.startAct(0.0), std::vector<std::string>{"camera"});
  EXPECT_EQ(c.owed(), std::vector<std::string>{"controller"});
  EXPECT_EQ(c.report("controller", 2, Phase::Act, true, false, {true, 0.1, 0}), "");
  EXPECT_TRUE(c.phaseComplete());
  EXPECT_TRUE(c.wantsTime());
}

TEST(Lockstep, AnActorJoiningInSenseActsInThatTicksActPhase) {
  LockstepCoordinator c(5.0);
  c.join("camera", Role::Sensor);
  c.startTick(1, 0.0);
  c.join("controller", Role::Actor);
  EXPECT_FALSE(c.awaitsTick());
  EXPECT_EQ(c.owed(), std::vector<std::string>{"camera"});
  c.report("camera", 1, Phase::Sense, false, true);
  c.startAct(0.0);
  EXPECT_EQ(c.owed(), std::vector<std::string>{"controller"});
}

TEST(Lockstep, ACameraOnRequestRendersOnlyWhenAnActorAsksOrTheWorldStands) {
  const double never = std::numeric_limits<double>::infinity();  // a sensor that renders on request only
  LockstepCoordinator c(5.0);
  c.join("overhead", Role::Sensor);
  c.join("robot_camera", Role::Sensor);
  c.join("controller", Role::Actor);
  c.startTick(1, 0.0, 0.0, true);  // idle: both render the standing world
  EXPECT_EQ(c.owed().size(), 2u);
  c.report("overhead", 1, Phase::Sense, false, true, {}, never);
  c.report("robot_camera", 1, Phase::Sense, false, true, {}, never);
  c.startAct(0.0);
  c.report("controller", 1, Phase::Act, true, false, {true, 0.1, 0.0, {}});
  // The world moves and nobody asked: no camera is waited for.
  c.startTick(2, 0.0, 0.02, false);
  EXPECT_TRUE(c.phaseComplete());
  EXPECT_TRUE(c.requested().empty());
  c.startAct(0.0);
  // The controller asks the overhead camera for a fix at the next tick (an unknown name asks nobody).
  c.report("controller", 2, Phase::Act, true, false, {true, 0.1, 0.0, {"overhead", "gone"}});
  c.startTick(3, 0.0, 0.04, false);
  EXPECT_EQ(c.owed(), std::vector<std::string>{"overhead"});
  EXPECT_EQ(c.requested(), std::vector<std::string>{"overhead"});
  c.report("overhead", 3, Phase::Sense, false, true, {}, never);
  EXPECT_EQ(c.startAct(0.0), std::vector<std::string>{"overhead"});
  // Asked once, rendered once.
  c.report("controller", 3, Phase::Act, true, false, {true, 0.1, 0.0, {}});
  c.startTick(4, 0.0, 0.06, false);
  EXPECT_TRUE(c.phaseComplete());
  EXPECT_TRUE(c.requested().empty());
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

TEST(Lockstep, EachOwedReportHasItsOwnDeadline) {
  LockstepCoordinator c(2.0);
  c.join("slow", Role::Actor);
  c.startTick(1, 10.0);
  c.startAct(10.0);                 // "slow" owes from 10.0
  c.join("late", Role::Actor);      // owes nothing before tick 2's ACT phase
  EXPECT_EQ(c.owed(), std::vector<std::string>{"slow"});
  EXPECT_EQ(c.report("slow", 1, Phase::Act, true, false), "");
  c.startTick(2, 11.0);
  c.startAct(11.5);
  EXPECT_EQ(c.report("slow", 2, Phase::Act, true, false), "");
  EXPECT_TRUE(c.dropLate(13.0).empty()) << "'late' has been owing for 1.5 s of its 2";
  EXPECT_TRUE(c.has("late"));
  EXPECT_EQ(c.dropLate(13.5), std::vector<std::string>{"late"});
  EXPECT_TRUE(c.phaseComplete());
}

// A component restarted after its manager died joins again under its old name while the dead one still owes a
// report: the new one owes nothing for the current phase, so the phase completes and nobody is dropped.
TEST(Lockstep, AParticipantThatJoinsAgainUnderItsNameOwesNothingForThePhase) {
  LockstepCoordinator c(5.0);
  c.join("camera", Role::Sensor);
  c.join("other_camera", Role::Sensor);
  c.startTick(1, 0.0, 0.02, false);
  EXPECT_EQ(c.report("other_camera", 1, Phase::Sense, false, true), "");
  EXPECT_FALSE(c.phaseComplete()) << "the camera owes its report";
  c.join("camera", Role::Sensor);  // the restarted camera
  EXPECT_TRUE(c.phaseComplete());
  EXPECT_TRUE(c.dropLate(100.0).empty()) << "nobody is dropped for what the dead one owed";
  c.startAct(0.0);
  c.startTick(2, 0.0, 0.04, false);
  EXPECT_EQ(c.owed(), (std::vector<std::string>{"camera", "other_camera"})) << "from the next tick it takes part again";
}

TEST(Lockstep, TimingSaysWhereATicksWallTimeGoes) {
  LockstepTiming timing;
  EXPECT_EQ(timing.describe(), "");
  // Four stepped ticks; a camera frame was due in one SENSE phase (4 ms), the others passed at once.
  timing.addSensing(0.004, true);
  for (int i = 0; i < 3; ++i) timing.addSensing(0.0, false);
  for (int i = 0; i < 4; ++i) timing.addStep(0.0008, 0.0005, 0.0001);
  EXPECT_EQ(timing.ticks, 4u);
  EXPECT_EQ(timing.sensing_waits, 1u);
  EXPECT_EQ(timing.describe(),
            "wall ms per stepped tick over 4 ticks: sensing 1.00 (a sensor waited for on 25 % of ticks, 4.00 ms each), "
            "acting 0.80, physics 0.50, publishing 0.10; 2.40 in all");
}
