// core::Invocation: the values a caller binds to a contract's parameters as text, and the sentences that name
// the parameter when one is missing, open, not a number, not finite, out of range, unknown or too long.
#include <gtest/gtest.h>

#include <string>

#include "xpersif/core/common/invocation.h"
#include "xpersif/core/common/validation.h"

using xpersif::core::Invocation;
using xpersif::core::ValidationError;

namespace {

/// The sentence a call throws ("" when it does not throw).
template <class F>
std::string sentence(F&& f) {
  try {
    f();
  } catch (const ValidationError& e) {
    return e.what();
  }
  return "";
}

Invocation push(std::vector<std::string> parameters, std::vector<std::string> values) {
  return Invocation("push", {"?object", "?side", "?offset", "?distance"}, std::move(parameters), std::move(values),
                    {"pose_source", "max_age"}, {"observation", "0.5"});
}

}  // namespace

TEST(Invocation, ReadsTextNumbersAndPoses) {
  const Invocation i = push({"?object", "?offset"}, {"red_cube", " -0.01 "});
  EXPECT_EQ(i.text("?object"), "red_cube");
  EXPECT_DOUBLE_EQ(i.number("?offset"), -0.01);
  EXPECT_TRUE(i.has("?object"));
  EXPECT_FALSE(i.has("?side"));
  const Invocation go("go_to_pose", {"?pose"}, {"?pose"}, {"(0.1, -0.2, 1.5)"});
  EXPECT_DOUBLE_EQ(go.pose("?pose").x, 0.1);
  EXPECT_DOUBLE_EQ(go.pose("?pose").y, -0.2);
  EXPECT_DOUBLE_EQ(go.pose("?pose").yaw, 1.5);
}

TEST(Invocation, SettingsAreOptionalAndChecked) {
  const Invocation i = push({}, {});
  EXPECT_EQ(i.setting("pose_source", ""), "observation");
  EXPECT_EQ(i.setting("colour", "none"), "none");  // not given: the fallback
  EXPECT_DOUBLE_EQ(i.settingNumber("max_age", 0.0, 0.0, 10.0), 0.5);
  EXPECT_DOUBLE_EQ(i.settingNumber("timeout", 3.0, 0.0, 10.0), 3.0);
  const Invocation bad("get_features", {}, {}, {}, {"max_age"}, {"nan"});
  EXPECT_NE(sentence([&] { bad.settingNumber("max_age", 0.0, 0.0, 10.0); }).find("max_age"), std::string::npos);
  const Invocation big("get_features", {}, {}, {}, {"max_age"}, {"1e9"});
  EXPECT_NE(sentence([&] { big.settingNumber("max_age", 0.0, 0.0, 10.0); }).find("max_age"), std::string::npos);
}

TEST(Invocation, EveryBadValueIsASentenceNamingTheParameter) {
  struct Case {
    std::string value;
    std::string says;
  };
  for (const Case& c : std::vector<Case>{{"nan", "finite"},
                                         {"inf", "finite"},
                                         {"-inf", "finite"},
                                         {"1e999", "range"},
                                         {"0.01x", "not a number"},
                                         {"", "empty"},
                                         {"?offset", "open"},
                                         {"far", "not a number"}}) {
    const Invocation i = push({"?offset"}, {c.value});
    const std::string why = sentence([&] { i.number("?offset"); });
    EXPECT_NE(why.find("?offset"), std::string::npos) << c.value << ": " << why;
    EXPECT_NE(why.find(c.says), std::string::npos) << c.value << ": " << why;
  }
  const Invocation i = push({"?distance"}, {"5"});
  const std::string range = sentence([&] { i.number("?distance", 0.0, 1.0); });
  EXPECT_NE(range.find("?distance"), std::string::npos) << range;
  EXPECT_NE(sentence([&] { i.text("?object"); }).find("?object"), std::string::npos);  // needed, not given
  const Invocation go("go_to_pose", {"?pose"}, {"?pose"}, {"(0.1, 0.2)"});
  EXPECT_NE(sentence([&] { go.pose("?pose"); }).find("?pose"), std::string::npos);
  const Invocation spin("go_to_pose", {"?pose"}, {"?pose"}, {"(0, 0, 1e6)"});
  EXPECT_NE(sentence([&] { spin.pose("?pose"); }).find("?pose yaw"), std::string::npos);
}

TEST(Invocation, MalformedBindingsAreRefusedWhenMade) {
  const std::vector<std::string> declared{"?object", "?side"};
  EXPECT_NE(sentence([&] { Invocation("push", declared, {"?colour"}, {"red"}); }).find("?colour"), std::string::npos);
  EXPECT_NE(sentence([&] { Invocation("push", declared, {"?object"}, {}); }).find("values"), std::string::npos);
  EXPECT_NE(sentence([&] { Invocation("push", declared, {"?object", "?object"}, {"a", "b"}); }).find("twice"),
            std::string::npos);
  EXPECT_NE(sentence([&] { Invocation("push", declared, {"?object"}, {std::string(5000, 'x')}); }).find("?object"),
            std::string::npos);
  std::vector<std::string> many(100, "x");
  EXPECT_NE(sentence([&] { Invocation("push", declared, {}, {}, many, many); }), "");
  EXPECT_EQ(sentence([&] { Invocation("push", declared, {"?object"}, {"red_cube"}); }), "");
}
