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

TEST(Validation, ShortenedTextKeepsItsBeginningAndEnd) {
  EXPECT_EQ(shortenText("short enough", 12), "short enough");
  const std::string reason = "robot_model is in ERROR: " + std::string(5000, 'x') + " after 2 attempts";
  const std::string shortened = shortenText(reason, 4096);
  EXPECT_LE(shortened.size(), 4096u);
  EXPECT_EQ(checkMaxLength("reason", shortened, 4096), "");
  EXPECT_EQ(shortened.rfind("robot_model is in ERROR: xxx", 0), 0u) << "the cause, at the beginning, is kept";
  EXPECT_EQ(shortened.substr(shortened.size() - 16), "after 2 attempts") << shortened;
  // What is said to be left out is what is missing.
  const auto at = shortened.find(" [... ");
  ASSERT_NE(at, std::string::npos);
  EXPECT_NE(shortened.find(" bytes left out ...] ", at), std::string::npos) << "the count is of bytes and says so";
  const std::size_t left_out = std::stoul(shortened.substr(at + 6));
  const std::size_t marker = shortened.find("...] ", at) + 5 - at;
  EXPECT_EQ(shortened.size() - marker + left_out, reason.size());
  // Never between the bytes of one character: 'é' is two bytes, so any cut through them would show.
  std::string accents;
  for (int i = 0; i < 3000; ++i) accents += "\xc3\xa9";
  for (std::size_t max : {4096u, 4097u, 100u, 101u, 9u}) {
    const std::string cut = shortenText(accents, max);
    EXPECT_LE(cut.size(), max);
    std::size_t pairs = 0;
    for (std::size_t i = 0; i < cut.size(); ++i) {
      if (static_cast<unsigned char>(cut[i]) == 0xc3) {
        ASSERT_LT(i + 1, cut.size()) << "a character cut in two at " << max;
        EXPECT_EQ(static_cast<unsigned char>(cut[i + 1]), 0xa9);
        ++pairs;
      } else if (static_cast<unsigned char>(cut[i]) == 0xa9) {
        EXPECT_TRUE(i > 0 && static_cast<unsigned char>(cut[i - 1]) == 0xc3) << "a character cut in two at " << max;
      }
    }
    EXPECT_GT(pairs, 0u);
  }
}

TEST(Validation, StringsAndIdentifiers) {
  EXPECT_EQ(checkMaxLength("label", std::string(10, 'a'), 10), "");
  EXPECT_EQ(checkMaxLength("label", std::string(11, 'a'), 10), "label is 11 bytes long; at most 10 are allowed");
  EXPECT_EQ(checkIdentifier("name", "loop/counter_1"), "");
  EXPECT_EQ(checkIdentifier("name", ""), "name is empty; a name is required");
  EXPECT_NE(checkIdentifier("name", "bad name").find("contains ' '"), std::string::npos);
  EXPECT_NE(checkIdentifier("name", std::string(200, 'a')).find("at most 128"), std::string::npos);
}
