#include <gtest/gtest.h>

#include "xpersif/core/common/contract.h"

using namespace xpersif::core;

TEST(Literal, ParsesAndPrints) {
  Literal l = parseLiteral("  not at( robot , ?pose )");
  EXPECT_TRUE(l.negated);
  EXPECT_EQ(l.predicate, "at");
  ASSERT_EQ(l.arguments.size(), 2u);
  EXPECT_EQ(l.arguments[1], "?pose");
  EXPECT_EQ(l.toString(), "not at(robot, ?pose)");
  EXPECT_EQ(parseLiteral("idle()").arguments.size(), 0u);
}

TEST(Literal, ATupleIsOneArgument) {
  const Literal l = parseLiteral("robot_at(robot,(0.100,  -0.2 , 1.5))");
  ASSERT_EQ(l.arguments.size(), 2u);
  EXPECT_EQ(l.arguments[1], "(0.100, -0.2, 1.5)");
  EXPECT_EQ(l.toString(), "robot_at(robot, (0.100, -0.2, 1.5))");
  EXPECT_EQ(ground("robot_at(robot, ?pose)", {{"?pose", "(0.1, 0.2, 0)"}}), "robot_at(robot, (0.1, 0.2, 0))");
  EXPECT_THROW(parseLiteral("at(a, (b, (c)))"), ContractError);
  EXPECT_THROW(parseLiteral("at(a, (b, c)"), ContractError);
  EXPECT_THROW(parseLiteral("at(a, b))"), ContractError);
  EXPECT_THROW(parseLiteral("at(a, (b,,c))"), ContractError);
  EXPECT_THROW(parseLiteral("at(a, ())"), ContractError);
  EXPECT_THROW(parseLiteral("at(a, (b) c)"), ContractError);
}

TEST(Literal, RejectsMalformedText) {
  EXPECT_THROW(parseLiteral("at robot"), ContractError);
  EXPECT_THROW(parseLiteral("(a)"), ContractError);
  EXPECT_THROW(parseLiteral("at(a,,b)"), ContractError);
  EXPECT_THROW(parseLiteral("at(a b)"), ContractError);
}

TEST(Literal, GroundingReplacesBoundParametersOnly) {
  EXPECT_EQ(ground("at(?object, ?place)", {{"?object", "red_cube"}}), "at(red_cube, ?place)");
  EXPECT_EQ(ground(std::vector<std::string>{"not free(?x)", "held(?x)"}, {{"?x", "c1"}}),
            (std::vector<std::string>{"not free(c1)", "held(c1)"}));
}

Contract pushContract() {
  Contract c;
  c.name = "push";
  c.kind = Contract::Kind::Command;
  c.parameters = {"?object", "?distance"};
  c.preconditions = {{"known(?object)", "the object must be known"},
                     {"positive(?distance)", "the distance must be positive"}};
  c.effects = {"moved(?object)"};
  return c;
}

TEST(Contract, ValidationCatchesDeclarationMistakes) {
  EXPECT_NO_THROW(pushContract().validate());
  Contract c = pushContract();
  c.effects.push_back("at(?nowhere)");
  EXPECT_THROW(c.validate(), ContractError);
  c = pushContract();
  c.parameters.push_back("distance");
  EXPECT_THROW(c.validate(), ContractError);
  c = pushContract();
  c.preconditions[0].description = "";
  EXPECT_THROW(c.validate(), ContractError);
}

struct PushGoal {
  std::string object;
  double distance;
};

TEST(ContractChecker, ReportsTheFirstUnmetPreconditionByName) {
  ContractChecker<PushGoal> checker(pushContract());
  checker
      .bind([](const PushGoal& g) { return Bindings{{"?object", g.object}, {"?distance", std::to_string(g.distance)}}; })
      .check("known(?object)", [](const PushGoal& g) { return g.object == "red_cube" ? "" : "no such object"; })
      .check("positive(?distance)", [](const PushGoal& g) { return g.distance > 0 ? "" : "it is not"; });
  EXPECT_EQ(checker.firstUnmet({"red_cube", 0.1}), "");
  EXPECT_EQ(checker.firstUnmet({"green_cube", -1}),
            "precondition 'known(green_cube)' (the object must be known) is not met: no such object");
  EXPECT_NE(checker.firstUnmet({"red_cube", -1}).find("'positive(-1.000000)'"), std::string::npos);
  EXPECT_EQ(checker.groundEffects({"red_cube", 0.1}), std::vector<std::string>{"moved(red_cube)"});
}

TEST(ContractChecker, CheckOfAnUndeclaredPreconditionIsAProgrammingError) {
  ContractChecker<PushGoal> checker(pushContract());
  EXPECT_THROW(checker.check("reachable(?object)", [](const PushGoal&) { return ""; }), ContractError);
}
