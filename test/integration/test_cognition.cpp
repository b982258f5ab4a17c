// KNOWLEDGEBASE, MACHINELEARNING and MOTIVATION as nodelets (KB in kb_manager, the others in loop_manager):
// synthetic pushes (the light cubes move 0.9 x the push distance, blue_cube never moves) go through predict
// and record_experiment as the loop would send them; the test checks what is stored, what is refused, what is
// learned, what motivates, and that a reloaded MACHINELEARNING restores itself from the KB.
#include <gtest/gtest.h>
#include <nodelet/NodeletLoad.h>
#include <nodelet/NodeletUnload.h>
#include <ros/ros.h>
#include <std_msgs/UInt64.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>

#include "test_helpers.h"
#include "xpersif/FinishRun.h"
#include "xpersif/GetExperiments.h"
#include "xpersif/GetNotions.h"
#include "xpersif/GetState.h"
#include "xpersif/LearnedModel.h"
#include "xpersif/Motivation.h"
#include "xpersif/Notions.h"
#include "xpersif/Predict.h"
#include "xpersif/ResultCode.h"
#include "xpersif/RecordExperiment.h"
#include "xpersif/StartRun.h"
#include "xpersif/core/kb/knowledge_base.h"
#include "xpersif/core/learning/motivation.h"
#include "xpersif/core/learning/gaussian_process_push_model.h"
#include "xpersif/core/learning/push_learner.h"

using xpersif::ComponentStatus;
using xpersif::ExperimentRecord;
using xpersif::LearnedModel;
using xpersif::Motivation;
using xpersif::Notions;
using xpersif_test::Recorder;
using xpersif_test::waitFor;

namespace {

struct Cube {
  const char* name;
  double hue;
  bool moves;
  double x, y;
};
const Cube kCubes[] = {{"red_cube", 0.0, true, 0.05, 0.15},
                       {"green_cube", 125.0, true, 0.05, -0.15},
                       {"blue_cube", 225.0, false, 0.25, 0.0},
                       {"yellow_cube", 52.0, true, 0.3, 0.18}};
const char* kSides[] = {"-x", "+x", "-y", "+y"};
const double kOffsets[] = {-0.012, 0.0, 0.012};

xpersif::ObjectFeatures objectOf(const Cube& cube, double dx_world) {
  xpersif::ObjectFeatures o;
  o.name = cube.name;
  o.position.x = cube.x + dx_world;
  o.position.y = cube.y;
  o.yaw_period = M_PI / 2;
  o.orientation_known = true;
  o.confidence = 1.0;
  o.feature_names = {"hue", "size"};
  o.feature_values = {cube.hue, 0.04};
  return o;
}

xpersif::FeatureVector sceneOf(int pushed, double dx_world, double stamp) {
  xpersif::FeatureVector v;
  v.header.stamp = ros::Time(stamp);
  v.source = "/xpersif/observation";
  for (int c = 0; c < 4; ++c) v.objects.push_back(objectOf(kCubes[c], c == pushed ? dx_world : 0.0));
  return v;
}

/// Push i of the synthetic run, with its true outcome (no prediction yet).
ExperimentRecord pushNumber(int i) {
  const int c = i % 4;
  ExperimentRecord r;
  r.design = "grid";
  r.experiment.object = kCubes[c].name;
  r.experiment.side = kSides[(i / 4) % 4];
  r.experiment.offset = kOffsets[i % 3];
  r.experiment.distance = 0.03 + 0.01 * (i % 5);
  r.status = "done";
  if (kCubes[c].moves) {
    r.dx = 0.9 * r.experiment.distance;
    r.dy = -0.1 * r.experiment.offset;
    r.dyaw = -3.0 * r.experiment.offset;
  }
  r.before = sceneOf(c, 0.0, 10.0 * i + 1);
  r.after = sceneOf(c, kCubes[c].moves ? 0.9 * r.experiment.distance : 0.0, 10.0 * i + 5);
  r.started = 10.0 * i + 1;
  r.finished = 10.0 * i + 5;
  return r;
}

template <class Service>
bool call(const std::string& name, Service& service) {
  return ros::service::waitForService(name, ros::Duration(30.0)) && ros::service::call(name, service);
}

std::uint8_t stateOf(const std::string& component) {
  xpersif::GetState s;
  if (!ros::service::call(component + "/get_state", s)) return 255;
  return s.response.state;
}

xpersif::Predict::Response predict(const ExperimentRecord& r, std::uint64_t run_id = 0) {
  xpersif::Predict p;
  p.request.run_id = run_id;
  p.request.experiment = r.experiment;
  for (const auto& o : r.before.objects) {
    if (o.name == r.experiment.object) p.request.object = o;
  }
  if (!call("/machine_learning/predict", p)) p.response.message = "predict did not answer";
  return p.response;
}

std::uint32_t predictedSamples() {
  xpersif::Predict::Response r = predict(pushNumber(0));
  return r.success ? r.samples : 0;
}

xpersif::RecordExperiment::Response record(const ExperimentRecord& r) {
  xpersif::RecordExperiment s;
  s.request.record = r;
  if (!call("/knowledge_base/record_experiment", s)) s.response.message = "record_experiment did not answer";
  return s.response;
}

std::vector<ExperimentRecord> storedExperiments(const std::string& status = "") {
  xpersif::GetExperiments s;
  s.request.run_id = 0;
  s.request.status = status;
  EXPECT_TRUE(call("/knowledge_base/get_experiments", s));
  EXPECT_TRUE(s.response.success) << s.response.message;
  return s.response.experiments;
}

bool hasNotion(const std::vector<xpersif::Notion>& notions, const std::string& subject, const std::string& predicate) {
  for (const auto& n : notions) {
    if (n.subject == subject && n.predicate == predicate) return true;
  }
  return false;
}

bool loadNodelet(const std::string& manager, const std::string& name, const std::string& type) {
  nodelet::NodeletLoad load;
  load.request.name = name;
  load.request.type = type;
  return call(manager + "/load_nodelet", load) && load.response.success;
}

bool reloadNodelet(const std::string& manager, const std::string& name, const std::string& type) {
  nodelet::NodeletUnload unload;
  unload.request.name = name;
  if (!call(manager + "/unload_nodelet", unload) || !unload.response.success) return false;
  nodelet::NodeletLoad load;
  load.request.name = name;
  load.request.type = type;
  return call(manager + "/load_nodelet", load) && load.response.success;
}

}  // namespace

class Cognition : public ::testing::Test {
 protected:
  ros::NodeHandle nh_;
};

TEST_F(Cognition, RecordsLearnsMotivatesAndRestores) {
  Recorder<std_msgs::UInt64> runs(nh_, "/knowledge_base/run");
  Recorder<ExperimentRecord> stored(nh_, "/knowledge_base/experiments");
  Recorder<LearnedModel> models(nh_, "/machine_learning/model");
  Recorder<Notions> notions(nh_, "/machine_learning/notions");
  Recorder<Motivation> motivations(nh_, "/motivation/motivation");
  ASSERT_TRUE(loadNodelet("/loop_manager", "/machine_learning", "xpersif/MachineLearningNodelet"));
  ASSERT_TRUE(loadNodelet("/loop_manager", "/motivation", "xpersif/MotivationNodelet"));
  for (const char* component : {"/knowledge_base", "/machine_learning", "/motivation"}) {
    ASSERT_TRUE(waitFor([&] { return stateOf(component) == ComponentStatus::ACTIVE; }, 60.0)) << component;
  }
  ASSERT_TRUE(stored.waitForConnection(30.0));

  // ---- a new run, announced on ~run; MACHINELEARNING follows it (an empty model of that run) ----
  xpersif::StartRun start;
  start.request.name = "cognition test";
  start.request.parameters = "{\"pushes\": 30}";
  start.request.seed = 7;
  start.request.design = "grid";
  ASSERT_TRUE(call("/knowledge_base/start_run", start));
  ASSERT_TRUE(start.response.success) << start.response.message;
  EXPECT_FALSE(start.response.resumed);
  EXPECT_EQ(start.response.experiments_done, 0u);
  const std::uint64_t run = start.response.run_id;
  ASSERT_GT(run, 0u);
  EXPECT_TRUE(runs.waitForMatch([&](const std_msgs::UInt64& m) { return m.data == run; }, 30.0));
  ASSERT_TRUE(models.waitForMatch([&](const LearnedModel& m) { return m.run_id == run && m.samples == 0; }, 60.0));
  // MOTIVATION too has taken the run (its restore from the KB is done): every push below then reaches it as one
  // message. Pushes stored before that would come back in one restore, as one message for several.
  ASSERT_TRUE(motivations.waitForMatch([&](const Motivation& m) { return m.run_id == run && m.experiments == 0; }, 60.0));
  // A prediction asked for another run than the model's is refused as not yet possible (the loop asks again), not
  // made with the wrong run's model.
  const xpersif::Predict::Response other_run = predict(pushNumber(0), run + 1);
  EXPECT_FALSE(other_run.success);
  EXPECT_EQ(other_run.code, xpersif::ResultCode::UNAVAILABLE) << other_run.message;
  EXPECT_NE(other_run.message.find("not yet of run " + std::to_string(run + 1)), std::string::npos) << other_run.message;
  EXPECT_TRUE(predict(pushNumber(0), run).success);

  // ---- 30 pushes: predict, record, and the model follows sample by sample ----
  const int kPushes = 30;
  std::vector<double> errors;
  std::vector<ExperimentRecord> sent;
  for (int i = 0; i < kPushes; ++i) {
    ExperimentRecord r = pushNumber(i);
    const xpersif::Predict::Response p = predict(r);
    ASSERT_TRUE(p.success) << "push " << i << ": " << p.message;
    ASSERT_EQ(p.mean.size(), 3u);
    ASSERT_EQ(p.std.size(), 3u);
    EXPECT_EQ(p.samples, static_cast<std::uint32_t>(i)) << "push " << i;
    r.predicted_mean = p.mean;
    r.predicted_std = p.std;
    const xpersif::core::Surprise s = xpersif::core::surprise(
        {{p.mean[0], p.mean[1], p.mean[2]}, {p.std[0], p.std[1], p.std[2]}}, {r.dx, r.dy, r.dyaw});
    r.surprise = s.error;
    errors.push_back(s.error);
    const xpersif::RecordExperiment::Response stored_response = record(r);
    ASSERT_TRUE(stored_response.success) << "push " << i << ": " << stored_response.message;
    EXPECT_EQ(stored_response.seq, static_cast<std::uint32_t>(i + 1));
    EXPECT_GT(stored_response.id, 0u);
    sent.push_back(r);
    ASSERT_TRUE(models.waitForMatch(
        [&](const LearnedModel& m) {
          return m.run_id == run && m.samples == static_cast<std::uint32_t>(i + 1) && !m.data.empty();
        },
        60.0))
        << "the model did not reach " << i + 1 << " samples";
  }

  // ---- stored and re-read: every record, in order, as sent ----
  ASSERT_TRUE(stored.waitForMatch([&](const ExperimentRecord& m) { return m.seq == kPushes; }, 30.0));
  const std::vector<ExperimentRecord> published = stored.messages();
  ASSERT_EQ(published.size(), static_cast<std::size_t>(kPushes));
  const std::vector<ExperimentRecord> reread = storedExperiments();
  ASSERT_EQ(reread.size(), static_cast<std::size_t>(kPushes));
  EXPECT_TRUE(storedExperiments("failed").empty());
  for (int i = 0; i < kPushes; ++i) {
    const ExperimentRecord& a = reread[i];
    const ExperimentRecord& b = sent[i];
    SCOPED_TRACE("record " + std::to_string(i + 1));
    EXPECT_EQ(a.seq, static_cast<std::uint32_t>(i + 1));
    EXPECT_EQ(a.run_id, run);
    EXPECT_EQ(a.id, published[i].id);
    EXPECT_EQ(published[i].seq, a.seq);
    EXPECT_EQ(published[i].design, "grid");
    EXPECT_EQ(a.experiment.object, b.experiment.object);
    EXPECT_EQ(a.experiment.side, b.experiment.side);
    EXPECT_DOUBLE_EQ(a.experiment.offset, b.experiment.offset);
    EXPECT_DOUBLE_EQ(a.experiment.distance, b.experiment.distance);
    EXPECT_EQ(a.status, "done");
    EXPECT_DOUBLE_EQ(a.dx, b.dx);
    EXPECT_DOUBLE_EQ(a.dy, b.dy);
    EXPECT_DOUBLE_EQ(a.dyaw, b.dyaw);
    ASSERT_EQ(a.predicted_mean.size(), 3u);
    EXPECT_EQ(a.predicted_mean, b.predicted_mean);
    EXPECT_EQ(a.predicted_std, b.predicted_std);
    EXPECT_DOUBLE_EQ(a.surprise, b.surprise);
    EXPECT_DOUBLE_EQ(a.started, b.started);
    EXPECT_DOUBLE_EQ(a.after.header.stamp.toSec(), b.after.header.stamp.toSec());
    ASSERT_EQ(a.before.objects.size(), 4u);
    ASSERT_EQ(a.after.objects.size(), 4u);
    for (std::size_t k = 0; k < 4; ++k) {
      // The stored form keeps name, x, y, yaw and the named features (in name order: hue, size).
      EXPECT_EQ(a.after.objects[k].name, b.after.objects[k].name);
      EXPECT_DOUBLE_EQ(a.after.objects[k].position.x, b.after.objects[k].position.x);
      EXPECT_DOUBLE_EQ(a.after.objects[k].position.y, b.after.objects[k].position.y);
      EXPECT_EQ(a.after.objects[k].feature_names, b.after.objects[k].feature_names);
      EXPECT_EQ(a.after.objects[k].feature_values, b.after.objects[k].feature_values);
    }
  }

  // ---- the prediction error falls as the model learns ----
  double early = 0, late = 0;
  for (int i = 0; i < 8; ++i) {
    early += errors[i] / 8;
    late += errors[kPushes - 8 + i] / 8;
  }
  std::printf("[ cognition ] mean prediction error, pushes 1-8: %.5f m, pushes 23-30: %.5f m\n", early, late);
  EXPECT_GT(early, 0.01);
  // The forest's error falls below a quarter; the Gaussian process (fixed kernel, cognition_gp.test) learns these
  // 30 pushes more slowly (measured: 0.0240 m -> 0.0089 m, 0.37x), so its bar is half. Tuning its kernel is open.
  std::string learner = "random_forest";
  ros::param::get("/machine_learning/learner_type", learner);
  EXPECT_LT(late, (learner == "gaussian_process" ? 0.5 : 0.25) * early);

  // ---- notions: blue_cube does not move, the light cubes do; the KB stores them ----
  Notions learned;
  ASSERT_TRUE(notions.waitForMatch([&](const Notions& n) { return n.run_id == run && n.samples == kPushes; }, 30.0,
                                   &learned));
  EXPECT_TRUE(hasNotion(learned.notions, "blue_cube", "does_not_move_when_pushed"));
  EXPECT_FALSE(hasNotion(learned.notions, "blue_cube", "moves_when_pushed"));
  for (const char* light : {"red_cube", "green_cube", "yellow_cube"}) {
    EXPECT_TRUE(hasNotion(learned.notions, light, "moves_when_pushed")) << light;
  }
  for (const auto& n : learned.notions) std::printf("[ cognition ] notion: %s\n", n.text.c_str());
  xpersif::GetNotions kb_notions;
  EXPECT_TRUE(waitFor(
      [&] {
        kb_notions.request.run_id = 0;
        return call("/knowledge_base/get_notions", kb_notions) && kb_notions.response.success &&
               kb_notions.response.notions.size() == learned.notions.size() &&
               hasNotion(kb_notions.response.notions, "blue_cube", "does_not_move_when_pushed");
      },
      30.0))
      << kb_notions.response.message;

  // ---- the KB stored the latest model MACHINELEARNING published (read from the database file itself) ----
  std::string database;
  ASSERT_TRUE(ros::param::get("/knowledge_base/database", database));
  {
    auto kb = xpersif::core::KnowledgeBase::open(database);
    std::optional<xpersif::core::ModelRecord> model;
    EXPECT_TRUE(waitFor(
        [&] {
          model = kb->latestModel(static_cast<std::int64_t>(run), "push_learner");
          return model && model->sample_count == kPushes;
        },
        30.0));
    ASSERT_TRUE(model.has_value());
    // The learner chosen by name (cognition_gp.test runs this test with the Gaussian process).
    std::string learner_type = "random_forest";
    ros::param::get("/machine_learning/learner_type", learner_type);
    const std::string format = learner_type == "gaussian_process" ? xpersif::core::GaussianProcessPushModel::kFormat
                                                                  : xpersif::core::PushLearner::kFormat;
    EXPECT_EQ(models.messages().back().format, format);
    EXPECT_EQ(model->format, format);
    EXPECT_EQ(model->blob, models.messages().back().data);
  }

  // ---- motivation after every experiment: surprise as the record says, curiosity per region ----
  Motivation motivation;
  ASSERT_TRUE(motivations.waitForMatch([&](const Motivation& m) { return m.run_id == run && m.experiments == kPushes; },
                                       30.0, &motivation));
  EXPECT_NEAR(motivation.surprise, sent.back().surprise, 1e-12);
  EXPECT_TRUE(std::isfinite(motivation.normalized_surprise));
  EXPECT_GE(motivation.normalized_surprise, 0.0);
  ASSERT_EQ(motivation.regions.size(), 4u * 4u * 3u);
  ASSERT_EQ(motivation.curiosity.size(), motivation.regions.size());
  ASSERT_EQ(motivation.learning_progress.size(), motivation.regions.size());
  ASSERT_EQ(motivation.visits.size(), motivation.regions.size());
  std::uint32_t visits = 0;
  for (auto v : motivation.visits) visits += v;
  EXPECT_EQ(visits, static_cast<std::uint32_t>(kPushes));
  EXPECT_NE(std::find(motivation.regions.begin(), motivation.regions.end(), motivation.most_curious),
            motivation.regions.end());
  std::size_t counted = 0;
  for (const auto& m : motivations.messages()) counted += m.run_id == run && m.experiments >= 1;
  EXPECT_GE(counted, static_cast<std::size_t>(kPushes));  // one per experiment (plus restores)

  // ---- invalid records are refused with a sentence, and nothing is stored or published ----
  struct Bad {
    const char* what;
    std::function<void(ExperimentRecord&)> spoil;
    const char* expected;
  };
  const std::vector<Bad> bad = {
      {"NaN outcome", [](ExperimentRecord& r) { r.dx = std::nan(""); }, "record.dx"},
      {"unknown status", [](ExperimentRecord& r) { r.status = "maybe"; }, "record.status"},
      {"unknown side", [](ExperimentRecord& r) { r.experiment.side = "up"; }, "side"},
      {"offset beyond the face", [](ExperimentRecord& r) { r.experiment.offset = 0.5; }, "offset"},
      {"infinite position",
       [](ExperimentRecord& r) { r.before.objects[1].position.x = std::numeric_limits<double>::infinity(); },
       "record.before.objects[1].position.x"},
      {"features not parallel", [](ExperimentRecord& r) { r.after.objects[0].feature_values.pop_back(); }, "parallel"},
      {"too many objects", [](ExperimentRecord& r) { r.before.objects.resize(65, r.before.objects[0]); }, "objects"},
      {"prediction of 2 numbers", [](ExperimentRecord& r) { r.predicted_mean.pop_back(); }, "predicted_mean"},
      {"negative predicted std", [](ExperimentRecord& r) { r.predicted_std[0] = -1; }, "predicted_std[0]"},
      {"failed without a reason", [](ExperimentRecord& r) { r.status = "failed"; }, "reason"},
      {"run that does not exist", [](ExperimentRecord& r) { r.run_id = 987654; }, "running(987654)"},
  };
  for (const Bad& b : bad) {
    ExperimentRecord r = sent.front();
    b.spoil(r);
    const xpersif::RecordExperiment::Response response = record(r);
    EXPECT_FALSE(response.success) << b.what;
    EXPECT_NE(response.message.find(b.expected), std::string::npos) << b.what << ": " << response.message;
    std::printf("[ cognition ] refused (%s): %s\n", b.what, response.message.c_str());
  }
  EXPECT_EQ(storedExperiments().size(), static_cast<std::size_t>(kPushes));
  // A valid failed experiment next: it is the very next one published (nothing refused was published before it).
  ExperimentRecord failed = pushNumber(kPushes);
  failed.status = "failed";
  failed.reason = "the robot lost contact with the cube";
  failed.dx = failed.dy = failed.dyaw = 0;
  const auto failed_response = record(failed);
  ASSERT_TRUE(failed_response.success) << failed_response.message;
  EXPECT_EQ(failed_response.seq, static_cast<std::uint32_t>(kPushes + 1));
  ASSERT_TRUE(stored.waitForMatch([&](const ExperimentRecord& m) { return m.seq == kPushes + 1; }, 30.0));
  EXPECT_EQ(stored.messages().size(), static_cast<std::size_t>(kPushes + 1));
  EXPECT_EQ(storedExperiments("failed").size(), 1u);

  // ---- resume: the same run with its count of done experiments ----
  xpersif::StartRun resume;
  resume.request.name = "cognition test";  // resume continues the unfinished run of that name
  resume.request.resume = true;
  ASSERT_TRUE(call("/knowledge_base/start_run", resume));
  ASSERT_TRUE(resume.response.success) << resume.response.message;
  EXPECT_TRUE(resume.response.resumed);
  EXPECT_EQ(resume.response.run_id, run);
  EXPECT_EQ(resume.response.experiments_done, static_cast<std::uint32_t>(kPushes));

  // ---- MACHINELEARNING reloaded: it restores its samples from the KB and predicts exactly as before ----
  const ExperimentRecord probe = pushNumber(3);
  const xpersif::Predict::Response before_reload = predict(probe);
  ASSERT_TRUE(before_reload.success) << before_reload.message;
  EXPECT_EQ(before_reload.samples, static_cast<std::uint32_t>(kPushes));  // the failed one is no sample
  const std::size_t models_before = models.messages().size();
  ASSERT_TRUE(reloadNodelet("/loop_manager", "/machine_learning", "xpersif/MachineLearningNodelet"));
  ASSERT_TRUE(waitFor([&] { return stateOf("/machine_learning") == ComponentStatus::ACTIVE; }, 60.0));
  ASSERT_TRUE(waitFor([&] { return predictedSamples() == static_cast<std::uint32_t>(kPushes); }, 60.0))
      << "the reloaded MACHINELEARNING has " << predictedSamples() << " samples";
  const xpersif::Predict::Response after_reload = predict(probe);
  ASSERT_TRUE(after_reload.success) << after_reload.message;
  EXPECT_EQ(after_reload.mean, before_reload.mean);
  EXPECT_EQ(after_reload.std, before_reload.std);
  EXPECT_TRUE(waitFor(
      [&] {
        const auto all = models.messages();
        for (std::size_t k = models_before; k < all.size(); ++k) {
          if (all[k].run_id == run && all[k].samples == kPushes) return true;
        }
        return false;
      },
      30.0));
  // ... and goes on learning from the next push.
  ExperimentRecord next = pushNumber(kPushes + 2);
  const xpersif::RecordExperiment::Response next_response = record(next);
  ASSERT_TRUE(next_response.success) << next_response.message;
  EXPECT_TRUE(models.waitForMatch([&](const LearnedModel& m) { return m.run_id == run && m.samples == kPushes + 1; },
                                  60.0));

  // ---- MOTIVATION reloaded: it replays the run's records and has the same curiosity as before ----
  // The push just recorded has no prediction: MOTIVATION counts it as heard of (what DESIGNOFEXPERIMENTS waits
  // for) without scoring it.
  const std::uint32_t heard = kPushes + 1;
  Motivation before_motivation;
  ASSERT_TRUE(motivations.waitForMatch([&](const Motivation& m) { return m.run_id == run && m.experiments == heard; },
                                       30.0, &before_motivation));
  const std::size_t motivations_before = motivations.messages().size();
  ASSERT_TRUE(reloadNodelet("/loop_manager", "/motivation", "xpersif/MotivationNodelet"));
  Motivation restored;
  EXPECT_TRUE(waitFor(
      [&] {
        const auto all = motivations.messages();
        for (std::size_t k = motivations_before; k < all.size(); ++k) {
          if (all[k].run_id == run && all[k].experiments == heard) {
            restored = all[k];
            return true;
          }
        }
        return false;
      },
      60.0));
  EXPECT_EQ(restored.regions, before_motivation.regions);
  EXPECT_EQ(restored.curiosity, before_motivation.curiosity);
  EXPECT_EQ(restored.visits, before_motivation.visits);
  EXPECT_EQ(restored.most_curious, before_motivation.most_curious);
  EXPECT_DOUBLE_EQ(restored.surprise, before_motivation.surprise);

  // ---- finishing the run: nothing more can be added to it ----
  xpersif::FinishRun finish;
  finish.request.run_id = 0;
  finish.request.status = "finished";
  ASSERT_TRUE(call("/knowledge_base/finish_run", finish));
  EXPECT_TRUE(finish.response.success) << finish.response.message;
  const auto late_response = record(pushNumber(0));
  EXPECT_FALSE(late_response.success);
  EXPECT_NE(late_response.message.find("finished"), std::string::npos) << late_response.message;
  xpersif::FinishRun again = finish;
  ASSERT_TRUE(call("/knowledge_base/finish_run", again));
  EXPECT_FALSE(again.response.success);
}

TEST_F(Cognition, RefusesAFileThatIsNotAKnowledgeBase) {
  const std::string path = "/tmp/xpersif_test_cognition_not_a_db_" + std::to_string(getpid()) + ".txt";
  {
    std::ofstream junk(path);
    junk << "this is a text file, not an SQLite database\n";
  }
  ros::param::set("/bad_knowledge_base/database", path);
  ros::param::set("/bad_knowledge_base/autostart", true);
  Recorder<ComponentStatus> status(nh_, "/bad_knowledge_base/status");
  nodelet::NodeletLoad load;
  load.request.name = "/bad_knowledge_base";
  load.request.type = "xpersif/KnowledgeBaseNodelet";
  ASSERT_TRUE(call("/kb_manager/load_nodelet", load));
  ASSERT_TRUE(load.response.success);
  ComponentStatus error;
  EXPECT_TRUE(status.waitForMatch([](const ComponentStatus& s) { return s.state == ComponentStatus::ERROR; }, 30.0,
                                  &error));
  EXPECT_NE(error.last_error.find("cannot be used"), std::string::npos) << error.last_error;
  EXPECT_NE(error.last_error.find(path), std::string::npos) << error.last_error;
  std::printf("[ cognition ] bad database: %s\n", error.last_error.c_str());
  nodelet::NodeletUnload unload;
  unload.request.name = "/bad_knowledge_base";
  EXPECT_TRUE(call("/kb_manager/unload_nodelet", unload));
  std::remove(path.c_str());
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_cognition");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  std::string database;
  if (ros::param::get("/knowledge_base/database", database) && database.rfind("/tmp/", 0) == 0) {
    for (const char* suffix : {"", "-wal", "-shm"}) std::remove((database + suffix).c_str());
  }
  return result;
}
