// Algorithms by name through pluginlib, as the components load them (AlgorithmLoader, algorithm_loader.h):
// this package's push models, designs and searches, and a plan search from another package
// (test/example_plugin_package, which depends on xpersif and exports its own XML; xpersif's package.xml does not
// mention it). No roscore: pluginlib finds plugins through rospack and the devel space's lib directory.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <set>

#include "xpersif/core/planning/experiment_design.h"
#include "xpersif/core/planning/plan_search.h"
#include "xpersif/core/learning/push_model.h"
#include "xpersif/core/common/random_stream.h"
#include "xpersif/ros/algorithm_loader.h"
#include "search_spaces.h"

using namespace xpersif;
using namespace xpersif::core;

namespace {

/// Put the other package on the package path, as installing it would (before the first loader crawls).
class OtherPackageOnThePath : public ::testing::Environment {
 public:
  void SetUp() override {
    const char* old = std::getenv("ROS_PACKAGE_PATH");
    std::string path = std::string(XPERSIF_SOURCE_DIR) + "/test/example_plugin_package";
    if (old && *old) path += std::string(":") + old;
    setenv("ROS_PACKAGE_PATH", path.c_str(), 1);
  }
};
const auto* const kEnvironment = ::testing::AddGlobalTestEnvironment(new OtherPackageOnThePath);

bool contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

PushInput input(const std::string& object, double distance) {
  PushInput in;
  in.experiment = {object, "+x", 0.0, distance};
  in.object.name = object;
  in.object.extra = {{"hue", 10}, {"size", 0.04}};
  return in;
}


}  // namespace

TEST(AlgorithmPlugins, PushModelsLoadByNameAndLearn) {
  AlgorithmLoader<PushModel> loader("xpersif::core::PushModel", "push model");
  const auto declared = loader.declared();
  ASSERT_TRUE(contains(declared, "random_forest")) << joinWithCommas(declared);
  ASSERT_TRUE(contains(declared, "gaussian_process")) << joinWithCommas(declared);
  ASSERT_TRUE(contains(declared, "per_object_forest")) << joinWithCommas(declared);
  std::set<std::string> formats;
  for (const std::string type : {"random_forest", "gaussian_process", "per_object_forest"}) {
    auto model = loader.create("~learner_type", type);
    model->configure(PushModelConfig{});
    for (int i = 0; i < 6; ++i) model->addSample(input("cube", 0.02 + 0.01 * i), {0.02 + 0.01 * i, 0, 0});
    EXPECT_EQ(model->sampleCount(), 6u) << type;
    EXPECT_GT(model->predict(input("cube", 0.05)).mean.dx, 0.02) << type;
    formats.insert(model->format());
  }
  EXPECT_EQ(formats.size(), 3u);  // GOALDESIGN tells them apart by format
}

TEST(AlgorithmPlugins, DesignsLoadByNameAndKeepTheirSeededStreams) {
  AlgorithmLoader<ExperimentDesign> loader("xpersif::core::ExperimentDesign", "experiment design");
  DesignContext context;
  context.objects = {{"a", true, Footprint::rectangle(0.04, 0.04)}, {"b", true, Footprint::rectangle(0.05, 0.05)}};
  context.curiosity = [](const ExperimentChoice& c) { return c.distance; };
  for (const auto& name : designNames()) {
    ASSERT_TRUE(contains(loader.declared(), name)) << name;
    auto plugin = loader.create("~design", name);
    plugin->initialize(5, DesignOptions{});
    auto direct = makeDesign(name, 5);
    for (std::uint64_t k = 0; k < 5; ++k) {
      context.stream = streamSeed(9, 1, k, StreamPurpose::Design);
      context.history_count = k;
      EXPECT_EQ(plugin->next(context).toString(), direct->next(context).toString()) << name << " #" << k;
    }
  }
}

TEST(AlgorithmPlugins, AnotherPackagesSearchLoadsByNameWithoutChangesHere) {
  AlgorithmLoader<PlanSearch> loader("xpersif::core::PlanSearch", "plan search");
  const auto declared = loader.declared();
  for (const std::string name : {"breadth_first", "greedy", "xpersif_example_plugins/iterative_deepening"}) {
    ASSERT_TRUE(contains(declared, name)) << name << " not in " << joinWithCommas(declared);
  }
  const SearchSpace space = core::testing_spaces::handSpace(3);
  const SearchResult shortest = loader.create("~search_type", "breadth_first")->search(space);
  auto other = loader.create("~search_type", "xpersif_example_plugins/iterative_deepening");
  EXPECT_NE(other->description().find("iterative-deepening"), std::string::npos);
  const SearchResult found = other->search(space);
  ASSERT_EQ(found.outcome, SearchResult::Outcome::Found);
  EXPECT_EQ(core::testing_spaces::check(space, found.plan), "");
  EXPECT_EQ(found.plan.size(), shortest.plan.size());  // it promises shortest plans too
}

TEST(AlgorithmPlugins, AnUnknownNameIsRefusedWithTheDeclaredClasses) {
  AlgorithmLoader<PlanSearch> loader("xpersif::core::PlanSearch", "plan search");
  const std::string why = loader.whyNot("~search_type", "dijkstra");
  EXPECT_NE(why.find("~search_type is 'dijkstra'"), std::string::npos) << why;
  EXPECT_NE(why.find("breadth_first, greedy"), std::string::npos) << why;
  EXPECT_EQ(loader.whyNot("~search_type", "greedy"), "");
  EXPECT_THROW(loader.create("~search_type", "dijkstra"), ValidationError);
  AlgorithmLoader<PushModel> models("xpersif::core::PushModel", "push model");
  EXPECT_THROW(models.create("~learner_type", "breadth_first"), ValidationError);  // another kind's class
}
