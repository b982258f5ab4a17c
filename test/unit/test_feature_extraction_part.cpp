// FEATUREEXTRACTION's part tells a refusal from a wait by its health code (issue 36, item 4): a scene it cannot
// perceive is HEALTH_ERROR with the sentence, which the aggregate's status carries for LOOPMODEL to name. No roscore.
#include <gtest/gtest.h>

#include "xpersif/perception/feature_extraction_part.h"

using namespace xpersif;

namespace {

core::CameraModel camera() {
  core::CameraModel c;
  c.name = "overhead";
  c.width = 64;
  c.height = 48;
  c.fx = c.fy = 50;
  c.cx = 32;
  c.cy = 24;
  return c;
}

struct Waiting : ComponentPart {
  Waiting() : ComponentPart("waiting") {}
  std::string problem() const override { return "waiting for the scene"; }
};

}  // namespace

TEST(FeatureExtractionPart, ARefusedSceneIsAnErrorWithItsSentence) {
  FeatureExtractionPart part;
  core::SceneDescription scene;
  scene.objects = {"grey_block"};  // names no node: the extractor cannot be built
  part.setCamera(scene, camera());
  EXPECT_FALSE(part.ready());
  const auto [health, message] = part.diagnose();
  EXPECT_EQ(health, ComponentStatus::HEALTH_ERROR);
  EXPECT_EQ(message, "cannot extract features from camera 'overhead': scene object 'grey_block' names no node of "
                     "the scene");
  EXPECT_EQ(part.problem(), message);
}

TEST(FeatureExtractionPart, AnAcceptedSceneClearsTheRefusal) {
  FeatureExtractionPart part;
  core::SceneDescription scene;
  scene.objects = {"grey_block"};
  part.setCamera(scene, camera());
  scene.objects.clear();
  part.setCamera(scene, camera());
  EXPECT_TRUE(part.ready());
  EXPECT_EQ(part.diagnose().first, ComponentStatus::HEALTH_OK);
  EXPECT_EQ(part.diagnose().second, "");
}

TEST(ComponentPart, AProblemIsAWarningByDefault) {
  const Waiting part;
  EXPECT_EQ(part.diagnose().first, ComponentStatus::HEALTH_WARN);
  EXPECT_EQ(part.diagnose().second, "waiting for the scene");
}
