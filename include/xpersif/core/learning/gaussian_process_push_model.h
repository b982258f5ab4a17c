/**
 * @file gaussian_process_push_model.h
 * @brief A second model of pushing (plugin "gaussian_process"): exact Gaussian-process regression with a fixed
 *        kernel, one GP per output (dx, dy, dyaw) sharing the kernel, written with Eigen.
 *
 * The inputs are the forest's (core::encodePushInput: push direction, offset, distance, the configured features,
 * the optional one-hot identity), each divided by its unit (core::pushInputScales), so a distance of 1 in the
 * input space is 1 cm of offset, 3 cm of distance, 30 of hue, ...
 *
 * The kernel is fixed, not fitted (so training is deterministic and needs no optimiser; the price is that its
 * scales are a modelling choice documented here):
 *    k_out(x, x') = prior_out^2 * exp(-|x - x'|^2 / (2 l^2)),   noise variance (f prior_out)^2,
 * with l = option "length_scale" (default 1.5 input units) and f = option "noise_fraction" (default 0.1). The
 * prior mean is zero motion. Because every output's kernel and noise are the same up to prior_out^2, one
 * Cholesky factor of R + f^2 I (R the correlation matrix exp(-d^2 / 2 l^2) of the samples) serves all three:
 *    mean_out = r*^T (R + f^2 I)^-1 y_out
 *    std_out  = prior_out * sqrt(1 - r*^T (R + f^2 I)^-1 r* + f^2)
 * Far from every sample the std is prior * sqrt(1 + f^2); near many samples it falls to about prior * f.
 * With no sample at all it predicts zero motion with exactly prior_std.
 *
 * Saved as YAML (format, configuration, sample_count, samples); loading retrains from the samples.
 *
 * Cost: adding a sample extends the factor in O(n^2), a prediction is O(n^2) (n samples); the memory is
 * n^2 doubles, so the model holds at most kMaxSamples (2000, 32 MB) samples and refuses more with a sentence
 * (the random forest holds 100000).
 *
 * Not thread-safe: one owner calls it.
 */
#pragma once

#include <Eigen/Dense>

#include <string>
#include <vector>

#include "xpersif/core/learning/push_model.h"

namespace xpersif::core {

class GaussianProcessPushModel : public PushModel {
 public:
  static constexpr std::size_t kMaxSamples = 2000;
  static constexpr const char* kFormat = "xpersif-gp-push-model/1";
  static constexpr double kDefaultLengthScale = 1.5;
  static constexpr double kDefaultNoiseFraction = 0.1;

  GaussianProcessPushModel();
  /// Throws ValidationError for a bad config; options: length_scale (> 0), noise_fraction (in (0, 1]).
  explicit GaussianProcessPushModel(const PushModelConfig& config);

  void configure(const PushModelConfig& config) override;
  void check(const PushInput& input, const std::string& field = "input") const override;
  void addSamples(const std::vector<PushSample>& samples) override;
  Prediction predict(const PushInput& input) const override;
  std::size_t sampleCount() const override { return samples_.size(); }
  const std::vector<PushSample>& samples() const override { return samples_; }
  /// YAML: format, the configuration and the samples (training is deterministic, so they are the model).
  std::string save() const override;
  void load(const std::string& bytes) override;
  std::string format() const override { return kFormat; }

  const PushModelConfig& config() const { return config_; }
  double lengthScale() const { return length_scale_; }
  double noiseFraction() const { return noise_fraction_; }

 private:
  std::vector<double> scaledRow(const PushInput& input) const;
  double correlation(const std::vector<double>& a, const std::vector<double>& b) const;

  PushModelConfig config_;
  double length_scale_ = kDefaultLengthScale;
  double noise_fraction_ = kDefaultNoiseFraction;
  std::vector<PushSample> samples_;
  std::vector<std::vector<double>> inputs_;  // scaled rows of samples_
  Eigen::MatrixXd factor_;                   // lower Cholesky factor of R + f^2 I
  Eigen::MatrixXd outputs_;                  // n x 3: dx, dy, dyaw
  Eigen::MatrixXd weights_;                  // (R + f^2 I)^-1 outputs_
};

}  // namespace xpersif::core
