#include "parameter_catalogue.h"

#include <map>

#include "xpersif/camera/sim_camera.h"
#include "xpersif/cognition/knowledge_base_component.h"
#include "xpersif/cognition/machine_learning.h"
#include "xpersif/cognition/motivation_component.h"
#include "xpersif/component/component.h"
#include "xpersif/component/supervisor.h"
#include "xpersif/decision/design_of_experiments.h"
#include "xpersif/decision/execution.h"
#include "xpersif/decision/goal_design.h"
#include "xpersif/decision/planner_component.h"
#include "xpersif/embodiment/manipulation.h"
#include "xpersif/embodiment/relocation.h"
#include "xpersif/embodiment/robot_model.h"
#include "xpersif/examples/example_counter.h"
#include "xpersif/loop/loop_model.h"
#include "xpersif/perception/feature_extraction.h"
#include "xpersif/perception/feature_selection.h"
#include "xpersif/perception/observation.h"
#include "xpersif/perception/perception.h"
#include "xpersif/perception/vision_component.h"
#include "xpersif/traces/snapshot_recorder.h"
#include "xpersif/web/web_bridge.h"
#include "xpersif/xpersim/xpersim.h"

namespace xpersif {

const std::vector<ComponentParameters>& parameterCatalogue() {
  static const std::vector<ComponentParameters> catalogue{
      {"Every component", "", &Component::baseParameters()},
      {"XPERSim", "xpersif/XPerSimNodelet", &XPerSim::parameters()},
      {"LOOPMODEL", "xpersif/LoopModelNodelet", &LoopModel::parameters()},
      {"DESIGNOFEXPERIMENTS", "xpersif/DesignOfExperimentsNodelet", &DesignOfExperiments::parameters()},
      {"GOALDESIGN", "xpersif/GoalDesignNodelet", &GoalDesign::parameters()},
      {"PLANNER", "xpersif/PlannerNodelet", &Planner::parameters()},
      {"EXECUTION", "xpersif/ExecutionNodelet", &Execution::parameters()},
      {"ROBOTMODEL", "xpersif/RobotModelNodelet", &RobotModel::parameters()},
      {"RELOCATION", "xpersif/RelocationNodelet", &Relocation::parameters()},
      {"MANIPULATION", "xpersif/ManipulationNodelet", &Manipulation::parameters()},
      {"PERCEPTION", "xpersif/PerceptionNodelet", &Perception::parameters()},
      {"OBSERVATION", "xpersif/ObservationNodelet", &Observation::parameters()},
      {"FEATUREEXTRACTION", "xpersif/FeatureExtractionNodelet", &FeatureExtraction::parameters()},
      {"FEATURESELECTION", "xpersif/FeatureSelectionNodelet", &FeatureSelection::parameters()},
      {"VISION", "xpersif/VisionNodelet", &Vision::parameters()},
      {"MOTIVATION", "xpersif/MotivationNodelet", &MotivationComponent::parameters()},
      {"MACHINELEARNING", "xpersif/MachineLearningNodelet", &MachineLearning::parameters()},
      {"KNOWLEDGEBASE", "xpersif/KnowledgeBaseNodelet", &KnowledgeBaseComponent::parameters()},
      {"SUPERVISOR", "xpersif/SupervisorNodelet", &Supervisor::parameters()},
      {"SIMCAMERA", "xpersif/SimCameraNodelet", &SimCamera::parameters()},
      {"SNAPSHOTRECORDER", "xpersif/SnapshotRecorderNodelet", &SnapshotRecorder::parameters()},
      {"WEBBRIDGE", "xpersif/WebBridgeNodelet", &WebBridge::parameters()},
      {"EXAMPLECOUNTER", "xpersif/ExampleCounterNodelet", &ExampleCounter::parameters()},
  };
  return catalogue;
}

const core::ParameterTable* declaredParametersOf(const std::string& type) {
  static const std::map<std::string, core::ParameterTable> with_base = [] {
    std::map<std::string, core::ParameterTable> tables;
    for (const auto& entry : parameterCatalogue()) {
      if (entry.type.empty()) continue;
      core::ParameterTable table = *entry.table;
      table.include(Component::baseParameters());
      tables.emplace(entry.type, std::move(table));
    }
    return tables;
  }();
  const auto found = with_base.find(type);
  return found == with_base.end() ? nullptr : &found->second;
}

}  // namespace xpersif
