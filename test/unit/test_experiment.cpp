#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "xpersif/core/common/experiment.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

namespace {
ObjectFeatures pose(double x, double y, double yaw) {
  ObjectFeatures o;
  o.name = "red_cube";
  o.x = x;
  o.y = y;
  o.yaw = yaw;
  return o;
}
}  // namespace

TEST(Experiment, WrapAngleIsHalfOpen) {
  EXPECT_NEAR(wrapAngle(0.5), 0.5, 1e-15);
  EXPECT_NEAR(wrapAngle(2 * M_PI + 0.5), 0.5, 1e-12);
  EXPECT_NEAR(wrapAngle(-2 * M_PI - 0.5), -0.5, 1e-12);
  EXPECT_DOUBLE_EQ(wrapAngle(M_PI), M_PI);
  EXPECT_DOUBLE_EQ(wrapAngle(-M_PI), M_PI);  // (-pi, pi]: -pi becomes pi
  EXPECT_NEAR(wrapAngle(3 * M_PI / 2), -M_PI / 2, 1e-12);
}

TEST(Experiment, PushDirectionIsTheFacesInwardNormal) {
  EXPECT_DOUBLE_EQ(pushAngleInObject("-x"), 0.0);
  EXPECT_DOUBLE_EQ(pushAngleInObject("+x"), M_PI);
  EXPECT_DOUBLE_EQ(pushAngleInObject("-y"), M_PI / 2);
  EXPECT_DOUBLE_EQ(pushAngleInObject("+y"), -M_PI / 2);
  EXPECT_THROW(pushAngleInObject("x"), ValidationError);
}

TEST(Experiment, OutcomeIsInThePushFrame) {
  // Cube at yaw 0 pushed on its -x face moves +x in the world: dx > 0.
  Outcome o = computeOutcome(pose(0, 0, 0), pose(0.05, 0.01, 0.1), "-x");
  EXPECT_NEAR(o.dx, 0.05, 1e-12);
  EXPECT_NEAR(o.dy, 0.01, 1e-12);
  EXPECT_NEAR(o.dyaw, 0.1, 1e-12);
  // Pushed on its +x face: the push goes towards world -x; a world +y drift is to the push's right.
  o = computeOutcome(pose(0, 0, 0), pose(-0.05, 0.01, 0), "+x");
  EXPECT_NEAR(o.dx, 0.05, 1e-12);
  EXPECT_NEAR(o.dy, -0.01, 1e-12);
  // Cube turned by 90 degrees, pushed on its -y face: its +y is world -x.
  o = computeOutcome(pose(1, 1, M_PI / 2), pose(0.96, 1.0, M_PI / 2), "-y");
  EXPECT_NEAR(o.dx, 0.04, 1e-12);
  EXPECT_NEAR(o.dy, 0.0, 1e-12);
  // "+y" face: push towards the cube's -y.
  o = computeOutcome(pose(0, 0, 0), pose(0.0, -0.03, 0), "+y");
  EXPECT_NEAR(o.dx, 0.03, 1e-12);
  EXPECT_NEAR(o.dy, 0.0, 1e-12);
}

TEST(Experiment, OutcomeYawWrapsAround) {
  const Outcome o = computeOutcome(pose(0, 0, M_PI - 0.05), pose(0, 0, -M_PI + 0.05), "-x");
  EXPECT_NEAR(o.dyaw, 0.1, 1e-12);  // not -2pi + 0.1
  const Outcome back = computeOutcome(pose(0, 0, -M_PI + 0.05), pose(0, 0, M_PI - 0.05), "-x");
  EXPECT_NEAR(back.dyaw, -0.1, 1e-12);
  EXPECT_THROW(computeOutcome(pose(0, 0, 0), pose(std::nan(""), 0, 0), "-x"), ValidationError);
}

TEST(Experiment, ChecksNameTheField) {
  Experiment e{"red_cube", "-x", 0.01, 0.1};
  EXPECT_EQ(checkExperiment("e", e), "");
  e.side = "left";
  EXPECT_NE(checkExperiment("e", e).find("e.side"), std::string::npos);
  e = {"red_cube", "-x", 0.03, 0.1};  // the object's own limit is the set-up's to check (test_setup.cpp)
  EXPECT_EQ(checkExperiment("e", e), "");
  e = {"red_cube", "-x", 11, 0.1};
  EXPECT_EQ(checkExperiment("e", e), "e.offset is 11; it must lie in [-10, 10]");
  e = {"red_cube", "-x", 0.0, 0.0};
  EXPECT_EQ(checkExperiment("e", e), "e.distance is 0; it must be greater than zero");
  e = {"", "-x", 0.0, 0.1};
  EXPECT_NE(checkExperiment("e", e).find("e.object is empty"), std::string::npos);
  e = {"red_cube", "-x", 0.0, std::numeric_limits<double>::infinity()};
  EXPECT_EQ(checkExperiment("e", e), "e.distance is +inf; it must be a finite number");
}

TEST(Experiment, FeatureVectorJsonRoundTripsExactly) {
  FeatureVector f;
  f.stamp = 12.345678901234567;
  ObjectFeatures a = pose(0.1, -0.2, 1.0 / 3.0);
  a.extra["hue"] = 120.0;
  a.extra["size"] = 0.04;
  a.extra["we\"ird\\ name\n\t\x01"] = -1e-300;
  ObjectFeatures b = pose(5e300, -0.0, M_PI);
  b.name = "blue \"cube\" \xc3\xa9";  // quotes and UTF-8
  f.objects = {a, b};
  const std::string json = toJson(f);
  const FeatureVector back = featureVectorFromJson(json);
  ASSERT_EQ(back.objects.size(), 2u);
  EXPECT_EQ(back.stamp, f.stamp);
  EXPECT_EQ(back.objects[0].name, "red_cube");
  EXPECT_EQ(back.objects[0].yaw, 1.0 / 3.0);
  EXPECT_EQ(back.objects[0].extra, a.extra);
  EXPECT_EQ(back.objects[1].name, b.name);
  EXPECT_EQ(back.objects[1].x, 5e300);
  EXPECT_EQ(toJson(back), json);
  ASSERT_NE(back.find("red_cube"), nullptr);
  EXPECT_EQ(back.find("green_cube"), nullptr);
}

TEST(Experiment, JsonParserAcceptsJsonAndRejectsTheRest) {
  const FeatureVector f = featureVectorFromJson(
      " { \"objects\" : [ { \"yaw\": -1.5E-1, \"name\": \"\\u00e9\\ud83d\\ude00\\/\", \"x\": 0, \"y\": 2 } ],"
      " \"stamp\": 3 } ");
  ASSERT_EQ(f.objects.size(), 1u);
  EXPECT_EQ(f.objects[0].name, "\xc3\xa9\xf0\x9f\x98\x80/");
  EXPECT_DOUBLE_EQ(f.objects[0].yaw, -0.15);
  EXPECT_DOUBLE_EQ(f.stamp, 3.0);

  for (const char* bad : {"", "{", "[]", "{\"objects\":[}", "{\"objects\":[]} x", "{\"objects\":[{\"x\":1}]}",
                          "{\"objects\":[{\"name\":\"a\",\"x\":NaN}]}", "{\"objects\":[{\"name\":\"a\",\"x\":1e999}]}",
                          "{\"objects\":[{\"name\":\"a\\q\"}]}", "{\"objects\":[{\"name\":\"\\ud800\"}]}",
                          "{\"objects\":[{\"name\":\"a\",\"x\":01}]}", "{\"stamp\":1}", "{\"objects\":[], \"z\":1}",
                          "{\"objects\":[{\"name\":\"a\"},{\"name\":\"a\"}]}", "\"objects\""}) {
    EXPECT_THROW(featureVectorFromJson(bad), ValidationError) << bad;
  }
  try {
    featureVectorFromJson("{\"objects\":[}");
    FAIL();
  } catch (const ValidationError& e) {
    EXPECT_NE(std::string(e.what()).find("at character 12"), std::string::npos) << e.what();
  }
  // Deep nesting is refused, not a stack overflow.
  EXPECT_THROW(featureVectorFromJson(std::string(100000, '[')), ValidationError);
  FeatureVector nan;
  nan.objects.push_back(pose(std::nan(""), 0, 0));
  EXPECT_THROW(toJson(nan), ValidationError);
}
