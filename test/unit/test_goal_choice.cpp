// Reaching a goal with a learned model (goal_choice.h): the push chosen counts the model's uncertainty, and an
// object's pushes are judged by how closely the model predicts where it ends.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "xpersif/core/learning/goal_choice.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

namespace {

/// A model by rule: the object slides `ratio` times the distance along the push; pushes on `unsure_side` are
/// predicted with a std of `unsure_std` (dx and dy), the others with `sure_std`.
class RuleModel : public PushModel {
 public:
  double ratio = 1.0, sure_std = 0.002, unsure_std = 0.03;
  std::string unsure_side = "-y";
  void configure(const PushModelConfig&) override {}
  void check(const PushInput&, const std::string&) const override {}
  void addSamples(const std::vector<PushSample>&) override {}
  Prediction predict(const PushInput& input) const override {
    const double std = input.experiment.side == unsure_side ? unsure_std : sure_std;
    return {{ratio * input.experiment.distance, 0, 0}, {std, std, 0.1}};
  }
  std::size_t sampleCount() const override { return 1; }
  const std::vector<PushSample>& samples() const override { return none_; }
  std::string save() const override { return ""; }
  void load(const std::string&) override {}
  std::string format() const override { return "rule/1"; }

 private:
  std::vector<PushSample> none_;
};

ObjectFeatures at(double x, double y, double yaw = 0) {
  ObjectFeatures o;
  o.name = "box";
  o.x = x;
  o.y = y;
  o.yaw = yaw;
  return o;
}

}  // namespace

TEST(GoalChoice, TheNearestEndWinsAmongEquallySurePushes) {
  RuleModel model;
  const std::vector<Experiment> candidates{{"box", "-x", 0, 0.09}, {"box", "-x", 0, 0.10}};
  const PushChoice c = bestPush(model, at(0, 0), 0.10, 0, candidates, 1.0);  // "-x" pushes along +x
  EXPECT_DOUBLE_EQ(c.experiment.distance, 0.10);
  EXPECT_NEAR(c.expected_error, 0, 1e-12);
  EXPECT_NEAR(c.spread, std::hypot(0.002, 0.002), 1e-12);
}

TEST(GoalChoice, TheSurePushBeatsOneThatOnlyMightLandCloser) {
  RuleModel model;
  const ObjectFeatures box = at(0, 0);
  // Target 5 cm along +y. A "-y" push of 5 cm ends on it, with a std of unsure_std in dx and dy; a sure "-x" push
  // of 2.5 cm ends at (0.025, 0), 0.0559 m off: expected squared distance 0.003125 + 8e-6.
  const std::vector<Experiment> two{{"box", "-y", 0, 0.05}, {"box", "-x", 0, 0.025}};
  EXPECT_EQ(bestPush(model, box, 0.0, 0.05, two, 0.0).experiment.side, "-y");  // the mean alone
  EXPECT_EQ(bestPush(model, box, 0.0, 0.05, two, 1.0).experiment.side, "-y");  // 2 * 0.03^2 = 0.0018 < 0.0031
  model.unsure_std = 0.05;                                                     // 2 * 0.05^2 = 0.005 > 0.0031
  const PushChoice c = bestPush(model, box, 0.0, 0.05, two, 1.0);
  EXPECT_EQ(c.experiment.side, "-x");
  EXPECT_NEAR(c.expected_error, std::hypot(0.025, 0.05), 1e-12);
  EXPECT_EQ(bestPush(model, box, 0.0, 0.05, two, 0.0).experiment.side, "-y");  // still, by the mean alone
}

TEST(GoalChoice, ThePushFrameTurnsWithTheObject) {
  RuleModel model;
  model.ratio = 0.5;
  const ObjectFeatures box = at(0.1, 0.1, M_PI / 2);  // its +x axis is the world's +y
  const PushChoice c = bestPush(model, box, 0.1, 0.15, {{"box", "-x", 0, 0.1}, {"box", "+x", 0, 0.1}}, 1.0);
  EXPECT_EQ(c.experiment.side, "-x");  // along the object's +x: the world's +y, 5 cm
  EXPECT_NEAR(c.expected_error, 0, 1e-12);
}

TEST(GoalChoice, BadArgumentsAreRefusedWithASentence) {
  RuleModel model;
  EXPECT_THROW(bestPush(model, at(0, 0), 0.1, 0, {}, 1.0), ValidationError);
  EXPECT_THROW(bestPush(model, at(0, 0), 0.1, 0, {{"box", "-x", 0, 0.1}}, -1.0), ValidationError);
  EXPECT_THROW(bestPush(model, at(0, 0), 0.1, 0, {{"box", "-x", 0, 0.1}}, NAN), ValidationError);
}

TEST(GoalChoice, PredictedSpreadIsTheMedianOverThePushes) {
  RuleModel model;
  const ObjectFeatures box = at(0, 0);
  // Two sure sides, one unsure: the median is a sure one's spread.
  const std::vector<Experiment> pushes{{"box", "-x", 0, 0.1}, {"box", "+x", 0, 0.1}, {"box", "-y", 0, 0.1}};
  EXPECT_NEAR(predictedSpread(model, box, pushes), std::hypot(0.002, 0.002), 1e-12);
  model.sure_std = 0.04;  // now the unsure side is the tighter one; the median is 0.04's
  EXPECT_NEAR(predictedSpread(model, box, pushes), std::hypot(0.04, 0.04), 1e-12);
  EXPECT_TRUE(std::isinf(predictedSpread(model, box, {})));
}
