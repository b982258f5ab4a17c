#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

TEST(Validation, FiniteNumbers) {
  EXPECT_EQ(checkFinite("x", 1.5), "");
  EXPECT_EQ(checkFinite("goal.x", std::nan("")), "goal.x is NaN; it must be a finite number");
  EXPECT_EQ(checkFinite("v", -std::numeric_limits<double>::infinity()), "v is -inf; it must be a finite number");
  EXPECT_THROW(requireFinite("x", std::nan("")), ValidationError);
  EXPECT_NO_THROW(requireFinite("x", 0.0));
}

TEST(Validation, ArraysNameTheBadElement) {
  EXPECT_EQ(checkAllFinite("values", {1, 2, 3}), "");
  EXPECT_EQ(checkAllFinite("values", {1, 2, std::nan(""), 4}),
            "values[2] is NaN; every element must be a finite number");
  EXPECT_EQ(checkMaxSize("values", 5, 5), "");
  EXPECT_EQ(checkMaxSize("values", 5000, 1000), "values has 5000 elements; at most 1000 are allowed");
}

TEST(Validation, Ranges) {
  EXPECT_EQ(checkInRange("d", 0.5, 0, 1), "");
  EXPECT_EQ(checkInRange("d", 2, 0, 1), "d is 2; it must lie in [0, 1]");
  EXPECT_EQ(checkInRange("d", std::nan(""), 0, 1), "d is NaN; it must be a finite number");
  EXPECT_EQ(checkPositive("step", 0), "step is 0; it must be greater than zero");
  EXPECT_EQ(checkPositive("step", 0.1), "");
}

TEST(Validation, HeadingsWithinAThousandRadians) {
  EXPECT_EQ(checkHeading("goal.heading", -3.0), "");
  EXPECT_EQ(checkHeading("goal.heading", 12.5), "") << "a few turns are normalised, not refused";
  EXPECT_EQ(checkHeading("goal.heading", 1e308), "goal.heading is 1e+308; it must lie in [-1000, 1000]");
  EXPECT_EQ(checkHeading("goal.heading", -1e308), "goal.heading is -1e+308; it must lie in [-1000, 1000]");
  EXPECT_EQ(checkHeading("goal.heading", std::nan("")), "goal.heading is NaN; it must be a finite number");
}

TEST(Validation, UnitQuaternions) {
  EXPECT_EQ(checkUnitQuaternion("q", 0, 0, 0, 1), "");
  EXPECT_EQ(checkUnitQuaternion("q", 0, 0, std::sqrt(0.5), std::sqrt(0.5)), "");
  EXPECT_NE(checkUnitQuaternion("q", 0, 0, 0, 0.5).find("q is not a unit quaternion (its norm is 0.5)"),
            std::string::npos);
  EXPECT_EQ(checkUnitQuaternion("q", 0, std::nan(""), 0, 1), "q.y is NaN; it must be a finite number");
  EXPECT_THROW(requireUnitQuaternion("q", 1, 1, 0, 0), ValidationError);
}

TEST(Validation, NamesAndEnums) {
  const std::vector<std::string> cubes = {"red_cube", "blue_cube"};
  EXPECT_EQ(checkKnownName("object", "red_cube", cubes), "");
  EXPECT_EQ(checkKnownName("object", "purple_cube", cubes),
            "object names 'purple_cube', which is unknown; known names: 'red_cube', 'blue_cube'");
  EXPECT_EQ(checkOneOf("side", "top", {"left", "right"}), "side is 'top'; it must be one of 'left', 'right'");
  std::vector<std::string> many;
  for (int i = 0; i < 20; ++i) many.push_back("n" + std::to_string(i));
  EXPECT_NE(checkKnownName("x", "zz", many).find("and 8 more"), std::string::npos);
}

TEST(Validation, StringsAndIdentifiers) {
  EXPECT_EQ(checkMaxLength("label", std::string(10, 'a'), 10), "");
  EXPECT_EQ(checkMaxLength("label", std::string(11, 'a'), 10), "label is 11 characters long; at most 10 are allowed");
  EXPECT_EQ(checkIdentifier("name", "loop/counter_1"), "");
  EXPECT_EQ(checkIdentifier("name", ""), "name is empty; a name is required");
  EXPECT_NE(checkIdentifier("name", "bad name").find("contains ' '"), std::string::npos);
  EXPECT_NE(checkIdentifier("name", std::string(200, 'a')).find("at most 128"), std::string::npos);
}
