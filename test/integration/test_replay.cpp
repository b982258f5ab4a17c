/**
 * @file test_replay.cpp
 * @brief Replay (issue 6, item 4): the comparison half of test/traces_replay.sh. The script records a short
 *        live run of the whole loop (images on), then plays its bags with `rosbag play --clock` into a fresh
 *        master where only a FEATUREEXTRACTION (overhead camera, fed the recorded images and scene) and a
 *        MACHINELEARNING (~restore false, fed the recorded experiment records) run, and records what they
 *        publish. This program reads both and checks that replay reproduces the live run:
 *
 *  - features: every replayed feature vector whose image (by stamp) also has a live
 *    /xpersif/observation/features vector describes the same objects (names, order, poses, blob measures,
 *    contours) to 1e-9, the same missing objects and the same robot; at least `XPERSIF_REPLAY_MIN_FEATURES`
 *    pairs (default 20);
 *  - learning: every live model (run, samples > 0) has a replayed model with the same run and sample count,
 *    byte-identical (PushLearner::save), and both, loaded with PushLearner::load, predict every recorded
 *    experiment identically; and each record's live prediction (made before its push by the live model)
 *    equals the replayed model's with the samples the records before it gave.
 *
 * Comparison is by content (image stamp, run/samples), never by timing: pairs missing on either side (an image
 * dropped by a queue) are not compared, only counted. Inputs from the environment:
 * `XPERSIF_REPLAY_LIVE` (the live run directory), `XPERSIF_REPLAY_BAG` (the replay's recording),
 * `XPERSIF_REPLAY_FEATURES` and `XPERSIF_REPLAY_MODEL` (the replayed topics).
 */
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "xpersif/ExperimentRecord.h"
#include "xpersif/FeatureVector.h"
#include "xpersif/LearnedModel.h"
#include "xpersif/core/evaluation/experiment_samples.h"
#include "xpersif/traces/bag_tools.h"
#include "xpersif/ros/experiment_conversions.h"

namespace {

std::string env(const char* name, const std::string& fallback = "") {
  const char* v = std::getenv(name);
  return v && *v ? v : fallback;
}

template <class M>
std::vector<typename M::ConstPtr> readTopic(const std::vector<std::string>& files, const std::string& topic) {
  std::vector<typename M::ConstPtr> out;
  for (const auto& file : files) {
    rosbag::Bag bag(file, rosbag::bagmode::Read);
    for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(topic))) {
      if (auto msg = m.instantiate<M>()) out.push_back(msg);
    }
  }
  return out;
}

struct Bags {
  std::vector<std::string> live, replay;
  std::string features_topic, model_topic;
};

Bags bags() {
  Bags b;
  b.live = xpersif::traces::bagFiles({env("XPERSIF_REPLAY_LIVE")});
  b.replay = {env("XPERSIF_REPLAY_BAG")};
  b.features_topic = env("XPERSIF_REPLAY_FEATURES", "/xpersif/replay_extraction/features");
  b.model_topic = env("XPERSIF_REPLAY_MODEL", "/xpersif/replay_learning/model");
  return b;
}

constexpr double kTolerance = 1e-9;

void expectNear(const geometry_msgs::Point& a, const geometry_msgs::Point& b, const std::string& what) {
  EXPECT_NEAR(a.x, b.x, kTolerance) << what;
  EXPECT_NEAR(a.y, b.y, kTolerance) << what;
  EXPECT_NEAR(a.z, b.z, kTolerance) << what;
}

void expectSameObject(const xpersif::ObjectFeatures& live, const xpersif::ObjectFeatures& replay,
                      const std::string& where) {
  const std::string what = where + " " + live.name;
  EXPECT_EQ(live.name, replay.name) << what;
  expectNear(live.position, replay.position, what + " position");
  EXPECT_NEAR(live.yaw, replay.yaw, kTolerance) << what;
  EXPECT_EQ(live.yaw_period, replay.yaw_period) << what;
  EXPECT_EQ(live.orientation_known, replay.orientation_known) << what;
  EXPECT_NEAR(live.confidence, replay.confidence, kTolerance) << what;
  EXPECT_EQ(live.pixel_area, replay.pixel_area) << what;
  expectNear(live.centroid_px, replay.centroid_px, what + " centroid");
  EXPECT_NEAR(live.measured_length, replay.measured_length, kTolerance) << what;
  EXPECT_NEAR(live.measured_width, replay.measured_width, kTolerance) << what;
  ASSERT_EQ(live.top_corners.size(), replay.top_corners.size()) << what;
  for (std::size_t i = 0; i < live.top_corners.size(); ++i) {
    expectNear(live.top_corners[i], replay.top_corners[i], what + " corner " + std::to_string(i));
  }
  EXPECT_EQ(live.contour, replay.contour) << what;
  EXPECT_EQ(live.top_contour, replay.top_contour) << what;
  EXPECT_EQ(live.feature_names, replay.feature_names) << what;
  ASSERT_EQ(live.feature_values.size(), replay.feature_values.size()) << what;
  for (std::size_t i = 0; i < live.feature_values.size(); ++i) {
    EXPECT_NEAR(live.feature_values[i], replay.feature_values[i], kTolerance) << what;
  }
}

TEST(Replay, featureVectorsEqualTheLiveOnes) {
  const Bags b = bags();
  const auto live = readTopic<xpersif::FeatureVector>(b.live, "/xpersif/observation/features");
  const auto replay = readTopic<xpersif::FeatureVector>(b.replay, b.features_topic);
  ASSERT_FALSE(live.empty()) << "no live /xpersif/observation/features in the recording";
  ASSERT_FALSE(replay.empty()) << "the replayed FEATUREEXTRACTION published nothing on " << b.features_topic;

  // By the image's stamp: roscpp renumbers header.seq per publisher, so the replayed vectors' seqs count the
  // images the replay processed. Two images rendered at the same simulated time share a stamp: skipped.
  std::map<std::uint64_t, std::vector<xpersif::FeatureVector::ConstPtr>> by_stamp;
  for (const auto& f : live) by_stamp[f->header.stamp.toNSec()].push_back(f);
  std::size_t pairs = 0, with_objects = 0, unmatched = 0, ambiguous = 0;
  for (const auto& r : replay) {
    const auto it = by_stamp.find(r->header.stamp.toNSec());
    if (it == by_stamp.end()) {
      ++unmatched;
      continue;
    }
    if (it->second.size() != 1) {
      ++ambiguous;
      continue;
    }
    const xpersif::FeatureVector& l = *it->second.front();
    const std::string where = "image stamp " + std::to_string(r->header.stamp.toSec());
    ++pairs;
    if (!l.objects.empty()) ++with_objects;
    EXPECT_EQ(l.header.frame_id, r->header.frame_id) << where;
    ASSERT_EQ(l.objects.size(), r->objects.size()) << where;
    for (std::size_t i = 0; i < l.objects.size(); ++i) expectSameObject(l.objects[i], r->objects[i], where);
    EXPECT_EQ(l.missing, r->missing) << where;
    EXPECT_EQ(l.robot_found, r->robot_found) << where;
    if (l.robot_found && r->robot_found) {
      EXPECT_NEAR(l.robot.x, r->robot.x, kTolerance) << where;
      EXPECT_NEAR(l.robot.y, r->robot.y, kTolerance) << where;
      EXPECT_NEAR(l.robot.theta, r->robot.theta, kTolerance) << where;
    }
  }
  const std::size_t min_pairs = std::stoul(env("XPERSIF_REPLAY_MIN_FEATURES", "20"));
  std::cout << "features: " << live.size() << " live vectors, " << replay.size() << " replayed, " << pairs
            << " pairs compared (" << with_objects << " with objects), " << unmatched
            << " replayed without a live twin, " << ambiguous << " with a stamp two live images share\n";
  EXPECT_GE(pairs, min_pairs);
  EXPECT_GE(with_objects, min_pairs);
}

/// The input a record's prediction was made for: its experiment and the pushed object as `before` saw it.
std::optional<xpersif::core::PushInput> inputOf(const xpersif::core::ExperimentRecord& record) {
  const xpersif::core::ObjectFeatures* object = record.before.find(record.experiment.object);
  if (!object) return std::nullopt;
  return xpersif::core::PushInput{record.experiment, *object};
}

void expectSamePrediction(const xpersif::core::Prediction& a, const xpersif::core::Prediction& b,
                          const std::string& what) {
  // Bit for bit: the same samples in the same order give the same model (push_learner.h, "Determinism").
  EXPECT_EQ(a.mean.dx, b.mean.dx) << what;
  EXPECT_EQ(a.mean.dy, b.mean.dy) << what;
  EXPECT_EQ(a.mean.dyaw, b.mean.dyaw) << what;
  EXPECT_EQ(a.std.dx, b.std.dx) << what;
  EXPECT_EQ(a.std.dy, b.std.dy) << what;
  EXPECT_EQ(a.std.dyaw, b.std.dyaw) << what;
}

TEST(Replay, learnedModelsAndPredictionsEqualTheLiveOnes) {
  const Bags b = bags();
  const auto live = readTopic<xpersif::LearnedModel>(b.live, "/xpersif/machine_learning/model");
  const auto replay = readTopic<xpersif::LearnedModel>(b.replay, b.model_topic);
  std::vector<xpersif::core::ExperimentRecord> records;
  for (const auto& r : xpersif::traces::readExperimentRecords(b.live)) records.push_back(xpersif::fromMsg(r.record));
  ASSERT_FALSE(records.empty()) << "no experiment records in the live recording";
  ASSERT_FALSE(replay.empty()) << "the replayed MACHINELEARNING published nothing on " << b.model_topic;

  std::map<std::pair<std::uint64_t, std::uint32_t>, xpersif::LearnedModel::ConstPtr> replayed;
  for (const auto& m : replay) replayed[{m->run_id, m->samples}] = m;
  auto load = [](const xpersif::LearnedModel& m) {
    xpersif::core::PushLearner learner;
    learner.load(m.data);
    return learner;
  };

  // 1. Every live model has a byte-identical replayed twin that predicts every record the same.
  std::size_t models = 0, predictions = 0, trained = 0;
  for (const auto& l : live) {
    if (l->samples == 0) continue;
    const std::string what = "run " + std::to_string(l->run_id) + ", " + std::to_string(l->samples) + " samples";
    const auto it = replayed.find({l->run_id, l->samples});
    ASSERT_NE(it, replayed.end()) << "no replayed model for the live model of " << what;
    EXPECT_EQ(l->format, it->second->format) << what;
    EXPECT_TRUE(l->data == it->second->data) << "the replayed model of " << what << " differs from the live one";
    const auto a = load(*l), c = load(*it->second);
    ASSERT_EQ(a.sampleCount(), l->samples) << what;
    if (a.trainedCount() >= xpersif::core::PushLearner::kMinTrainingSamples) ++trained;
    for (const auto& record : records) {
      if (auto input = inputOf(record)) {
        expectSamePrediction(a.predict(*input), c.predict(*input), what + ", record seq " + std::to_string(record.seq));
        ++predictions;
      }
    }
    ++models;
  }

  // 2. The predictions the live loop made before each push are the replayed model's with the samples before it.
  std::map<std::uint64_t, std::uint32_t> samples_before;  // per run: samples given by the records so far
  std::size_t live_predictions = 0;
  for (const auto& record : records) {
    std::uint32_t& n = samples_before[record.run_id];
    const auto input = inputOf(record);
    if (record.prediction && input && n > 0) {
      const auto it = replayed.find({static_cast<std::uint64_t>(record.run_id), n});
      ASSERT_NE(it, replayed.end()) << "no replayed model with " << n << " samples for record seq " << record.seq;
      expectSamePrediction(*record.prediction, load(*it->second).predict(*input),
                           "the live prediction of record seq " + std::to_string(record.seq));
      ++live_predictions;
    }
    if (xpersif::core::pushSampleOf(record)) ++n;
  }
  std::cout << "learning: " << records.size() << " records, " << live.size() << " live models, " << replay.size()
            << " replayed; " << models << " model pairs (" << trained << " trained) identical, " << predictions
            << " predictions compared, " << live_predictions << " live predictions reproduced\n";
  EXPECT_GE(models, 3u);
  EXPECT_GE(trained, 1u) << "no model was past its first kMinTrainingSamples samples";
  EXPECT_GE(live_predictions, 2u);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  if (env("XPERSIF_REPLAY_LIVE").empty() || env("XPERSIF_REPLAY_BAG").empty()) {
    std::cerr << "test_replay is run by test/traces_replay.sh (XPERSIF_REPLAY_LIVE, XPERSIF_REPLAY_BAG)\n";
    return 2;
  }
  return RUN_ALL_TESTS();
}
