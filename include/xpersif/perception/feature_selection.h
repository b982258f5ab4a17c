/**
 * @file feature_selection.h
 * @brief FEATURESELECTION: says which further features VISION computes for every object (colour, size,
 *        orientation, distance to the robot, ...), and chooses which of the object's own features MACHINELEARNING
 *        learns from. The selection is published latched on `~selection`, which VISION follows.
 *
 * Operations:
 *  - `select_features` (SelectFeatures): set the selection by hand (unknown names are refused, listing the known
 *    ones; the selection stays as it was); empty: back to the initial one, `~features` plus every candidate. Effect `selected(vision, (names...))`.
 *  - `choose_features` (ChooseFeatures): rank the candidates (`~candidates`, or the request's) on the run's first
 *    `experiments` experiments as the KNOWLEDGEBASE (`~knowledge_base`) has them, by held-out permutation importance
 *    (core/feature_ranking.h: random forests on the push and the candidates, never the identity, seeded by the
 *    request), choose at most `~count` scoring at least `~min_score`, best first, and make VISION extract them: the
 *    selection becomes `~features` plus the chosen ones. Only done experiments whose pushed
 *    object carries every candidate as a finite number count (`rows`; the others are `skipped`); fewer than
 *    core::kMinRankingRows is FAILED with a sentence that says how many there are. A name that is not a candidate
 *    is INVALID (the sentence lists the candidates); a knowledge base that does not answer UNAVAILABLE. Effects:
 *    `features_chosen(RUN, (chosen...) | none, EXPERIMENTS)`, `feature_scores(RUN, (name/score, ...))` (every
 *    candidate, best first, three decimals) and `selected(vision, (names...))`: the knowledge base keeps them as
 *    the run's facts.
 *
 * Parameters: `~features` (what VISION always computes; default core::FeatureSelection's defaults: x, y, hue,
 * size, orientation and the relations to robot and walls; the initial selection adds every candidate, so that the
 * experiments before a choice carry them all), `~candidates` (core::objectFeatureNames(): the features
 * that describe the object itself), `~count` (2, 1..16), `~min_score` (0.01, 0..1), `~knowledge_base`
 * (knowledge_base), `~knowledge_base_timeout` (5 s). `~available` is set on configure to the features one can
 * choose, "name [unit]: description".
 */
#pragma once

#include <mutex>

#include "xpersif/ChooseFeatures.h"
#include "xpersif/FeatureNames.h"
#include "xpersif/SelectFeatures.h"
#include "xpersif/component/component.h"
#include "xpersif/core/learning/feature_ranking.h"
#include "xpersif/core/perception/vision.h"

namespace xpersif {

class FeatureSelection : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  FeatureSelection(ros::NodeHandle nh, ros::NodeHandle private_nh);

 protected:
  void onConfigure() override;

 private:
  void publish();
  void choose(const ChooseFeatures::Request& request, ChooseFeatures::Response& response);

  std::mutex mutex_;
  core::FeatureSelection selection_;
  std::vector<std::string> base_;        // ~features
  std::vector<std::string> initial_;     // ~features and every candidate
  std::vector<std::string> candidates_;  // ~candidates
  core::FeatureRankingOptions ranking_;  // count, min_score
  std::string knowledge_base_ = "knowledge_base";
  double knowledge_base_timeout_ = 5.0;
  ros::Publisher selection_pub_;
};

}  // namespace xpersif
