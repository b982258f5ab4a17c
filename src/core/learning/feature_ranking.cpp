#include "xpersif/core/learning/feature_ranking.h"

#include <opencv2/ml.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

constexpr int kPushColumns = 4;  // cos, sin of the push direction in the object's frame, offset, distance
constexpr int kOutputs = 3;      // dx, dy, dyaw

/// SplitMix64: a fully specified generator, so that the permutations are the same on every platform.
struct SplitMix {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  std::size_t below(std::size_t n) { return static_cast<std::size_t>(next() % n); }
};

cv::Ptr<cv::ml::RTrees> makeForest(const FeatureRankingOptions& o, int inputs) {
  auto forest = cv::ml::RTrees::create();
  forest->setMaxDepth(o.max_depth);
  forest->setMinSampleCount(2);
  forest->setRegressionAccuracy(1e-7f);
  forest->setUseSurrogates(false);
  forest->setCVFolds(0);
  forest->setCalculateVarImportance(false);
  forest->setActiveVarCount(std::max(1, (inputs * 2 + 2) / 3));
  forest->setTermCriteria(cv::TermCriteria(cv::TermCriteria::MAX_ITER, o.trees, 0.0));
  return forest;
}

/// One seeded forest on @p x -> @p y (a column); a constant response gives no forest (predict the constant).
struct Regressor {
  cv::Ptr<cv::ml::RTrees> forest;
  float constant = 0.0f;
  float predict(const cv::Mat& row) const { return forest ? forest->predict(row) : constant; }
};

Regressor train(const cv::Mat& x, const cv::Mat& y, const FeatureRankingOptions& o, std::uint64_t stream) {
  Regressor r;
  double lo = 0, hi = 0;
  cv::minMaxLoc(y, &lo, &hi);
  if (lo == hi) {
    r.constant = static_cast<float>(lo);
    return r;
  }
  r.forest = makeForest(o, x.cols);
  cv::Mat var_type(1, x.cols + 1, CV_8U, cv::Scalar(cv::ml::VAR_ORDERED));
  auto data = cv::ml::TrainData::create(x, cv::ml::ROW_SAMPLE, y, cv::noArray(), cv::noArray(), cv::noArray(), var_type);
  // RTrees draws from cv::theRNG() (this thread's): seeded per forest, the caller's generator given back.
  const cv::RNG callers = cv::theRNG();
  cv::theRNG() = cv::RNG(o.seed * 1000003u + stream + 1u);
  bool trained = false;
  try {
    trained = r.forest->train(data);
  } catch (...) {
    cv::theRNG() = callers;
    throw;
  }
  cv::theRNG() = callers;
  if (!trained) throw std::runtime_error("feature ranking: OpenCV RTrees training failed");
  return r;
}

}  // namespace

std::string checkFeatureRankingOptions(const FeatureRankingOptions& o) {
  std::string why = checkInRange("count", static_cast<double>(o.count), 1, 16);
  if (why.empty()) why = checkInRange("min_score", o.min_score, 0.0, 1.0);
  if (why.empty()) why = checkInRange("folds", static_cast<double>(o.folds), 2, 20);
  if (why.empty()) why = checkInRange("repeats", static_cast<double>(o.repeats), 1, 100);
  if (why.empty()) why = checkInRange("trees", o.trees, 1, 500);
  if (why.empty()) why = checkInRange("max_depth", o.max_depth, 1, 30);
  return why;
}

namespace {

void checkCandidates(const std::vector<std::string>& candidates) {
  if (candidates.empty()) throw ValidationError("no candidate features to rank; name at least one (e.g. hue, size)");
  throwIfInvalid(checkMaxSize("candidates", candidates.size(), kMaxExtraFeatures));
  for (std::size_t j = 0; j < candidates.size(); ++j) {
    if (candidates[j].empty()) throw ValidationError("candidates[" + std::to_string(j) + "] is an empty name");
    if (std::find(candidates.begin(), candidates.begin() + static_cast<std::ptrdiff_t>(j), candidates[j]) !=
        candidates.begin() + static_cast<std::ptrdiff_t>(j)) {
      throw ValidationError("candidates[" + std::to_string(j) + "] '" + candidates[j] + "' is named twice");
    }
  }
}

/// The samples as rows: @p x the push's columns then the candidates', @p y the outcome (dx, dy, dyaw).
void sampleMatrices(const std::vector<PushSample>& samples, const std::vector<std::string>& candidates, cv::Mat& x,
                    cv::Mat& y) {
  const int n = static_cast<int>(samples.size());
  const int d = kPushColumns + static_cast<int>(candidates.size());
  x.create(n, d, CV_32F);
  y.create(n, kOutputs, CV_32F);
  for (int i = 0; i < n; ++i) {
    const PushSample& s = samples[static_cast<std::size_t>(i)];
    const std::string field = "samples[" + std::to_string(i) + "]";
    throwIfInvalid(checkExperiment(field + ".input.experiment", s.input.experiment));
    requireOutcome(field + ".outcome", s.outcome);
    const double angle = pushAngleInObject(s.input.experiment.side);
    x.at<float>(i, 0) = static_cast<float>(std::cos(angle));
    x.at<float>(i, 1) = static_cast<float>(std::sin(angle));
    x.at<float>(i, 2) = static_cast<float>(s.input.experiment.offset);
    x.at<float>(i, 3) = static_cast<float>(s.input.experiment.distance);
    for (std::size_t j = 0; j < candidates.size(); ++j) {
      const auto it = s.input.object.extra.find(candidates[j]);
      if (it == s.input.object.extra.end()) {
        throw ValidationError(field + " (" + s.input.object.name + ") has no feature '" + candidates[j] +
                              "'; every candidate must be measured in every push ranked on");
      }
      requireFinite(field + ".input.object.extra[" + candidates[j] + "]", it->second);
      x.at<float>(i, kPushColumns + static_cast<int>(j)) = static_cast<float>(it->second);
    }
    y.at<float>(i, 0) = static_cast<float>(s.outcome.dx);
    y.at<float>(i, 1) = static_cast<float>(s.outcome.dy);
    y.at<float>(i, 2) = static_cast<float>(s.outcome.dyaw);
  }
}

/// Output @p k's rise in held-out squared error, summed over the folds, when each candidate's column is shuffled
/// (from @p permutations), relative to the output's @p variance: a forest per fold, trained on the other folds.
std::vector<double> permutationRise(const cv::Mat& x, const cv::Mat& column, double variance, int k,
                                    std::size_t candidates, const FeatureRankingOptions& options,
                                    SplitMix& permutations) {
  const int n = x.rows;
  const std::size_t folds = std::min<std::size_t>(options.folds, static_cast<std::size_t>(n));
  std::vector<double> output_rise(candidates, 0.0);
  for (std::size_t f = 0; f < folds; ++f) {
    cv::Mat train_x, train_y;
    std::vector<int> held;
    for (int i = 0; i < n; ++i) {
      if (static_cast<std::size_t>(i) % folds == f) {
        held.push_back(i);
      } else {
        train_x.push_back(x.row(i));
        train_y.push_back(column.row(i));
      }
    }
    const Regressor model = train(train_x, train_y, options, static_cast<std::uint64_t>(k * 1000 + f));
    double base = 0;
    for (int i : held) {
      const double e = model.predict(x.row(i)) - column.at<float>(i);
      base += e * e;
    }
    for (std::size_t j = 0; j < candidates; ++j) {
      const int c = kPushColumns + static_cast<int>(j);
      double shuffled = 0;
      for (std::size_t r = 0; r < options.repeats; ++r) {
        for (int i : held) {
          cv::Mat row = x.row(i).clone();
          row.at<float>(0, c) = x.at<float>(static_cast<int>(permutations.below(static_cast<std::size_t>(n))), c);
          const double e = model.predict(row) - column.at<float>(i);
          shuffled += e * e;
        }
      }
      output_rise[j] += (shuffled / static_cast<double>(options.repeats) - base) / variance;
    }
  }
  return output_rise;
}

/// Scores (the mean rise over the outputs used, at least 0), best first, and the chosen names.
FeatureRanking rankingOf(const std::vector<double>& rise, int outputs_used, const std::vector<std::string>& candidates,
                         std::size_t rows, const FeatureRankingOptions& options) {
  FeatureRanking ranking;
  ranking.rows = rows;
  for (std::size_t j = 0; j < candidates.size(); ++j) {
    const double score = outputs_used > 0 ? std::max(0.0, rise[j] / outputs_used) : 0.0;
    ranking.scores.push_back({candidates[j], score});
  }
  std::stable_sort(ranking.scores.begin(), ranking.scores.end(),
                   [](const FeatureScore& a, const FeatureScore& b) { return a.score > b.score; });
  for (const auto& s : ranking.scores) {
    if (ranking.chosen.size() >= options.count || s.score < options.min_score) break;
    ranking.chosen.push_back(s.name);
  }
  return ranking;
}

}  // namespace

FeatureRanking rankFeatures(const std::vector<PushSample>& samples, const std::vector<std::string>& candidates,
                            const FeatureRankingOptions& options) {
  throwIfInvalid(checkFeatureRankingOptions(options));
  checkCandidates(candidates);
  if (samples.size() < kMinRankingRows) {
    throw ValidationError("ranking features needs at least " + std::to_string(kMinRankingRows) +
                          " pushes that carry every candidate; there are " + std::to_string(samples.size()));
  }
  cv::Mat x, y;
  sampleMatrices(samples, candidates, x, y);
  const int n = x.rows;
  std::vector<double> rise(candidates.size(), 0.0);
  int outputs_used = 0;
  SplitMix permutations{options.seed ^ 0x5EEDF00Dull};
  for (int k = 0; k < kOutputs; ++k) {
    const cv::Mat column = y.col(k);
    cv::Scalar mean, stddev;
    cv::meanStdDev(column, mean, stddev);
    const double variance = stddev[0] * stddev[0];
    if (!(variance > 0)) continue;  // an outcome that never varies says nothing about any feature
    ++outputs_used;
    const std::vector<double> output_rise =
        permutationRise(x, column, variance, k, candidates.size(), options, permutations);
    for (std::size_t j = 0; j < candidates.size(); ++j) rise[j] += output_rise[j] / static_cast<double>(n);
  }
  return rankingOf(rise, outputs_used, candidates, samples.size(), options);
}

}  // namespace xpersif::core
