/**
 * @file gaussian_process_push_model.cpp
 * @brief Exact GP regression of push outcomes with a fixed squared-exponential kernel; see the header.
 */
#include "xpersif/core/learning/gaussian_process_push_model.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <limits>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

const std::vector<std::string> kOptions{"length_scale", "noise_fraction"};

double component(const Outcome& o, int k) { return k == 0 ? o.dx : (k == 1 ? o.dy : o.dyaw); }

[[noreturn]] void badModel(const std::string& why) {
  throw ValidationError("model bytes are not a usable Gaussian-process push model: " + why);
}

}  // namespace

GaussianProcessPushModel::GaussianProcessPushModel() { configure(PushModelConfig{}); }

GaussianProcessPushModel::GaussianProcessPushModel(const PushModelConfig& config) { configure(config); }

void GaussianProcessPushModel::configure(const PushModelConfig& config) {
  checkPushModelConfig(config);
  double length = kDefaultLengthScale, noise = kDefaultNoiseFraction;
  for (const auto& [name, value] : config.options) {
    requireOneOf("the Gaussian process's option", name, kOptions);
    if (name == "length_scale") length = value;
    if (name == "noise_fraction") noise = value;
  }
  requirePositive("options.length_scale", length);
  requirePositive("options.noise_fraction", noise);
  requireInRange("options.noise_fraction", noise, 0, 1);
  config_ = config;
  length_scale_ = length;
  noise_fraction_ = noise;
  samples_.clear();
  inputs_.clear();
  factor_.resize(0, 0);
  outputs_.resize(0, 3);
  weights_.resize(0, 3);
}

void GaussianProcessPushModel::check(const PushInput& input, const std::string& field) const {
  checkPushInput(config_.feature_names, input, field);
}

std::vector<double> GaussianProcessPushModel::scaledRow(const PushInput& input) const {
  std::vector<double> row = encodePushInput(config_, input);
  const std::vector<double> scales = pushInputScales(config_);
  for (std::size_t j = 0; j < row.size(); ++j) row[j] /= scales[j];
  return row;
}

double GaussianProcessPushModel::correlation(const std::vector<double>& a, const std::vector<double>& b) const {
  double d2 = 0.0;
  for (std::size_t j = 0; j < a.size(); ++j) d2 += (a[j] - b[j]) * (a[j] - b[j]);
  return std::exp(-d2 / (2.0 * length_scale_ * length_scale_));
}

void GaussianProcessPushModel::addSamples(const std::vector<PushSample>& samples) {
  std::vector<std::vector<double>> rows;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const std::string field = samples.size() == 1 ? std::string("sample") : "samples[" + std::to_string(i) + "]";
    check(samples[i].input, field + ".input");
    requireOutcome(field + ".outcome", samples[i].outcome);
    rows.push_back(scaledRow(samples[i].input));
  }
  if (samples_.size() + samples.size() > kMaxSamples) {
    throw ValidationError("the Gaussian-process model holds at most " + std::to_string(kMaxSamples) +
                          " samples (its memory grows with their square); use the random_forest learner for "
                          "longer runs");
  }
  if (samples.empty()) return;
  const Eigen::Index old_n = static_cast<Eigen::Index>(samples_.size());
  const Eigen::Index new_n = old_n + static_cast<Eigen::Index>(samples.size());
  const double nugget = noise_fraction_ * noise_fraction_;
  Eigen::MatrixXd factor = factor_;
  factor.conservativeResize(new_n, new_n);
  factor.topRightCorner(old_n, new_n - old_n).setZero();
  Eigen::MatrixXd outputs = outputs_;
  outputs.conservativeResize(new_n, 3);
  std::vector<std::vector<double>> inputs = inputs_;
  // Extend the Cholesky factor one row at a time: L_new = [L 0; l^T d], l = L^-1 k, d^2 = k(x,x) + f^2 - |l|^2.
  for (std::size_t s = 0; s < samples.size(); ++s) {
    const Eigen::Index n = old_n + static_cast<Eigen::Index>(s);
    Eigen::VectorXd k(n);
    for (Eigen::Index i = 0; i < n; ++i) k(i) = correlation(inputs[i], rows[s]);
    Eigen::VectorXd l = factor.topLeftCorner(n, n).triangularView<Eigen::Lower>().solve(k);
    // d^2 >= f^2 in exact arithmetic; the floor guards rounding.
    const double d2 = std::max(1.0 + nugget - l.squaredNorm(), nugget * 1e-6);
    factor.block(n, 0, 1, n) = l.transpose();
    factor.block(n, n, 1, new_n - n).setZero();
    factor(n, n) = std::sqrt(d2);
    for (int out = 0; out < 3; ++out) outputs(n, out) = component(samples[s].outcome, out);
    inputs.push_back(rows[s]);
  }
  Eigen::MatrixXd weights = factor.triangularView<Eigen::Lower>().solve(outputs);
  factor.triangularView<Eigen::Lower>().transpose().solveInPlace(weights);

  for (const auto& sample : samples) {
    PushSample kept = sample;  // keep only the features the model uses: saved models stay small
    kept.input.object.extra.clear();
    for (const auto& name : config_.feature_names) kept.input.object.extra[name] = sample.input.object.extra.at(name);
    samples_.push_back(std::move(kept));
  }
  inputs_ = std::move(inputs);
  factor_ = std::move(factor);
  outputs_ = std::move(outputs);
  weights_ = std::move(weights);
}

Prediction GaussianProcessPushModel::predict(const PushInput& input) const {
  const std::vector<double> row = scaledRow(input);  // validates
  Prediction p;
  p.std = config_.prior_std;
  if (samples_.empty()) return p;
  const Eigen::Index n = static_cast<Eigen::Index>(samples_.size());
  Eigen::VectorXd k(n);
  for (Eigen::Index i = 0; i < n; ++i) k(i) = correlation(inputs_[i], row);
  const Eigen::VectorXd mean = weights_.transpose() * k;
  const Eigen::VectorXd v = factor_.triangularView<Eigen::Lower>().solve(k);
  const double latent = std::max(0.0, 1.0 - v.squaredNorm());
  const double scale = std::sqrt(latent + noise_fraction_ * noise_fraction_);
  p.mean = {mean(0), mean(1), mean(2)};
  p.std = {config_.prior_std.dx * scale, config_.prior_std.dy * scale, config_.prior_std.dyaw * scale};
  return p;
}

// ---- save / load ---------------------------------------------------------------------------------------

std::string GaussianProcessPushModel::save() const {
  YAML::Emitter out;
  out.SetDoublePrecision(std::numeric_limits<double>::max_digits10);
  out << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << kFormat;
  out << YAML::Key << "feature_names" << YAML::Value << YAML::Flow << config_.feature_names;
  out << YAML::Key << "feature_scales" << YAML::Value << YAML::Flow << config_.feature_scales;
  out << YAML::Key << "one_hot_identity" << YAML::Value << config_.one_hot_identity;
  out << YAML::Key << "identities" << YAML::Value << YAML::Flow << config_.identities;
  out << YAML::Key << "seed" << YAML::Value << std::to_string(config_.seed);
  out << YAML::Key << "prior_std" << YAML::Value << YAML::Flow
      << std::vector<double>{config_.prior_std.dx, config_.prior_std.dy, config_.prior_std.dyaw};
  out << YAML::Key << "options" << YAML::Value << YAML::Flow
      << std::map<std::string, double>{{"length_scale", length_scale_}, {"noise_fraction", noise_fraction_}};
  // The count catches a file cut off between two samples, which would otherwise still parse.
  out << YAML::Key << "sample_count" << YAML::Value << samples_.size();
  out << YAML::Key << "samples" << YAML::Value << YAML::BeginSeq;
  for (const auto& s : samples_) {
    std::vector<double> features;
    for (const auto& name : config_.feature_names) features.push_back(s.input.object.extra.at(name));
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "object" << YAML::Value << s.input.experiment.object;
    out << YAML::Key << "side" << YAML::Value << s.input.experiment.side;
    out << YAML::Key << "offset" << YAML::Value << s.input.experiment.offset;
    out << YAML::Key << "distance" << YAML::Value << s.input.experiment.distance;
    out << YAML::Key << "pose" << YAML::Value << std::vector<double>{s.input.object.x, s.input.object.y, s.input.object.yaw};
    out << YAML::Key << "features" << YAML::Value << features;
    out << YAML::Key << "outcome" << YAML::Value << std::vector<double>{s.outcome.dx, s.outcome.dy, s.outcome.dyaw};
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  if (!out.good()) throw std::logic_error("GaussianProcessPushModel::save: " + out.GetLastError());
  return out.c_str();
}

namespace {

std::vector<double> numbers(const YAML::Node& node, const std::string& what, std::size_t size) {
  if (!node || !node.IsSequence()) badModel("'" + what + "' is missing or not a list");
  const auto values = node.as<std::vector<double>>();
  if (values.size() != size) {
    badModel("'" + what + "' has " + std::to_string(values.size()) + " numbers, not " + std::to_string(size));
  }
  return values;
}

}  // namespace

void GaussianProcessPushModel::load(const std::string& bytes) {
  if (bytes.empty()) badModel("they are empty");
  PushModelConfig c;
  std::vector<PushSample> samples;
  try {
    const YAML::Node root = YAML::Load(bytes);
    if (!root.IsMap()) badModel("the top level is not a map");
    if (!root["format"] || root["format"].as<std::string>() != kFormat) {
      badModel(std::string("the format is not '") + kFormat + "'");
    }
    c.feature_names = root["feature_names"].as<std::vector<std::string>>();
    c.feature_scales = root["feature_scales"].as<std::map<std::string, double>>();
    c.one_hot_identity = root["one_hot_identity"].as<bool>();
    c.identities = root["identities"].as<std::vector<std::string>>();
    const std::string seed = root["seed"].as<std::string>();
    std::size_t used = 0;
    try {
      c.seed = std::stoull(seed, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != seed.size()) badModel("'seed' is not an unsigned integer");
    const auto prior = numbers(root["prior_std"], "prior_std", 3);
    c.prior_std = {prior[0], prior[1], prior[2]};
    c.options = root["options"].as<std::map<std::string, double>>();
    const YAML::Node list = root["samples"];
    if (!list || !list.IsSequence()) badModel("'samples' is missing or not a list");
    if (list.size() > kMaxSamples) badModel("there are more than " + std::to_string(kMaxSamples) + " samples");
    if (!root["sample_count"] || root["sample_count"].as<std::size_t>() != list.size()) {
      badModel("'sample_count' is missing or differs from the samples listed (a truncated file?)");
    }
    for (const auto& node : list) {
      if (!node.IsMap()) badModel("a sample is not a map");
      const auto pose = numbers(node["pose"], "samples.pose", 3);
      const auto features = numbers(node["features"], "samples.features", c.feature_names.size());
      const auto outcome = numbers(node["outcome"], "samples.outcome", 3);
      samples.push_back(pushSampleFrom(node["object"].as<std::string>(), node["side"].as<std::string>(),
                                       node["offset"].as<double>(), node["distance"].as<double>(), pose, features,
                                       c.feature_names, outcome));
    }
  } catch (const YAML::Exception& e) {
    badModel(std::string("YAML cannot read them (") + e.what() + ")");
  }
  GaussianProcessPushModel loaded;
  try {
    loaded.configure(c);
    loaded.addSamples(samples);
  } catch (const ValidationError& e) {
    badModel(e.what());
  }
  *this = std::move(loaded);
}

}  // namespace xpersif::core
