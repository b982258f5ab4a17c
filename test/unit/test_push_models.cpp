// Every push model of this package on the PushModel interface (push_model.h): the random-forest ensemble and
// the Gaussian process must both learn, know where they do not know, save and load, and give notions.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <random>

#include "xpersif/core/learning/gaussian_process_push_model.h"
#include "xpersif/core/learning/per_object_push_model.h"
#include "xpersif/core/learning/push_learner.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

namespace {

/// The rule behind the data: the heavy blue cube never moves; the others slide k * distance along the push and
/// turn by c * offset * distance, with a little noise.
struct Cube {
  const char* name;
  double hue, k, c;
};
const Cube kCubes[] = {{"red_cube", 0, 0.9, -150}, {"green_cube", 120, 0.8, -120}, {"blue_cube", 240, 0.0, 0.0}};

PushInput inputFor(const std::string& name, double hue, double size, const std::string& side, double offset,
                   double distance) {
  PushInput in;
  in.experiment = {name, side, offset, distance};
  in.object.name = name;
  in.object.x = 0.1;
  in.object.y = -0.2;
  in.object.extra = {{"hue", hue}, {"size", size}};
  return in;
}

std::vector<PushSample> pushes(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> cube_of(0, 2), side_of(0, 3);
  std::uniform_real_distribution<double> offset_of(-0.015, 0.015), distance_of(0.02, 0.12);
  std::normal_distribution<double> noise(0.0, 1.0);
  const std::vector<std::string> sides{"-x", "+x", "-y", "+y"};
  std::vector<PushSample> samples;
  for (int i = 0; i < n; ++i) {
    const Cube& cube = kCubes[cube_of(rng)];
    const std::string side = sides[side_of(rng)];
    const double offset = offset_of(rng), distance = distance_of(rng);
    Outcome o{cube.k * distance, 0.0, cube.c * offset * distance};
    if (cube.k > 0) {
      o.dx += 0.002 * noise(rng);
      o.dy += 0.002 * noise(rng);
      o.dyaw += 0.01 * noise(rng);
    }
    samples.push_back({inputFor(cube.name, cube.hue, 0.04, side, offset, distance), o});
  }
  return samples;
}

using Factory = std::function<std::unique_ptr<PushModel>()>;

struct Named {
  std::string name;
  Factory make;
};

std::ostream& operator<<(std::ostream& out, const Named& n) { return out << n.name; }

/// Every model as the plugins make them: default-constructed, then configured.
std::vector<Named> models() {
  return {{"random_forest", [] { return std::unique_ptr<PushModel>(std::make_unique<PushLearner>()); }},
          {"per_object_forest", [] { return std::unique_ptr<PushModel>(std::make_unique<PerObjectPushModel>()); }},
          {"gaussian_process",
           [] { return std::unique_ptr<PushModel>(std::make_unique<GaussianProcessPushModel>()); }}};
}

class PushModels : public ::testing::TestWithParam<Named> {
 protected:
  std::unique_ptr<PushModel> configured(PushModelConfig config = {}) {
    auto model = GetParam().make();
    model->configure(config);
    return model;
  }
};

}  // namespace

TEST_P(PushModels, BeforeAnySamplePredictsNoMotionWithThePrior) {
  PushModelConfig config;
  config.prior_std = {0.2, 0.1, 0.7};
  auto model = configured(config);
  const Prediction p = model->predict(inputFor("red_cube", 0, 0.04, "+x", 0.0, 0.05));
  EXPECT_EQ(p.mean.dx, 0.0);
  EXPECT_EQ(p.mean.dyaw, 0.0);
  EXPECT_DOUBLE_EQ(p.std.dx, 0.2);
  EXPECT_DOUBLE_EQ(p.std.dy, 0.1);
  EXPECT_DOUBLE_EQ(p.std.dyaw, 0.7);
}

TEST_P(PushModels, LearnsHowFarACubeSlides) {
  auto model = configured();
  model->addSamples(pushes(150, 1));
  EXPECT_EQ(model->sampleCount(), 150u);
  // On fresh pushes: much better than predicting no motion.
  double model_error = 0, zero_error = 0;
  for (const auto& s : pushes(60, 2)) {
    const Prediction p = model->predict(s.input);
    model_error += std::pow(p.mean.dx - s.outcome.dx, 2);
    zero_error += std::pow(s.outcome.dx, 2);
  }
  EXPECT_LT(std::sqrt(model_error), 0.3 * std::sqrt(zero_error)) << GetParam();
  // The heavy cube stays, the red one slides about 0.9 * 8 cm.
  EXPECT_NEAR(model->predict(inputFor("blue_cube", 240, 0.04, "+x", 0.0, 0.08)).mean.dx, 0.0, 0.01);
  EXPECT_NEAR(model->predict(inputFor("red_cube", 0, 0.04, "+x", 0.0, 0.08)).mean.dx, 0.072, 0.015);
}

TEST_P(PushModels, IsSureNearItsDataAndUnsureFarFromIt) {
  PushModelConfig config;
  auto model = configured(config);
  model->addSamples(pushes(150, 3));
  const Prediction near = model->predict(inputFor("red_cube", 0, 0.04, "+x", 0.0, 0.06));
  // An object unlike every pushed one (another colour, twice the size), pushed further than ever.
  const Prediction far = model->predict(inputFor("purple_cube", 300, 0.08, "+x", 0.0, 0.30));
  EXPECT_LT(near.std.dx, 0.5 * far.std.dx) << GetParam();
  EXPECT_GT(far.std.dx, 0.8 * config.prior_std.dx) << GetParam();
  EXPECT_LT(near.std.dx, 0.5 * config.prior_std.dx) << GetParam();
  EXPECT_GT(near.std.dx, 0.0);
}

TEST_P(PushModels, SavedAndLoadedItPredictsTheSame) {
  auto model = configured();
  model->addSamples(pushes(60, 4));
  const std::string bytes = model->save();
  auto loaded = configured();  // a fresh instance, as GOALDESIGN makes one
  loaded->load(bytes);
  EXPECT_EQ(loaded->sampleCount(), 60u);
  EXPECT_EQ(loaded->format(), model->format());
  for (const auto& s : pushes(10, 5)) {
    const Prediction a = model->predict(s.input), b = loaded->predict(s.input);
    EXPECT_NEAR(a.mean.dx, b.mean.dx, 1e-9);
    EXPECT_NEAR(a.mean.dyaw, b.mean.dyaw, 1e-9);
    EXPECT_NEAR(a.std.dx, b.std.dx, 1e-9);
  }
  EXPECT_EQ(loaded->save(), bytes);
}

TEST_P(PushModels, MalformedBytesAreRefusedAndChangeNothing) {
  auto model = configured();
  model->addSamples(pushes(10, 6));
  for (const std::string bytes : {std::string(), std::string("format: nonsense\n"), std::string("[1, 2"),
                                  model->save().substr(0, model->save().size() / 2)}) {
    EXPECT_THROW(model->load(bytes), ValidationError) << GetParam() << ": " << bytes.substr(0, 40);
    EXPECT_EQ(model->sampleCount(), 10u);
  }
}

TEST_P(PushModels, NotionsSayWhatMovesAndWhatDoesNot) {
  auto model = configured();
  model->addSamples(pushes(60, 7));
  bool blue_still = false, red_moves = false;
  for (const auto& n : model->notions()) {
    blue_still = blue_still || (n.subject == "blue_cube" && n.predicate == "does_not_move_when_pushed");
    red_moves = red_moves || (n.subject == "red_cube" && n.predicate == "moves_when_pushed");
    EXPECT_FALSE(n.subject == "blue_cube" && n.predicate == "moves_when_pushed");
  }
  EXPECT_TRUE(blue_still) << GetParam();
  EXPECT_TRUE(red_moves) << GetParam();
}

TEST_P(PushModels, BadInputIsRefusedAndChangesNothing) {
  auto model = configured();
  model->addSamples(pushes(5, 8));
  std::vector<PushSample> bad = pushes(3, 9);
  bad[1].input.object.extra.erase("hue");
  EXPECT_THROW(model->addSamples(bad), ValidationError);
  bad = pushes(1, 10);
  bad[0].outcome.dx = std::nan("");
  EXPECT_THROW(model->addSamples(bad), ValidationError);
  EXPECT_EQ(model->sampleCount(), 5u);
  PushInput wrong = inputFor("red_cube", 0, 0.04, "+z", 0.0, 0.05);
  EXPECT_THROW(model->predict(wrong), ValidationError);
  EXPECT_THROW(model->check(wrong), ValidationError);
}

TEST_P(PushModels, UnknownOptionsAndBadConfigsAreRefused) {
  auto model = configured();
  model->addSamples(pushes(5, 11));
  PushModelConfig config;
  config.options["no_such_option"] = 1;
  EXPECT_THROW(model->configure(config), ValidationError);
  config.options.clear();
  config.prior_std.dx = -1;
  EXPECT_THROW(model->configure(config), ValidationError);
  EXPECT_EQ(model->sampleCount(), 5u);  // the refused configurations changed nothing
  model->configure(PushModelConfig{});
  EXPECT_EQ(model->sampleCount(), 0u);  // a new configuration starts afresh
}

TEST_P(PushModels, OneByOneOrAllAtOnceGiveTheSameModel) {
  const auto samples = pushes(30, 12);
  auto batch = configured(), single = configured();
  batch->addSamples(samples);
  for (const auto& s : samples) single->addSample(s.input, s.outcome);
  for (const auto& s : pushes(5, 13)) {
    EXPECT_NEAR(batch->predict(s.input).mean.dx, single->predict(s.input).mean.dx, 1e-9) << GetParam();
    EXPECT_NEAR(batch->predict(s.input).std.dx, single->predict(s.input).std.dx, 1e-9) << GetParam();
  }
}

INSTANTIATE_TEST_SUITE_P(All, PushModels, ::testing::ValuesIn(models()),
                         [](const ::testing::TestParamInfo<Named>& info) { return info.param.name; });

TEST(GaussianProcessPushModel, OptionsSetTheKernel) {
  PushModelConfig config;
  config.options = {{"length_scale", 0.5}, {"noise_fraction", 0.2}};
  GaussianProcessPushModel model(config);
  EXPECT_EQ(model.lengthScale(), 0.5);
  EXPECT_EQ(model.noiseFraction(), 0.2);
  // Right on many samples of the same push, the std falls to about the noise: prior * noise_fraction.
  for (int i = 0; i < 20; ++i) model.addSample(inputFor("red_cube", 0, 0.04, "+x", 0.0, 0.05), {0.045, 0, 0});
  const Prediction p = model.predict(inputFor("red_cube", 0, 0.04, "+x", 0.0, 0.05));
  EXPECT_NEAR(p.mean.dx, 0.045, 0.002);
  EXPECT_NEAR(p.std.dx, config.prior_std.dx * 0.2, 0.01 * config.prior_std.dx);
  config.options = {{"noise_fraction", 0.0}};
  EXPECT_THROW(GaussianProcessPushModel{config}, ValidationError);
}

TEST(PushLearner, ItsOptionsAreItsConfig) {
  PushLearnerConfig config;
  config.ensemble_size = 3;
  config.trees_per_member = 5;
  config.novelty_length = 0.7;
  const PushLearnerConfig back = PushLearnerConfig::fromModelConfig(config.toModelConfig());
  EXPECT_EQ(back.ensemble_size, 3);
  EXPECT_EQ(back.trees_per_member, 5);
  EXPECT_EQ(back.novelty_length, 0.7);
  PushModelConfig fractional = config.toModelConfig();
  fractional.options["ensemble_size"] = 2.5;
  EXPECT_THROW(PushLearnerConfig::fromModelConfig(fractional), ValidationError);
}

TEST(PerObjectPushModel, KnowsAnObjectThatNeverMovesFromThreePushesAmongMany) {
  // 60 pushes of the two sliding cubes and 3 of blue_cube, which never moves (the share a design that leaves the
  // trivial object alone gives it): blue's own learner predicts no motion; the shared forest lends it the others'.
  PushModelConfig config;
  config.one_hot_identity = true;
  config.identities = {"red_cube", "green_cube", "blue_cube"};
  std::vector<PushSample> movers, blue;
  for (const auto& s : pushes(200, 21)) {
    auto& to = s.input.experiment.object == "blue_cube" ? blue : movers;
    if ((&to == &movers && movers.size() < 60) || (&to == &blue && blue.size() < 3)) to.push_back(s);
  }
  ASSERT_EQ(blue.size(), 3u);
  PerObjectPushModel per_object(PushLearnerConfig::fromModelConfig(config));
  PushLearner shared(PushLearnerConfig::fromModelConfig(config));
  per_object.addSamples(movers);
  per_object.addSamples({blue[0], blue[1]});
  EXPECT_FALSE(per_object.ownsPrediction("blue_cube"));  // two pushes: the shared model still speaks for it
  per_object.addSamples({blue[2]});
  EXPECT_TRUE(per_object.ownsPrediction("blue_cube"));
  EXPECT_TRUE(per_object.ownsPrediction("red_cube"));
  shared.addSamples(movers);
  shared.addSamples(blue);
  double per_object_error = 0, shared_error = 0;
  for (const auto& s : pushes(200, 22)) {
    if (s.input.experiment.object != "blue_cube") continue;
    per_object_error = std::max(per_object_error, std::abs(per_object.predict(s.input).mean.dx));
    shared_error = std::max(shared_error, std::abs(shared.predict(s.input).mean.dx));
  }
  EXPECT_LT(per_object_error, 0.001);
  EXPECT_GT(shared_error, 5 * per_object_error + 0.002) << "the shared forest learned blue too: the test shows nothing";
  // Another model's bytes are refused and change nothing.
  const std::size_t before = per_object.sampleCount();
  EXPECT_THROW(per_object.load(shared.save()), ValidationError);
  EXPECT_EQ(per_object.sampleCount(), before);
  EXPECT_TRUE(per_object.ownsPrediction("blue_cube"));
}
