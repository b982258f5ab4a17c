/**
 * @file feature_ranking.h
 * @brief FEATURESELECTION's choice, ROS-free: which of an object's own features help predict how it moves when
 *        pushed, scored on stored pushes, and the top ones chosen by a declared rule.
 *
 * The score of a candidate feature is its held-out permutation importance (Breiman's, with k-fold cross-validation
 * in place of the out-of-bag rows): OpenCV random forests, one per outcome (dx, dy, dyaw), are trained on the push
 * (cos and sin of the push direction in the object's frame, offset, distance) and every candidate — never the
 * object's identity, so a feature scores only as far as what it says about the object carries the outcome. For
 * each held-out row the candidate's value is replaced by that of a row drawn at random from all rows (seeded,
 * `repeats` times: the feature's own distribution with its link to the outcome broken); the score is the mean rise of the squared held-out error this causes, as a share of the
 * outcome's variance, averaged over the outcomes that vary, and never below 0. A feature that is the same in every
 * row scores exactly 0; one that decides the outcome scores high.
 *
 * The rule: the `count` candidates with the highest scores among those scoring at least `min_score`, best first;
 * equal scores keep the candidates' order. Nothing may be chosen (no candidate helps).
 *
 * Deterministic: the same samples, candidates and options give the same scores bit for bit (the forests draw from
 * cv::theRNG(), seeded per forest from `seed` and restored afterwards; the draws from a SplitMix64 stream).
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "xpersif/core/learning/push_model.h"

namespace xpersif::core {

struct FeatureRankingOptions {
  std::size_t count = 2;     ///< at most this many are chosen (1..16)
  double min_score = 0.01;   ///< a chosen feature's score is at least this (0..1)
  std::size_t folds = 5;     ///< cross-validation folds (2..20; at most one per row)
  std::size_t repeats = 5;   ///< permutations per held-out fold (1..100)
  int trees = 40;            ///< trees per forest (1..500)
  int max_depth = 6;         ///< (1..30)
  std::uint64_t seed = 1;
};

/// At least this many rows (pushes that carry every candidate) are needed to rank.
constexpr std::size_t kMinRankingRows = 4;

struct FeatureScore {
  std::string name;
  double score = 0.0;  ///< held-out error rise when the feature is shuffled, share of the outcome's variance, >= 0
};

struct FeatureRanking {
  std::vector<FeatureScore> scores;  ///< every candidate, best first (equal scores: the candidates' order)
  std::vector<std::string> chosen;   ///< the rule's choice, best first; may be empty
  std::size_t rows = 0;              ///< pushes ranked on
};

/// Field-named sentence ("" when fine) for options out of their ranges (non-finite min_score included).
std::string checkFeatureRankingOptions(const FeatureRankingOptions& options);

/**
 * @brief Score @p candidates on @p samples and choose by the rule above.
 * @param samples pushes whose object carries every candidate in `input.object.extra`
 * @throws ValidationError (a sentence naming what) for no candidates, an empty or repeated name, bad options, a
 *         sample with a bad push or outcome, a sample missing a candidate or holding a non-finite value; and for
 *         fewer than kMinRankingRows samples
 */
FeatureRanking rankFeatures(const std::vector<PushSample>& samples, const std::vector<std::string>& candidates,
                            const FeatureRankingOptions& options = {});

}  // namespace xpersif::core
