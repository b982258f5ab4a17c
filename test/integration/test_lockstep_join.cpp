// A lockstep actor's join when the simulator's ACT tick overtakes the join's answer (issue 13, the cold-start
// difference). An actor that joins in a SENSE phase owes that tick's ACT phase, which the simulator may publish
// the moment the sensors are done: on a loaded machine the tick thread can hear it before the joining thread has
// read the answer. The client used to ignore every tick until then, waited for a tick that had passed, and was
// dropped 10 s later (at a campaign's start: LOOPMODEL's settling skipped, other physics).
//
// This test is the simulator: its join service publishes the ACT tick first and answers 0.3 s later, so the
// overtaking is certain. The client must act on that tick.
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <atomic>
#include <memory>
#include <string>

#include "test_helpers.h"
#include "xpersif/Lockstep.h"
#include "xpersif/LockstepDone.h"
#include "xpersif/LockstepTick.h"
#include "xpersif/component/lockstep_client.h"

using xpersif::Lockstep;
using xpersif::LockstepClient;
using xpersif::LockstepDone;
using xpersif::LockstepTick;
using xpersif_test::Recorder;
using xpersif_test::waitFor;

namespace {

const std::string kSim = "/overtaking_sim";
constexpr std::uint64_t kClock = 7, kTick = 41;

class OvertakingSimulator {
 public:
  explicit OvertakingSimulator(ros::NodeHandle& nh) {
    ros::param::set(kSim + "/clock_mode", "lockstep");
    tick_pub_ = nh.advertise<LockstepTick>(kSim + "/tick", 10);
    service_ = nh.advertiseService(kSim + "/lockstep", &OvertakingSimulator::onLockstep, this);
  }
  bool connected() const { return tick_pub_.getNumSubscribers() > 0; }

  LockstepTick tick(std::uint64_t number, std::uint8_t phase) const {
    LockstepTick t;
    t.clock = kClock;
    t.tick = number;
    t.phase = phase;
    t.stamp = ros::Time(number * 0.02);
    t.physics_time = number * 0.02;
    t.participants = {participant_};
    return t;
  }

 private:
  bool onLockstep(Lockstep::Request& request, Lockstep::Response& response) {
    participant_ = request.participant;
    const bool sensor = request.role == Lockstep::Request::SENSOR;
    // An actor: the sensors were quick, and the ACT tick it owes comes first. A sensor, joined in an ACT phase: the
    // next tick starts at once (in one process it does), and its SENSE tick, which the sensor owes, comes first.
    if (request.join) tick_pub_.publish(sensor ? tick(kTick + 1, LockstepTick::SENSE) : tick(kTick, LockstepTick::ACT));
    ros::WallDuration(0.3).sleep();  // the answer is slow
    response.success = true;
    response.clock = kClock;
    response.tick = kTick;
    response.phase = sensor ? LockstepTick::ACT : LockstepTick::SENSE;
    response.stamp = ros::Time(kTick * 0.02);
    return true;
  }

  ros::Publisher tick_pub_;
  ros::ServiceServer service_;
  std::string participant_;
};

/// The simulator, the reports it hears, and one client of its clock.
struct Overtaken {
  Overtaken(const std::string& name, bool sensor) : sim(nh), done(nh, kSim + "/lockstep_done") {
    ros::NodeHandle private_nh("~");
    private_nh.setParam("lockstep_xpersim", kSim);
    client = std::make_unique<LockstepClient>(nh, private_nh, name, sensor);
  }
  bool connected() const { return waitFor([&] { return sim.connected(); }, 10.0); }

  ros::NodeHandle nh;
  OvertakingSimulator sim;
  Recorder<LockstepDone> done;
  std::unique_ptr<LockstepClient> client;
};

}  // namespace

TEST(LockstepJoin, AnActTickHeardBeforeTheJoinsAnswerIsActedOn) {
  Overtaken test("/overtaken_actor", false);
  LockstepClient& client = *test.client;
  auto& done = test.done;
  ASSERT_TRUE(client.enabled());
  ASSERT_TRUE(test.connected()) << "the client subscribes to the ticks";

  const LockstepClient::Tick joined = client.join();
  EXPECT_EQ(joined.tick, kTick);
  EXPECT_EQ(joined.phase, LockstepTick::SENSE) << "an actor joined in SENSE owes this tick's ACT phase";
  const auto act = client.reportAndWait(joined, {}, {}, 3.0);
  ASSERT_TRUE(act.has_value()) << "the ACT tick published before the join's answer was lost";
  EXPECT_EQ(act->tick, kTick);
  EXPECT_EQ(act->phase, LockstepTick::ACT);

  // It reports that tick, and goes on with the next.
  client.report(*act, true, false);
  EXPECT_TRUE(done.waitForMatch([](const LockstepDone& d) { return d.tick == kTick && d.phase == LockstepTick::ACT; }, 5.0));
  client.leave();
}

TEST(LockstepJoin, ASenseTickHeardBeforeTheJoinsAnswerIsServed) {
  Overtaken test("/overtaken_sensor", true);
  LockstepClient& client = *test.client;
  auto& done = test.done;
  ASSERT_TRUE(test.connected()) << "the client subscribes to the ticks";
  std::atomic<std::uint64_t> served{0};
  client.onTick([&](LockstepClient& c, const LockstepClient::Tick& t) {
    served = t.tick;
    c.report(t, false, true, {}, 1e9);
  });
  client.join();
  EXPECT_EQ(served.load(), kTick + 1) << "the SENSE tick that began before the join's answer was not served";
  EXPECT_TRUE(done.waitForMatch(
      [](const LockstepDone& d) { return d.tick == kTick + 1 && d.phase == LockstepTick::SENSE && d.published; }, 5.0))
      << "the simulator would wait for that report, and drop the sensor 10 s later";
  client.leave();
}

TEST(LockstepJoin, AnActorsReportCarriesTheFramesItAsksFor) {
  Overtaken test("/asking_actor", false);
  LockstepClient& client = *test.client;
  auto& done = test.done;
  ASSERT_TRUE(test.connected());
  const auto act = client.reportAndWait(client.join(), {}, {}, 3.0);
  ASSERT_TRUE(act.has_value());
  client.report(*act, true, false, {true, 0.05, 0.0, {"/xpersif/observation"}});
  EXPECT_TRUE(done.waitForMatch(
      [](const LockstepDone& d) {
        return d.participant == "/asking_actor" && d.wants_frames == std::vector<std::string>{"/xpersif/observation"};
      },
      5.0));
  client.leave();
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_lockstep_join");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
