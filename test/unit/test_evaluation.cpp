#include <cmath>
// The learning-curve evaluation used by the report: trained on a run's first k experiments, judged on a
// fixed evaluation set, straight from the knowledge base's records.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "xpersif/core/evaluation/evaluation.h"
#include "xpersif/core/learning/motivation.h"

using namespace xpersif::core;

namespace {

// Synthetic pushes: blue never moves; the others move k * distance, turning with the offset.
ExperimentRecord synthetic(std::mt19937& rng, int seq) {
  const std::vector<std::string> objects = {"blue_cube", "green_cube", "red_cube"};
  const std::map<std::string, double> hue = {{"blue_cube", 232}, {"green_cube", 125}, {"red_cube", 0}};
  std::uniform_real_distribution<double> offset(-0.015, 0.015), distance(0.02, 0.08);
  std::uniform_int_distribution<int> pick(0, 2), side(0, 3);
  ExperimentRecord r;
  r.seq = seq;
  r.experiment = {objects[pick(rng)], pushSides()[side(rng)], offset(rng), distance(rng)};
  ObjectFeatures o{r.experiment.object, 0.0, 0.0, 0.0, {{"hue", hue.at(r.experiment.object)}, {"size", 0.04}}};
  r.before.objects = {o};
  r.after.objects = {o};
  const double k = r.experiment.object == "blue_cube" ? 0.0 : (r.experiment.object == "red_cube" ? 0.9 : 0.7);
  r.outcome = Outcome{k * r.experiment.distance, 0.0, -8.0 * k * r.experiment.offset};
  return r;
}

}  // namespace

TEST(Evaluation, PushSamplesSkipFailedAndIncompleteRecords) {
  std::mt19937 rng(1);
  std::vector<ExperimentRecord> records = {synthetic(rng, 1), synthetic(rng, 2), synthetic(rng, 3)};
  records[1].status = "failed";
  records[1].outcome.reset();
  records[2].before.objects.clear();  // the object was not seen before the push
  const auto samples = pushSamples(records);
  ASSERT_EQ(samples.size(), 1u);
  EXPECT_EQ(samples[0].input.experiment.object, records[0].experiment.object);
}

TEST(Evaluation, ErrorFallsAsTheModelLearnsAndTheCurveFindsWhereItReachesAnError) {
  std::mt19937 rng(7);
  std::vector<ExperimentRecord> train, test;
  for (int i = 0; i < 40; ++i) train.push_back(synthetic(rng, i + 1));
  for (int i = 0; i < 20; ++i) test.push_back(synthetic(rng, i + 1));
  const auto config = loopLearnerConfig({"blue_cube", "green_cube", "red_cube"});
  const LearningCurve curve = learningCurve("random", pushSamples(train), pushSamples(test), config, {0, 5, 20, 40, 99});
  ASSERT_EQ(curve.experiments, (std::vector<int>{0, 5, 20, 40}));  // 99 > the samples available
  EXPECT_GT(curve.error[0], curve.error[3] * 2);
  EXPECT_LT(curve.error[3], curve.error[1]);
  EXPECT_EQ(experimentsToReach(curve, curve.error[3]), curve.experiments[std::distance(
                                                           curve.error.begin(),
                                                           std::find_if(curve.error.begin(), curve.error.end(),
                                                                        [&](double e) { return e <= curve.error[3]; }))]);
  EXPECT_EQ(experimentsToReach(curve, -1.0), -1);
  // Deterministic: the same records give the same curve.
  const LearningCurve again = learningCurve("random", pushSamples(train), pushSamples(test), config, {0, 5, 20, 40});
  EXPECT_EQ(again.error, curve.error);
  // Per object: every object of the evaluation set has a point at every k, and the objects' squared errors,
  // weighted by their pushes, make up the whole set's.
  int pushes = 0;
  for (const auto& [object, n] : curve.object_pushes) pushes += n;
  EXPECT_EQ(pushes, 20);
  for (std::size_t i = 0; i < curve.experiments.size(); ++i) {
    double squares = 0;
    for (const auto& [object, errors] : curve.object_error) {
      ASSERT_EQ(errors.size(), curve.experiments.size()) << object;
      squares += curve.object_pushes.at(object) * errors[i] * errors[i];
    }
    EXPECT_NEAR(std::sqrt(squares / pushes), curve.error[i], 1e-12);
  }
}

TEST(Evaluation, OnlyObjectsThatMoveAreWeighedAndEachEqually) {
  auto push = [](const std::string& object, double distance, double dx, double dyaw) {
    PushSample s;
    s.input.experiment.object = object;
    s.input.experiment.distance = distance;
    s.outcome.dx = dx;
    s.outcome.dyaw = dyaw;
    return s;
  };
  std::vector<PushSample> evaluation;
  for (int i = 0; i < 5; ++i) {
    evaluation.push_back(push("block", 0.05, 0.0003, 0.001));  // 0.6 % + a turn of 0.02 mm: does not move
    evaluation.push_back(push("cube", 0.05, 0.04, 0.1));
    evaluation.push_back(push("bar", 0.04, 0.0, 0.3));  // turns only: 0.3 rad at 2 cm = 6 mm, 15 % of the push
  }
  EXPECT_EQ(movingObjects(evaluation), (std::vector<std::string>{"cube", "bar"}));
  EXPECT_EQ(movingObjects(evaluation, 0.2), (std::vector<std::string>{"cube"}));

  LearningCurve curve;
  curve.experiments = {0, 10, 20};
  curve.object_error = {{"cube", {0.04, 0.02, 0.01}}, {"bar", {0.02, 0.02, 0.01}}, {"block", {0.0, 0.0, 0.0}}};
  const auto balanced = balancedError(curve, {"cube", "bar"});
  EXPECT_NEAR(balanced[0], 0.03, 1e-12);
  EXPECT_NEAR(balanced[2], 0.01, 1e-12);
  curve.object_goal_error = {{"cube", {0.03, 0.01, 0.01}}, {"bar", {0.05, 0.03}}};  // bar lacks its last point
  const auto goal = balancedGoalError(curve, {"cube", "bar"});
  EXPECT_NEAR(goal[0], 0.04, 1e-12);
  EXPECT_NEAR(goal[2], 0.01, 1e-12);  // the objects that have the point
  EXPECT_TRUE(std::isnan(balancedGoalError(curve, {"block"})[1]));
  // After k experiments: the first checkpoint at or after k, the last one past the end.
  EXPECT_DOUBLE_EQ(valueAt(curve.experiments, goal, 5), goal[1]);
  EXPECT_DOUBLE_EQ(valueAt(curve.experiments, goal, 10), goal[1]);
  EXPECT_DOUBLE_EQ(valueAt(curve.experiments, goal, 99), goal[2]);
  EXPECT_TRUE(std::isnan(valueAt({}, {}, 1)));
  // Constant error: the area is its log; log-linear from 0.04 to 0.01: the log of the geometric middle, 0.02.
  EXPECT_NEAR(logArea({0, 20, 40}, {0.02, 0.02, 0.02}), std::log(0.02), 1e-12);
  EXPECT_NEAR(logArea({0, 20, 40}, {0.04, 0.02, 0.01}), std::log(0.02), 1e-12);
  EXPECT_TRUE(std::isnan(logArea({0, 1}, {0.1})));
}

TEST(Evaluation, RunParametersAreReadFromTheStoredJsonOrFallBack) {
  const std::string stored = R"({"experiments":32,"goals":5,"design":"random","goal_tolerance":0.02,"provenance":{}})";
  EXPECT_EQ(designedCount(stored), 32);
  EXPECT_DOUBLE_EQ(runParameter(stored, "goal_tolerance", 0.05), 0.02);
  EXPECT_DOUBLE_EQ(runParameter(stored, "max_goal_pushes", 6), 6);   // an older run: not stored
  EXPECT_DOUBLE_EQ(runParameter(stored, "design", 1), 1);            // not a number
  EXPECT_EQ(designedCount("{\"experiments\": 7}"), 7);                // spacing is JSON's business
  EXPECT_EQ(designedCount("not json"), -1);
  EXPECT_EQ(designedCount("[32]"), -1);
  EXPECT_EQ(designedCount(""), -1);
}

TEST(Evaluation, APerObjectLearnerKnowsTheObjectThatNeverMovesFromAFewPushes) {
  // Few pushes of blue_cube (it never moves) among many of the moving cubes: a model per object predicts blue's
  // pushes from blue's own, where one shared model lends it some of its neighbours' motion.
  std::mt19937 rng(3);
  std::vector<ExperimentRecord> train, test;
  int blue = 0;
  while (train.size() < 60) {
    ExperimentRecord r = synthetic(rng, static_cast<int>(train.size()) + 1);
    if (r.experiment.object == "blue_cube" && ++blue > 4) continue;
    train.push_back(r);
  }
  while (test.size() < 20) {
    ExperimentRecord r = synthetic(rng, static_cast<int>(test.size()) + 1);
    if (r.experiment.object == "blue_cube") test.push_back(r);
  }
  const auto config = loopLearnerConfig({"blue_cube", "green_cube", "red_cube"});
  const int n = static_cast<int>(pushSamples(train).size());
  const LearningCurve shared = learningCurve("shared", pushSamples(train), pushSamples(test), config, {0, n});
  const LearningCurve per_object =
      learningCurve("per_object", pushSamples(train), pushSamples(test), config, {0, n}, LearnerScope::PerObject);
  EXPECT_EQ(per_object.error[0], shared.error[0]);  // untrained: both are the prior
  EXPECT_LT(per_object.error[1], 0.5 * shared.error[1]) << "shared " << shared.error[1] << " per object "
                                                         << per_object.error[1];
  // An object the per-object model has no learner of its own for is predicted by the shared one.
  std::vector<ExperimentRecord> without_blue;
  for (const auto& r : train) {
    if (r.experiment.object != "blue_cube") without_blue.push_back(r);
  }
  const int m = static_cast<int>(pushSamples(without_blue).size());
  const LearningCurve unseen =
      learningCurve("unseen", pushSamples(without_blue), pushSamples(test), config, {m}, LearnerScope::PerObject);
  const LearningCurve unseen_shared = learningCurve("unseen", pushSamples(without_blue), pushSamples(test), config, {m});
  EXPECT_EQ(unseen.error[0], unseen_shared.error[0]);
}

TEST(Evaluation, DesignedSamplesLeaveOutFailedPushesAndTheGoalPushesAfterTheDesignedOnes) {
  const std::string path = ::testing::TempDir() + "designed_samples.db";
  std::remove(path.c_str());
  std::mt19937 rng(3);
  std::vector<ExperimentRecord> stored;
  {
    auto kb = KnowledgeBase::open(path);
    const RunInfo run = kb->createRun("a", "{\"experiments\": 3}", 1, "random");
    for (int seq = 1; seq <= 5; ++seq) {  // 1-3 designed (2 fails), 4-5 goal-directed pushes
      ExperimentRecord r = synthetic(rng, seq);
      r.run_id = run.id;
      if (seq == 2) {
        r.status = "failed";
        r.outcome.reset();
        r.failure_reason = "refused";
      }
      stored.push_back(kb->recordExperiment(r));
    }
  }
  const auto samples = designedSamples(path);
  const EvaluationSet evaluation = loadEvaluationSet(path);  // every successful push of every run
  EXPECT_EQ(evaluation.samples.size(), 4u);
  EXPECT_EQ(evaluation.identities, sceneIdentities(stored));
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_EQ(samples[0].input.experiment.object, stored[0].experiment.object);
  EXPECT_EQ(samples[1].input.experiment.object, stored[2].experiment.object);
  std::remove(path.c_str());
}

TEST(Evaluation, SceneIdentitiesKeepTheOrderTheScenesListThem) {
  ExperimentRecord a, b;
  a.before.objects = {ObjectFeatures{"red_cube", 0, 0, 0, {}}, ObjectFeatures{"blue_cube", 0, 0, 0, {}}};
  b.before.objects = {ObjectFeatures{"blue_cube", 0, 0, 0, {}}, ObjectFeatures{"green_cube", 0, 0, 0, {}}};
  EXPECT_EQ(sceneIdentities({a, b}), (std::vector<std::string>{"red_cube", "blue_cube", "green_cube"}));
  EXPECT_TRUE(sceneIdentities({}).empty());
}

// Competence at one-push goals (issue 38): a model that predicts every outcome picks the push the library's best
// chooser picks; one that predicts nothing useful does no better than picking at random; and a model that learned
// from pushes gets better than it was with none.
TEST(Evaluation, OneShotGoalErrorIsTheBestChoiceForAPerfectModelAndFallsAsTheModelLearns) {
  std::vector<PushSample> evaluation;
  for (int i = 0; i < 6; ++i) {
    PushSample s;
    s.input.experiment.object = "cube";
    s.outcome = Outcome{0.01 * (i + 1), 0.0, 0.0};  // 1, 2, ... 6 cm along the push
    evaluation.push_back(s);
  }
  std::vector<Outcome> perfect;
  for (const auto& s : evaluation) perfect.push_back(s.outcome);
  const auto [random_choice, best_choice] = goalReferences(evaluation).at("cube");
  EXPECT_NEAR(best_choice, 0.01, 1e-12) << "the nearest other outcome is 1 cm away for every target";
  EXPECT_NEAR(oneShotGoalErrors(evaluation, perfect).at("cube"), best_choice, 1e-12);
  // Mean distance to the other five, over the six targets: (15+11+9+9+11+15)/5/6 cm = 2.33 cm.
  EXPECT_NEAR(random_choice, 0.07 / 3.0, 1e-12);
  const std::vector<Outcome> nothing(evaluation.size(), Outcome{0.0, 0.0, 0.0});
  // Predicting no motion for all: the first other push (ties go to the earlier) is always chosen.
  EXPECT_GT(oneShotGoalErrors(evaluation, nothing).at("cube"), best_choice * 2);
  EXPECT_NEAR(outcomeDistance(Outcome{0, 0, M_PI - 0.1}, Outcome{0, 0, -M_PI + 0.1}), 0.2 * kYawLength, 1e-12)
      << "a turn is measured the short way round";

  // From the learning curve: with the synthetic pushes, the model after 60 pushes chooses better than with none.
  std::mt19937 rng(7);
  std::vector<ExperimentRecord> records;
  for (int i = 0; i < 90; ++i) records.push_back(synthetic(rng, i + 1));
  const auto samples = pushSamples(records);
  const std::vector<PushSample> training(samples.begin(), samples.begin() + 60), held(samples.begin() + 60, samples.end());
  const auto curve = learningCurve("c", training, held, loopLearnerConfig(sceneIdentities(records)), {0, 60});
  const auto& red = curve.object_goal_error.at("red_cube");
  ASSERT_EQ(red.size(), 2u);
  EXPECT_LT(red[1], red[0]);
  EXPECT_LE(curve.object_goal_random_best.at("red_cube").second, red[1] + 1e-12) << "no model beats the best choice";
}
