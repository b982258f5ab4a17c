#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <limits>

#include "xpersif/core/learning/push_learner.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

namespace {

/// A known physical-ish rule: the heavy blue cube never moves; light cubes move k * distance along the push,
/// turn by c * offset * distance (away from the contact side), plus noise.
struct Cube {
  const char* name;
  double hue, k, c;
};
const Cube kCubes[] = {{"red_cube", 0, 0.9, -150}, {"green_cube", 120, 0.8, -120}, {"yellow_cube", 60, 1.3, -90},
                       {"blue_cube", 240, 0.0, 0.0}};

PushInput inputFor(const Cube& cube, const std::string& side, double offset, double distance) {
  PushInput in;
  in.experiment = {cube.name, side, offset, distance};
  in.object.name = cube.name;
  in.object.x = 0.1;
  in.object.y = -0.2;
  in.object.extra = {{"hue", cube.hue}, {"size", 0.04}};
  return in;
}

Outcome truth(const Cube& cube, double offset, double distance) {
  return {cube.k * distance, 0.0, cube.c * offset * distance};
}

/// Random pushes with the rule's outcome plus noise; cv::RNG so that the data are the same everywhere.
std::vector<PushSample> pushes(int n, std::uint64_t seed, const std::vector<std::string>& sides = pushSides(),
                               double min_distance = 0.01, double max_distance = 0.15) {
  cv::RNG rng(seed);
  std::vector<PushSample> samples;
  for (int i = 0; i < n; ++i) {
    const Cube& cube = kCubes[rng.uniform(0, 4)];
    const std::string side = sides[rng.uniform(0, static_cast<int>(sides.size()))];
    const double offset = rng.uniform(-0.02, 0.02);  // a 4 cm cube's offset limit
    const double distance = rng.uniform(min_distance, max_distance);
    Outcome o = truth(cube, offset, distance);
    if (cube.k > 0) {
      o.dx += rng.gaussian(0.002);
      o.dy += rng.gaussian(0.002);
      o.dyaw += rng.gaussian(0.01);
    }
    samples.push_back({inputFor(cube, side, offset, distance), o});
  }
  return samples;
}

double rmsError(const PushLearner& learner, const std::vector<PushSample>& test) {
  double sum = 0.0;
  for (const auto& s : test) {
    const Prediction p = learner.predict(s.input);
    sum += std::pow(p.mean.dx - s.outcome.dx, 2) + std::pow(p.mean.dy - s.outcome.dy, 2) +
           std::pow(0.02 * (p.mean.dyaw - s.outcome.dyaw), 2);
  }
  return std::sqrt(sum / test.size());
}

const Notion* findNotion(const std::vector<Notion>& notions, const std::string& subject, const std::string& predicate) {
  for (const auto& n : notions) {
    if (n.subject == subject && n.predicate == predicate) return &n;
  }
  return nullptr;
}

}  // namespace

TEST(PushLearner, PredictsNoMotionWithTheLargePriorBeforeData) {
  PushLearner learner;
  const Prediction p = learner.predict(inputFor(kCubes[0], "-x", 0, 0.1));
  EXPECT_EQ(p.mean.dx, 0.0);
  EXPECT_EQ(p.mean.dyaw, 0.0);
  EXPECT_EQ(p.std.dx, learner.config().prior_std.dx);
  EXPECT_EQ(p.std.dyaw, learner.config().prior_std.dyaw);
  EXPECT_EQ(learner.sampleCount(), 0u);
}

TEST(PushLearner, ErrorFallsAsSamplesAccumulate) {
  const std::vector<PushSample> train = pushes(240, 11), test = pushes(200, 99);
  std::vector<double> errors;
  for (const int n : {4, 15, 60, 240}) {
    PushLearner learner;
    learner.addSamples(std::vector<PushSample>(train.begin(), train.begin() + n));
    errors.push_back(rmsError(learner, test));
  }
  PushLearner untrained;
  const double prior_error = rmsError(untrained, test);
  std::printf("[ measured ] rms error (m): none %.4f, 4: %.4f, 15: %.4f, 60: %.4f, 240: %.4f\n", prior_error,
              errors[0], errors[1], errors[2], errors[3]);
  EXPECT_LT(errors[1], errors[0]);
  EXPECT_LT(errors[2], errors[1]);
  EXPECT_LT(errors[3], errors[2]);
  EXPECT_LT(errors[3], 0.25 * prior_error);
  EXPECT_LT(errors[3], 0.01);  // 1 cm on pushes of up to 15 cm
}

TEST(PushLearner, LearnsThatTheHeavyCubeStaysAndLightOnesFollow) {
  PushLearner learner;
  learner.addSamples(pushes(200, 5));
  const Prediction blue = learner.predict(inputFor(kCubes[3], "-y", 0.01, 0.1));
  const Prediction yellow = learner.predict(inputFor(kCubes[2], "-y", 0.0, 0.1));
  EXPECT_NEAR(blue.mean.dx, 0.0, 0.005);
  EXPECT_NEAR(yellow.mean.dx, 0.13, 0.015);
  const Prediction red_left = learner.predict(inputFor(kCubes[0], "+x", 0.018, 0.12));
  const Prediction red_right = learner.predict(inputFor(kCubes[0], "+x", -0.018, 0.12));
  EXPECT_LT(red_left.mean.dyaw, -0.1);  // truth: -0.32
  EXPECT_GT(red_right.mean.dyaw, 0.1);
}

TEST(PushLearner, StdIsLargeFarFromDataAndSmallNearIt) {
  // Data only on the -x face with short pushes.
  PushLearner learner;
  learner.addSamples(pushes(150, 21, {"-x"}, 0.02, 0.06));
  const Prediction near = learner.predict(inputFor(kCubes[0], "-x", 0.0, 0.04));
  const Prediction other_side = learner.predict(inputFor(kCubes[0], "+x", 0.0, 0.04));
  const Prediction long_push = learner.predict(inputFor(kCubes[0], "-x", 0.0, 0.15));
  Cube purple{"purple_cube", 300, 0, 0};
  PushInput unseen = inputFor(purple, "-x", 0.0, 0.04);
  const Prediction unseen_object = learner.predict(unseen);
  std::printf("[ measured ] std dx (m): near %.4f, other side %.4f, long push %.4f, unseen hue %.4f (prior %.2f)\n",
              near.std.dx, other_side.std.dx, long_push.std.dx, unseen_object.std.dx, learner.config().prior_std.dx);
  EXPECT_LT(near.std.dx, 0.01);
  for (const Prediction* far : {&other_side, &long_push, &unseen_object}) {
    EXPECT_GT(far->std.dx, 5 * near.std.dx);
    EXPECT_GT(far->std.dx, 0.5 * learner.config().prior_std.dx);
    EXPECT_GT(far->std.dyaw, 5 * near.std.dyaw);
  }
  // The heavy cube's outcome has no noise: near its data the learner is surer than for a noisy light cube.
  const Prediction blue = learner.predict(inputFor(kCubes[3], "-x", 0.0, 0.04));
  EXPECT_LT(blue.std.dx, near.std.dx);
}

TEST(PushLearner, TrainingIsDeterministicAndOrderDefined) {
  const std::vector<PushSample> data = pushes(60, 3);
  PushLearner one_by_one, batch, again;
  for (const auto& s : data) one_by_one.addSample(s.input, s.outcome);
  batch.addSamples(data);
  again.addSamples(data);
  PushLearnerConfig other_seed;
  other_seed.seed = 2;
  PushLearner reseeded(other_seed);
  reseeded.addSamples(data);
  bool seed_matters = false;
  for (const auto& s : pushes(30, 77)) {
    const Prediction a = one_by_one.predict(s.input), b = batch.predict(s.input), c = again.predict(s.input);
    EXPECT_EQ(a.mean.dx, b.mean.dx);
    EXPECT_EQ(a.mean.dyaw, b.mean.dyaw);
    EXPECT_EQ(a.std.dy, b.std.dy);
    EXPECT_EQ(b.mean.dx, c.mean.dx);
    EXPECT_EQ(b.std.dyaw, c.std.dyaw);
    seed_matters = seed_matters || reseeded.predict(s.input).mean.dx != a.mean.dx;
  }
  EXPECT_TRUE(seed_matters);
}

TEST(PushLearner, RetrainingScheduleKeepsTheCostPerSampleBounded) {
  // Not timed: the schedule's shape. A training costs about n log n, so the bound needs strides that grow with n.
  std::size_t trainings = 0, previous = 0;
  for (std::size_t n = 0; n <= 2000; ++n) {
    const std::size_t t = PushLearner::trainedCount(n);
    EXPECT_GE(t, previous) << n;  // monotone
    EXPECT_LE(t, n);
    if (n >= PushLearner::kMinTrainingSamples) EXPECT_LE(n - t, n / 10) << n;  // lags by at most 10 %
    if (n <= PushLearner::kRetrainEveryUpTo && n >= PushLearner::kMinTrainingSamples) EXPECT_EQ(t, n);
    trainings += t != previous;
    previous = t;
  }
  EXPECT_LE(trainings, 100u);  // 648 with the earlier schedule (every sample to 500, then every 10)
  EXPECT_EQ(PushLearner::trainedCount(2), 0u);
  // The learner follows the rule whether samples come one by one or in a batch.
  PushLearner one_by_one, batch;
  const auto data = pushes(90, 4);
  for (const auto& s : data) one_by_one.addSample(s.input, s.outcome);
  batch.addSamples(data);
  EXPECT_EQ(one_by_one.trainedCount(), PushLearner::trainedCount(90));
  EXPECT_EQ(batch.trainedCount(), PushLearner::trainedCount(90));
}

TEST(PushLearner, SaveLoadGivesIdenticalPredictions) {
  PushLearnerConfig config;
  config.one_hot_identity = true;
  config.identities = {"red_cube", "green_cube", "yellow_cube", "blue_cube"};
  config.seed = 0xFFFFFFFFFFFFull;
  PushLearner learner(config);
  learner.addSamples(pushes(80, 8));
  const std::string bytes = learner.save();
  EXPECT_NE(bytes.find(PushLearner::kFormat), std::string::npos);
  std::printf("[ measured ] saved model of 80 samples: %zu bytes\n", bytes.size());

  PushLearner loaded;
  loaded.load(bytes);
  EXPECT_EQ(loaded.sampleCount(), 80u);
  EXPECT_EQ(loaded.config().seed, config.seed);
  EXPECT_TRUE(loaded.config().one_hot_identity);
  for (const auto& s : pushes(20, 123)) {
    const Prediction a = learner.predict(s.input), b = loaded.predict(s.input);
    EXPECT_EQ(a.mean.dx, b.mean.dx);
    EXPECT_EQ(a.mean.dy, b.mean.dy);
    EXPECT_EQ(a.mean.dyaw, b.mean.dyaw);
    EXPECT_EQ(a.std.dx, b.std.dx);
    EXPECT_EQ(a.std.dyaw, b.std.dyaw);
  }
  // Learning goes on after loading exactly as it would have without the round trip.
  const auto more = pushes(5, 321);
  learner.addSamples(more);
  loaded.addSamples(more);
  const PushInput probe = inputFor(kCubes[1], "+y", 0.01, 0.07);
  EXPECT_EQ(learner.predict(probe).mean.dx, loaded.predict(probe).mean.dx);
  // save() keeps the samples' text between calls: saved again after more samples, the bytes are those of a
  // learner that saves once.
  PushLearner fresh(config);
  fresh.addSamples(learner.samples());
  EXPECT_EQ(learner.save(), fresh.save());
  EXPECT_EQ(loaded.save(), fresh.save());
  // Names that YAML or FileStorage would read as structure ('[', '{', ':', quotes) survive the round trip.
  PushLearnerConfig odd_config;
  odd_config.feature_names = {"{hue}", "[size]"};
  odd_config.feature_scales = {{"{hue}", 30.0}};
  PushLearner odd(odd_config);
  std::vector<PushSample> odd_samples = pushes(6, 6);
  for (auto& s : odd_samples) {
    s.input.experiment.object = s.input.object.name = "[odd]: \"cube\" #1";
    s.input.object.extra = {{"{hue}", 1.0}, {"[size]", 0.04}};
  }
  odd.addSamples(odd_samples);
  PushLearner odd_loaded;
  odd_loaded.load(odd.save());
  EXPECT_EQ(odd_loaded.samples().at(0).input.experiment.object, "[odd]: \"cube\" #1");
  EXPECT_EQ(odd_loaded.config().feature_names, odd_config.feature_names);
  EXPECT_EQ(odd_loaded.config().feature_scales, odd_config.feature_scales);
  EXPECT_EQ(odd_loaded.predict(odd_samples[0].input).mean.dx, odd.predict(odd_samples[0].input).mean.dx);
  // An empty learner round-trips too.
  PushLearner empty, empty_loaded;
  empty_loaded.load(empty.save());
  EXPECT_EQ(empty_loaded.sampleCount(), 0u);
}

TEST(PushLearner, MalformedModelBytesAreRefusedAndChangeNothing) {
  PushLearner learner;
  learner.addSamples(pushes(20, 4));
  const std::string bytes = learner.save();
  PushLearner target;
  target.addSamples(pushes(10, 5));
  const PushInput probe = inputFor(kCubes[0], "-x", 0, 0.05);
  const double before = target.predict(probe).mean.dx;

  auto expectRefused = [&](const std::string& bad, const std::string& phrase) {
    try {
      target.load(bad);
      ADD_FAILURE() << "accepted; expected: " << phrase;
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find(phrase), std::string::npos) << e.what();
    }
  };
  expectRefused("", "they are empty");
  expectRefused("\x01\x02 not yaml at all {{{", "model bytes are not a usable PushLearner model");
  expectRefused("%YAML:1.0\n---\nformat: \"something-else/3\"\n", "the format is 'something-else/3'");
  expectRefused(bytes.substr(0, bytes.size() / 2), "model bytes are not a usable PushLearner model");
  std::string tampered = bytes;
  const std::size_t at = tampered.find("outcome: [ ");
  ASSERT_NE(at, std::string::npos);
  tampered.insert(at + 11, "1");  // one outcome changes: retraining no longer matches the fingerprint
  expectRefused(tampered, "predicts differently");
  std::string nan = bytes;
  nan.replace(nan.find("distance: ") + 10, 1, ".nan");
  expectRefused(nan, "model bytes are not a usable PushLearner model");

  EXPECT_EQ(target.sampleCount(), 10u);
  EXPECT_EQ(target.predict(probe).mean.dx, before);
}

TEST(PushLearner, InvalidInputIsRejectedAndChangesNothing) {
  PushLearner learner;
  learner.addSamples(pushes(10, 1));
  PushInput in = inputFor(kCubes[0], "-x", 0.0, 0.05);
  PushInput nan = in;
  nan.experiment.offset = std::nan("");
  EXPECT_THROW(learner.predict(nan), ValidationError);
  EXPECT_THROW(learner.addSample(nan, {0.05, 0, 0}), ValidationError);
  EXPECT_THROW(learner.addSample(in, {std::nan(""), 0, 0}), ValidationError);
  PushInput no_hue = in;
  no_hue.object.extra.erase("hue");
  try {
    learner.addSample(no_hue, {0.05, 0, 0});
    ADD_FAILURE();
  } catch (const ValidationError& e) {
    EXPECT_STREQ(e.what(), "sample.input.object.extra has no feature 'hue'; the learner uses it as an input");
  }
  PushInput wrong_name = in;
  wrong_name.object.name = "blue_cube";
  EXPECT_THROW(learner.addSample(wrong_name, {0.05, 0, 0}), ValidationError);
  PushInput inf_feature = in;
  inf_feature.object.extra["size"] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(learner.predict(inf_feature), ValidationError);
  // A batch with one bad sample adds none of them.
  std::vector<PushSample> batch = pushes(5, 2);
  batch[3].input.experiment.distance = -0.1;
  EXPECT_THROW(learner.addSamples(batch), ValidationError);
  EXPECT_EQ(learner.sampleCount(), 10u);

  PushLearnerConfig bad;
  bad.ensemble_size = 0;
  EXPECT_THROW(PushLearner{bad}, ValidationError);
  bad = {};
  bad.one_hot_identity = true;
  EXPECT_THROW(PushLearner{bad}, ValidationError);
  bad = {};
  bad.prior_std.dx = 0;
  EXPECT_THROW(PushLearner{bad}, ValidationError);
}

TEST(PushLearner, OneHotIdentityAloneAlsoLearns) {
  PushLearnerConfig config;
  config.feature_names.clear();
  config.one_hot_identity = true;
  config.identities = {"red_cube", "green_cube", "yellow_cube", "blue_cube"};
  PushLearner learner(config);
  std::vector<PushSample> data = pushes(150, 9);
  for (auto& s : data) s.input.object.extra.clear();
  learner.addSamples(data);
  PushInput blue = inputFor(kCubes[3], "-x", 0.0, 0.1), red = inputFor(kCubes[0], "-x", 0.0, 0.1);
  blue.object.extra.clear();
  red.object.extra.clear();
  EXPECT_NEAR(learner.predict(blue).mean.dx, 0.0, 0.005);
  EXPECT_NEAR(learner.predict(red).mean.dx, 0.09, 0.012);
}

TEST(PushLearner, DerivesTheRightNotions) {
  const std::vector<PushSample> data = pushes(160, 17);
  const std::vector<Notion> notions = deriveNotions(data);
  for (const auto& n : notions) {
    std::printf("[ measured ] notion %s %s value %.3f confidence %.2f support %d: %s\n", n.subject.c_str(),
                n.predicate.c_str(), n.value, n.confidence, n.support, n.text.c_str());
  }
  const Notion* still = findNotion(notions, "blue_cube", "does_not_move_when_pushed");
  ASSERT_NE(still, nullptr);
  EXPECT_NEAR(still->value, 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(still->confidence, 1.0);
  EXPECT_GE(still->support, 3);
  EXPECT_EQ(still->text.rfind("blue_cube does not move when pushed", 0), 0u);
  EXPECT_EQ(findNotion(notions, "blue_cube", "moves_when_pushed"), nullptr);
  for (const char* light : {"red_cube", "green_cube", "yellow_cube"}) {
    SCOPED_TRACE(light);
    EXPECT_EQ(findNotion(notions, light, "does_not_move_when_pushed"), nullptr);
    const Notion* moves = findNotion(notions, light, "moves_when_pushed");
    ASSERT_NE(moves, nullptr);
    EXPECT_GT(moves->confidence, 0.9);
    const Notion* rotates = findNotion(notions, light, "rotates_when_pushed_off_centre");
    ASSERT_NE(rotates, nullptr);
    EXPECT_LT(rotates->value, -0.5);  // turns away from the contact side
    EXPECT_GE(rotates->confidence, 0.8);
  }
  EXPECT_NEAR(findNotion(notions, "yellow_cube", "moves_when_pushed")->value, 1.3, 0.1);
  EXPECT_NEAR(findNotion(notions, "red_cube", "moves_when_pushed")->value, 0.9, 0.1);
  ASSERT_NE(findNotion(notions, "yellow_cube", "slides_further_than_pushed"), nullptr);
  EXPECT_EQ(findNotion(notions, "red_cube", "slides_further_than_pushed"), nullptr);
  EXPECT_EQ(findNotion(notions, "blue_cube", "rotates_when_pushed_off_centre"), nullptr);

  // Too few pushes: no notion. Centred pushes only: no rotation notion.
  EXPECT_TRUE(deriveNotions(std::vector<PushSample>(data.begin(), data.begin() + 2)).empty());
  std::vector<PushSample> centred = data;
  for (auto& s : centred) {
    s.input.experiment.offset = 0.0;
    s.outcome.dyaw = 0.0;
  }
  EXPECT_EQ(findNotion(deriveNotions(centred), "red_cube", "rotates_when_pushed_off_centre"), nullptr);
  std::vector<PushSample> bad = data;
  bad[4].outcome.dx = std::nan("");
  EXPECT_THROW(deriveNotions(bad), ValidationError);
}
