// Parameters declared once (core/parameters.h): the table, its checks, "did you mean" and the reference.
#include <gtest/gtest.h>

#include <cmath>

#include "xpersif/core/common/parameters.h"

using namespace xpersif::core;

namespace {
ParameterTable example() {
  return ParameterTable("example", {intParameter("seed", 1, 0, 100, "the seed"),
                                    numberParameter("temperature", 0.1, 0.001, 100.0, "softmax temperature"),
                                    textParameter("mode", "fast", "how", {"fast", "slow"}),
                                    numbersParameter("offsets", {-0.5, 0.5}, -1.0, 1.0, "fractions"),
                                    namesParameter("objects", {}, 2, "names")});
}
}  // namespace

TEST(Parameters, ValuesAreCheckedAgainstTheirDeclaration) {
  const ParameterTable table = example();
  EXPECT_EQ(checkParameter(table.at("seed"), 7), "");
  EXPECT_EQ(checkParameter(table.at("seed"), 101), "~seed is 101; it must lie in [0, 100]");
  EXPECT_EQ(checkParameter(table.at("temperature"), std::nan("")), "~temperature is NaN; it must be a finite number");
  EXPECT_EQ(checkParameter(table.at("mode"), std::string("slow")), "");
  EXPECT_NE(checkParameter(table.at("mode"), std::string("medium")).find("~mode is 'medium'; it must be one of"),
            std::string::npos);
  EXPECT_EQ(checkParameter(table.at("offsets"), std::vector<double>{0.0, 2.0}), "~offsets[1] is 2; it must lie in [-1, 1]");
  EXPECT_NE(checkParameter(table.at("objects"), std::vector<std::string>{"a", "b", "c"}), "");
  EXPECT_EQ(checkParameter(table.at("seed"), 101, "~part/seed"), "~part/seed is 101; it must lie in [0, 100]");
}

TEST(Parameters, ReadingAnUndeclaredNameIsAProgrammingError) {
  const ParameterTable table = example();
  EXPECT_THROW(table.at("sead"), std::logic_error);
  EXPECT_EQ(table.find("sead"), nullptr);
  EXPECT_THROW(ParameterTable("twice", {flagParameter("a", true, ""), flagParameter("a", false, "")}), std::logic_error);
}

TEST(Parameters, UndeclaredNamesAreNamedWithTheClosestDeclaredOne) {
  ParameterTable table = example();
  table.include(ParameterTable("part", {numberParameter("min_blob_pixels", 6, 1, 1e9, "")}), "feature_extraction/");
  const auto unknown = table.undeclared({"seed", "tempreature", "feature_extraction", "colour_space"});
  ASSERT_EQ(unknown.size(), 2u);
  EXPECT_EQ(unknown[0], "~tempreature (did you mean ~temperature?)");
  EXPECT_EQ(unknown[1], "~colour_space");  // nothing near: no guess
  EXPECT_EQ(editDistance("kitten", "sitting"), 3u);
}

TEST(Parameters, TheReferenceListsEveryParameterWithTypeDefaultAndRange) {
  ParameterTable table = example();
  table.include(ParameterTable("derived", {derivedParameter(ParameterSpec::Type::Double, "max_distance", "A / 4", 0, 1,
                                                            "m | longest")}));
  const std::string text = table.markdown();
  EXPECT_NE(text.find("| `~seed` | int | 1 | 0 .. 100 | the seed |"), std::string::npos) << text;
  EXPECT_NE(text.find("| `~mode` | string | fast | one of fast, slow | how |"), std::string::npos) << text;
  EXPECT_NE(text.find("| `~offsets` | number list | [-0.5, 0.5] | -1 .. 1 | fractions |"), std::string::npos) << text;
  EXPECT_NE(text.find("| `~max_distance` | double | A / 4 | 0 .. 1 | m \\| longest |"), std::string::npos) << text;
}
