/**
 * @file evaluation.h
 * @brief How well a run learned: prediction error on a fixed evaluation set against the number of
 *        experiments learned from, for any design (curiosity-driven, random, ...), computed from the knowledge
 *        base alone. ROS-free; used by the report tool and the benchmarks.
 *
 * The model after k experiments is what MACHINELEARNING had learned then: a PushLearner with the same
 * configuration, trained on the run's first k successful experiments in their order (training is
 * deterministic, push_learner.h). Its error on the evaluation set is the RMS over the evaluation experiments
 * of core::surprise().error (metres, a turn counted at 2 cm), so every design is judged on the same pushes.
 */
#pragma once

#include <map>
#include <string>
#include <vector>

#include "xpersif/core/kb/knowledge_base.h"
#include "xpersif/core/learning/push_learner.h"

namespace xpersif::core {

/// The learner's samples in a run's records, by the one rule of experiment_samples.h.
std::vector<PushSample> pushSamples(const std::vector<ExperimentRecord>& records);

/// The objects' names in the order the records' scenes list them (as MACHINELEARNING's one-hot code has them).
std::vector<std::string> sceneIdentities(const std::vector<ExperimentRecord>& records);

/// The learner's samples of the designed experiments of every run in @p database (a study cell's knowledge base):
/// the successful ones up to the run's "experiments" count, so not the goal-directed pushes that follow them.
std::vector<PushSample> designedSamples(const std::string& database);

/// A study's held-out evaluation set: its pushes as the learner's samples, and the objects' identities in scene order.
struct EvaluationSet {
  std::vector<std::string> identities;
  std::vector<PushSample> samples;
};

/// The evaluation set in @p database: every successful experiment of every run. Throws std::runtime_error when it
/// holds none.
EvaluationSet loadEvaluationSet(const std::string& database);

/// The configuration MACHINELEARNING uses: hue and size as features plus the objects' identities.
PushLearnerConfig loopLearnerConfig(const std::vector<std::string>& identities);

struct LearningCurve {
  std::string name;
  std::vector<int> experiments;  ///< k
  std::vector<double> error;     ///< RMS error on the evaluation set after k experiments, m
  /// The same per object of the evaluation set (its pushes alone), in the order of `experiments`: a study weighs
  /// the objects equally from these, so that the object with the most evaluation pushes does not decide the curve.
  std::map<std::string, std::vector<double>> object_error;
  std::map<std::string, int> object_pushes;  ///< evaluation pushes per object
  /// Competence, per object of the evaluation set, in the order of `experiments`: the one-push goal error (m), see
  /// oneShotGoalErrors.
  std::map<std::string, std::vector<double>> object_goal_error;
  /// Per object, the same measure for two choosers that do not depend on k: picking a push at random (the null) and
  /// picking the best one (a model that knows every outcome; the floor the push library allows).
  std::map<std::string, std::pair<double, double>> object_goal_random_best;
};

/// How far apart two outcomes are (m): the distance of the displacements in the push's frame plus a turn counted at
/// kYawLength per radian.
double outcomeDistance(const Outcome& a, const Outcome& b);

/// Competence of a model at one-push goals, on the evaluation set as a library of pushes with measured outcomes. The
/// targets are fixed: each evaluation push's outcome on its object. For a target, the model picks, among the object's
/// other evaluation pushes, the one whose predicted outcome (@p predicted, one per sample of @p evaluation) is closest
/// to it; the error is how far the chosen push's measured outcome is from the target. Per object, the mean error over
/// its targets (objects with fewer than two pushes are left out). Pushing once from a library of measured pushes
/// stands in for pushing in the simulator: the outcomes are the simulator's, and every design is judged on the same.
std::map<std::string, double> oneShotGoalErrors(const std::vector<PushSample>& evaluation,
                                                 const std::vector<Outcome>& predicted);

/// Per object, oneShotGoalErrors for a chooser picking uniformly at random (its expected error) and for one picking the
/// push whose measured outcome is closest: (random, best).
std::map<std::string, std::pair<double, double>> goalReferences(const std::vector<PushSample>& evaluation);

/// How the learner is trained: one model over every object (learner_type random_forest, MACHINELEARNING's
/// default), or one model per object with the shared one for objects seen fewer than three times
/// (per_object_forest, core::PerObjectPushModel).
enum class LearnerScope { Shared, PerObject };

/// Error after each k in @p checkpoints (k larger than the samples available are skipped).
LearningCurve learningCurve(const std::string& name, const std::vector<PushSample>& training,
                            const std::vector<PushSample>& evaluation, const PushLearnerConfig& config,
                            const std::vector<int>& checkpoints, LearnerScope scope = LearnerScope::Shared);

/// The evaluation set's objects that move when pushed: those whose median travel (a turn counted at 2 cm) is at least
/// `share` of their median push distance. An object that never moves is predicted by any model; weighing it in a
/// measure only dilutes the differences between designs (the same rule as scripts/study_measures.py).
std::vector<std::string> movingObjects(const std::vector<PushSample>& evaluation, double share = 0.1);

/// Per-object values (one per k of a curve with @p points checkpoints) averaged with equal weight over @p objects,
/// at each k (NAN where none has a point).
std::vector<double> balancedOver(const std::map<std::string, std::vector<double>>& per_object, std::size_t points,
                                 const std::vector<std::string>& objects);
/// The curve's prediction error averaged that way.
inline std::vector<double> balancedError(const LearningCurve& curve, const std::vector<std::string>& objects) {
  return balancedOver(curve.object_error, curve.experiments.size(), objects);
}
/// The curve's one-push goal error (competence) averaged that way.
inline std::vector<double> balancedGoalError(const LearningCurve& curve, const std::vector<std::string>& objects) {
  return balancedOver(curve.object_goal_error, curve.experiments.size(), objects);
}
/// @p values at the first of @p experiments at or after @p k (the last one if none; NAN when empty): the figure
/// "after k experiments" where the curve has checkpoints only (scripts/study_measures.py's error_at).
double valueAt(const std::vector<int>& experiments, const std::vector<double>& values, int k);

/// The mean of log(error) over the curve's span of k, by the trapezoid rule: the log of the curve's geometric-mean
/// error over the budget. A design's ratio to another is exp(the difference of their areas).
double logArea(const std::vector<int>& experiments, const std::vector<double>& error);

/// The first k at which the curve is at or below @p error, or -1.
int experimentsToReach(const LearningCurve& curve, double error);

/// A number of a run's parameters (the JSON object LOOPMODEL stores), or `fallback` when the text is not a JSON
/// object or has no such number (runs stored before the key existed).
double runParameter(const std::string& parameters_json, const std::string& key, double fallback);

/// "experiments" of a run's parameters, or -1 (the report and the study read it).
long designedCount(const std::string& parameters_json);

}  // namespace xpersif::core
