/**
 * @file goal_design.h
 * @brief GOALDESIGN: in the goal-directed state, the operations design_goal (a movable object and a place to
 *        bring it) and choose_push (the push the learned model expects to bring it closest to that place).
 *
 * GOALDESIGN never calls MACHINELEARNING: it keeps its own core::PushModel, loaded (PushModel::load) from every
 * latched LearnedModel on ~model_topic, and the latest Notions on ~notions_topic. The model is made by pluginlib:
 * of the declared push models (doc/plugins.md), the one whose format() is the message's format, so whichever
 * learner MACHINELEARNING runs, GOALDESIGN reads it without a parameter of its own.
 *
 * design_goal: an object of the scene (restricted to ~objects) that no notion calls does_not_move_when_pushed
 * and, when the request gives a tolerance, whose pushes the model predicts within it (median spread of the end
 * over the grid of pushes below; while none is, within twice the best object's spread), chosen with a seeded
 * generator (~seed), and a target ~min_target_distance..~max_target_distance (5-15 cm in a 0.6 m arena)
 * away from it, at least ~wall_clearance (8 cm) from every wall and ~object_clearance (6 cm) from the other
 * objects.
 * choose_push: candidates = sides x ~offsets x ~distances plus ~random_candidates random pushes (seeded), less
 * those MANIPULATION's push planner (core::planPush, default options) would refuse from the scene; for each,
 * the model's mean outcome (dx, dy in the push frame) is turned into the world (the push direction is
 * the object's perceived yaw plus the side's push angle, core::pushAngleInObject) and added to the object's
 * position; the push with the least expected squared distance to the target wins: the predicted end's distance
 * squared plus ~uncertainty_weight times the variance of the end (std of dx and dy), so a push the model is sure
 * of beats a guess (ties: the first candidate). expected_error is the chosen push's predicted end's distance.
 * Both refuse while no model has arrived.
 *
 * Parameters: GoalDesign::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md). The choices themselves are
 * core/goal_choice.h's.
 */
#pragma once

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "xpersif/ChoosePush.h"
#include "xpersif/DesignGoal.h"
#include "xpersif/LearnedModel.h"
#include "xpersif/Notions.h"
#include "xpersif/component/component.h"
#include "xpersif/core/common/footprint.h"
#include "xpersif/core/learning/goal_choice.h"
#include "xpersif/core/motion/motion.h"
#include "xpersif/core/learning/push_model.h"
#include "xpersif/ros/algorithm_loader.h"

namespace xpersif {


class GoalDesign : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  GoalDesign(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;
  void onShutdown() override;

 private:
  void onModel(const LearnedModel::ConstPtr& model);
  void onNotions(const Notions::ConstPtr& notions);
  std::string whyNoModel() const;
  void designGoal(const DesignGoal::Request& request, DesignGoal::Response& response);
  void choosePush(const ChoosePush::Request& request, ChoosePush::Response& response);
  /// The grid of pushes of @p object: every side x ~offsets x ~distances.
  std::vector<core::Experiment> gridPushes(const std::string& object, const core::Footprint& footprint) const;
  /// How closely the model predicts where @p object ends: the median, over the grid's pushes, of the spread
  /// sqrt(std_dx^2 + std_dy^2) of its end (m).
  double predictedSpread(const core::ObjectFeatures& object) const;

  mutable std::mutex mutex_;
  std::vector<std::string> objects_;
  std::map<std::string, core::Footprint> footprints_;
  std::condition_variable modelled_;  // a new model was loaded
  /// Wait (bounded) until the loaded model has @p samples samples: a goal never depends on message timing.
  void waitForSamples(std::unique_lock<std::mutex>& lock, std::uint32_t samples,
                      const std::vector<std::string>& features);
  double min_push_ = 0, max_push_ = 0;  // the set-up's push distances, m
  double min_target_ = 0.05, max_target_ = 0.12, wall_clearance_ = 0.08, object_clearance_ = 0.06;
  std::vector<double> offsets_, distances_;
  int random_candidates_ = 256;
  double uncertainty_weight_ = 1.0;
  core::ArenaGeometry arena_;
  double robot_radius_ = 0.035;  // m, the set-up's
  std::mt19937_64 rng_;
  /// A model that reads @p format (the first declared class, by name, whose format() it is), or why none does.
  std::shared_ptr<core::PushModel> modelFor(const std::string& format, std::string* why);
  std::mutex loader_mutex_;  // guards loader_, formats_
  AlgorithmLoader<core::PushModel> loader_;  // before learner_: it holds the model's code
  std::map<std::string, std::string> formats_;  // format -> declared class, learned by asking each once
  std::shared_ptr<core::PushModel> learner_;
  std::uint64_t model_run_ = 0;
  std::string model_topic_;
  std::vector<std::string> model_features_;  // LearnedModel.features of learner_
  std::string model_problem_;  // why the last model could not be loaded
  std::set<std::string> immobile_;  // objects whose notion says does_not_move_when_pushed

  ros::Subscriber model_sub_;
  ros::Subscriber notions_sub_;
};

}  // namespace xpersif
