#include "xpersif/core/learning/push_learner.h"

#include <opencv2/core.hpp>
#include <opencv2/ml.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

constexpr int kOutputs = 3;
constexpr int kFixedInputs = 4;  // cos, sin of the push direction, offset, distance
constexpr double kDirectionScale = 1.0;
constexpr double kOffsetScale = 0.01;    // m
constexpr double kDistanceScale = 0.03;  // m
constexpr std::size_t kFingerprintProbes = 8;
constexpr double kNoiseFloor = 0.05;  // of the prior std: the noise assumed where samples show none

/// FileStorage reads a written string that starts with '[' or '{' as the start of a structure: every name
/// from outside is written behind this mark and read back without it.
constexpr char kMark = '=';
std::string marked(const std::string& text) { return kMark + text; }
std::vector<std::string> marked(const std::vector<std::string>& texts) {
  std::vector<std::string> out;
  for (const auto& t : texts) out.push_back(marked(t));
  return out;
}

double component(const Outcome& o, int k) { return k == 0 ? o.dx : (k == 1 ? o.dy : o.dyaw); }
void setComponent(Outcome& o, int k, double v) { (k == 0 ? o.dx : (k == 1 ? o.dy : o.dyaw)) = v; }

}  // namespace

/// One member's regressor for one output: a forest, or a constant when its bootstrap's responses are all
/// equal (OpenCV's RTrees refuses all-zero responses, and a forest of a constant is that constant).
struct Regressor {
  cv::Ptr<cv::ml::RTrees> forest;
  float constant = 0.0f;
  double predict(const cv::Mat& row) const { return forest ? forest->predict(row) : constant; }
};

/// The trained ensemble, plus what the uncertainty needs: scaled training inputs and out-of-bag residuals.
struct PushLearner::Model {
  std::vector<std::array<Regressor, kOutputs>> members;
  cv::Mat scaled_inputs;                   // n x d, CV_64F: inputs divided by their novelty scales
  std::vector<std::array<double, kOutputs>> oob_residual2;  // per sample
};

PushLearner::PushLearner(PushLearnerConfig config) : config_(std::move(config)) {
  const PushLearnerConfig& c = config_;
  if (c.ensemble_size < 1 || c.ensemble_size > 64) throw ValidationError("ensemble_size must be in [1, 64]");
  if (c.trees_per_member < 1 || c.trees_per_member > 500) throw ValidationError("trees_per_member must be in [1, 500]");
  if (c.max_depth < 1 || c.max_depth > 30) throw ValidationError("max_depth must be in [1, 30]");
  if (c.min_sample_count < 1) throw ValidationError("min_sample_count must be at least 1");
  if (c.noise_neighbours < 1) throw ValidationError("noise_neighbours must be at least 1");
  requirePositive("prior_std.dx", c.prior_std.dx);
  requirePositive("prior_std.dy", c.prior_std.dy);
  requirePositive("prior_std.dyaw", c.prior_std.dyaw);
  requirePositive("novelty_length", c.novelty_length);
  throwIfInvalid(checkMaxSize("feature_names", c.feature_names.size(), kMaxExtraFeatures));
  throwIfInvalid(checkMaxSize("identities", c.identities.size(), kMaxObjectsPerFeatureVector));
  for (const auto& name : c.feature_names) {
    if (name.empty()) throw ValidationError("feature_names has an empty name");
  }
  for (const auto& [name, scale] : c.feature_scales) requirePositive("feature_scales[" + name + "]", scale);
  if (c.one_hot_identity && c.identities.empty()) {
    throw ValidationError("one_hot_identity is on but identities is empty; list the object names");
  }
}

PushLearner::~PushLearner() = default;

const std::vector<std::string> PushLearnerConfig::kOptionNames{"ensemble_size",    "trees_per_member",
                                                               "max_depth",        "min_sample_count",
                                                               "novelty_length",   "noise_neighbours"};

PushModelConfig PushLearnerConfig::toModelConfig() const {
  PushModelConfig m;
  m.feature_names = feature_names;
  m.feature_scales = feature_scales;
  m.one_hot_identity = one_hot_identity;
  m.identities = identities;
  m.seed = seed;
  m.prior_std = prior_std;
  m.options = {{"ensemble_size", ensemble_size},       {"trees_per_member", trees_per_member},
               {"max_depth", max_depth},               {"min_sample_count", min_sample_count},
               {"novelty_length", novelty_length},     {"noise_neighbours", noise_neighbours}};
  return m;
}

PushLearnerConfig PushLearnerConfig::fromModelConfig(const PushModelConfig& m) {
  PushLearnerConfig c;
  c.feature_names = m.feature_names;
  c.feature_scales = m.feature_scales;
  c.one_hot_identity = m.one_hot_identity;
  c.identities = m.identities;
  c.seed = m.seed;
  c.prior_std = m.prior_std;
  auto integer = [](const std::string& name, double value) {
    requireInRange("options." + name, value, 0, 1e6);
    if (value != std::floor(value)) throw ValidationError("options." + name + " must be a whole number");
    return static_cast<int>(value);
  };
  for (const auto& [name, value] : m.options) {
    if (name == "ensemble_size") c.ensemble_size = integer(name, value);
    else if (name == "trees_per_member") c.trees_per_member = integer(name, value);
    else if (name == "max_depth") c.max_depth = integer(name, value);
    else if (name == "min_sample_count") c.min_sample_count = integer(name, value);
    else if (name == "noise_neighbours") c.noise_neighbours = integer(name, value);
    else if (name == "novelty_length") c.novelty_length = value;
    else requireOneOf("the random forest's option", name, kOptionNames);
  }
  return c;
}

void PushLearner::configure(const PushModelConfig& config) {
  *this = PushLearner(PushLearnerConfig::fromModelConfig(config));  // validates before anything changes
}
PushLearner::PushLearner(PushLearner&&) noexcept = default;
PushLearner& PushLearner::operator=(PushLearner&&) noexcept = default;

void PushLearner::validate(const PushInput& input, const std::string& field) const {
  checkPushInput(config_.feature_names, input, field);
}

std::vector<float> PushLearner::encode(const PushInput& input) const {
  validate(input, "input");
  const double angle = pushAngleInObject(input.experiment.side);
  std::vector<float> row{static_cast<float>(std::cos(angle)), static_cast<float>(std::sin(angle)),
                         static_cast<float>(input.experiment.offset), static_cast<float>(input.experiment.distance)};
  for (const auto& name : config_.feature_names) row.push_back(static_cast<float>(input.object.extra.at(name)));
  if (config_.one_hot_identity) {
    for (const auto& id : config_.identities) row.push_back(id == input.object.name ? 1.0f : 0.0f);
  }
  return row;
}

namespace {

std::vector<double> inputScales(const PushLearnerConfig& c) {
  std::vector<double> scales{kDirectionScale, kDirectionScale, kOffsetScale, kDistanceScale};
  for (const auto& name : c.feature_names) {
    const auto it = c.feature_scales.find(name);
    scales.push_back(it == c.feature_scales.end() ? 1.0 : it->second);
  }
  if (c.one_hot_identity) scales.insert(scales.end(), c.identities.size(), 1.0);
  return scales;
}

cv::Ptr<cv::ml::RTrees> makeForest(const PushLearnerConfig& c, int inputs) {
  auto forest = cv::ml::RTrees::create();
  forest->setMaxDepth(c.max_depth);
  forest->setMinSampleCount(c.min_sample_count);
  forest->setRegressionAccuracy(1e-7f);
  forest->setUseSurrogates(false);
  forest->setCVFolds(0);
  forest->setCalculateVarImportance(false);
  // Most inputs at each split: with few inputs, sqrt(d) would often miss the one that matters.
  forest->setActiveVarCount(std::max(1, (inputs * 2 + 2) / 3));
  forest->setTermCriteria(cv::TermCriteria(cv::TermCriteria::MAX_ITER, c.trees_per_member, 0.0));
  return forest;
}

}  // namespace

std::size_t PushLearner::trainedCount(std::size_t n) {
  if (n < kMinTrainingSamples) return 0;
  if (n <= kRetrainEveryUpTo) return n;
  // The stride doubles each time n doubles: a training costs about n log n, so the cost per sample stays bounded.
  std::size_t base = kRetrainEveryUpTo, stride = kRetrainStride;
  while (n >= 2 * base) {
    base *= 2;
    stride *= 2;
  }
  return n - (n - base) % stride;
}

void PushLearner::addSamples(const std::vector<PushSample>& samples) {
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const std::string field = samples.size() == 1 ? std::string("sample") : "samples[" + std::to_string(i) + "]";
    validate(samples[i].input, field + ".input");
    requireOutcome(field + ".outcome", samples[i].outcome);
  }
  if (samples_.size() + samples.size() > kMaxSamples) {
    throw ValidationError("the learner holds at most " + std::to_string(kMaxSamples) + " samples");
  }
  if (samples.empty()) return;
  // Keep only the features the learner uses: the stored samples (and saved models) stay small.
  for (const auto& s : samples) {
    PushSample kept = s;
    kept.input.object.extra.clear();
    for (const auto& name : config_.feature_names) kept.input.object.extra[name] = s.input.object.extra.at(name);
    samples_.push_back(std::move(kept));
  }
  if (trainedCount(samples_.size()) != trained_count_) retrain();
}

void PushLearner::retrain() {
  const std::size_t n = trainedCount(samples_.size());
  if (n == 0) {
    model_.reset();
    trained_count_ = 0;
    return;
  }
  const int d = static_cast<int>(encode(samples_[0].input).size());
  cv::Mat inputs(static_cast<int>(n), d, CV_32F), outputs(static_cast<int>(n), kOutputs, CV_32F);
  auto model = std::make_unique<Model>();
  const std::vector<double> scales = inputScales(config_);
  model->scaled_inputs.create(static_cast<int>(n), d, CV_64F);
  for (std::size_t i = 0; i < n; ++i) {
    const std::vector<float> row = encode(samples_[i].input);
    for (int j = 0; j < d; ++j) {
      inputs.at<float>(static_cast<int>(i), j) = row[j];
      model->scaled_inputs.at<double>(static_cast<int>(i), j) = row[j] / scales[j];
    }
    for (int k = 0; k < kOutputs; ++k) {
      outputs.at<float>(static_cast<int>(i), k) = static_cast<float>(component(samples_[i].outcome, k));
    }
  }
  cv::Mat var_type(d + 1, 1, CV_8U, cv::Scalar(cv::ml::VAR_ORDERED));

  cv::RNG rng(config_.seed);
  std::vector<std::array<double, kOutputs>> oob_sum(n, {0, 0, 0});
  std::vector<int> oob_count(n, 0);
  for (int m = 0; m < config_.ensemble_size; ++m) {
    std::vector<int> picked(n);
    std::vector<char> in_bag(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
      picked[i] = static_cast<int>(rng.uniform(0, static_cast<int>(n)));
      in_bag[picked[i]] = 1;
    }
    cv::Mat x(static_cast<int>(n), d, CV_32F);
    cv::Mat y(static_cast<int>(n), kOutputs, CV_32F);
    for (std::size_t i = 0; i < n; ++i) {
      inputs.row(picked[i]).copyTo(x.row(static_cast<int>(i)));
      outputs.row(picked[i]).copyTo(y.row(static_cast<int>(i)));
    }
    std::array<Regressor, kOutputs> member;
    for (int k = 0; k < kOutputs; ++k) {
      const cv::Mat response = y.col(k).clone();
      double lo = 0, hi = 0;
      cv::minMaxLoc(response, &lo, &hi);
      if (lo == hi) {
        member[k].constant = static_cast<float>(lo);
        continue;
      }
      member[k].forest = makeForest(config_, d);
      auto data = cv::ml::TrainData::create(x, cv::ml::ROW_SAMPLE, response, cv::noArray(), cv::noArray(),
                                            cv::noArray(), var_type);
      // RTrees draws its bootstraps and split variables from cv::theRNG() (this thread's): seed it per forest,
      // so that training is deterministic, and give the caller its generator back afterwards.
      const cv::RNG callers = cv::theRNG();
      cv::theRNG() = cv::RNG(config_.seed * 1000003u + static_cast<std::uint64_t>(m * kOutputs + k) + 1u);
      bool trained = false;
      try {
        trained = member[k].forest->train(data);
      } catch (...) {
        cv::theRNG() = callers;
        throw;
      }
      cv::theRNG() = callers;
      if (!trained) throw std::runtime_error("PushLearner: OpenCV RTrees training failed");
    }
    // Out-of-bag predictions in one call per output: row by row, they cost as much as the training itself.
    cv::Mat oob_rows;
    std::vector<std::size_t> oob;
    for (std::size_t i = 0; i < n; ++i) {
      if (in_bag[i]) continue;
      oob_rows.push_back(inputs.row(static_cast<int>(i)));
      oob.push_back(i);
      ++oob_count[i];
    }
    for (int k = 0; k < kOutputs && !oob.empty(); ++k) {
      cv::Mat predicted(static_cast<int>(oob.size()), 1, CV_32F, cv::Scalar(member[k].constant));
      if (member[k].forest) member[k].forest->predict(oob_rows, predicted);
      for (std::size_t j = 0; j < oob.size(); ++j) oob_sum[oob[j]][k] += predicted.at<float>(static_cast<int>(j));
    }
    model->members.push_back(member);
  }
  model->oob_residual2.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < kOutputs; ++k) {
      double predicted = 0.0;
      if (oob_count[i] > 0) {
        predicted = oob_sum[i][k] / oob_count[i];
      } else {  // in every bag (rare): the ensemble's own, optimistic, residual
        for (const auto& member : model->members) predicted += member[k].predict(inputs.row(static_cast<int>(i)));
        predicted /= static_cast<double>(model->members.size());
      }
      const double r = component(samples_[i].outcome, k) - predicted;
      model->oob_residual2[i][k] = r * r;
    }
  }
  model_ = std::move(model);
  trained_count_ = n;
}

Prediction PushLearner::predict(const PushInput& input) const {
  const std::vector<float> row = encode(input);  // validates
  Prediction p;
  p.std = config_.prior_std;
  if (!model_) return p;

  const cv::Mat x(1, static_cast<int>(row.size()), CV_32F, const_cast<float*>(row.data()));
  const double members = static_cast<double>(model_->members.size());
  double mean[kOutputs] = {0, 0, 0}, m2[kOutputs] = {0, 0, 0};
  for (const auto& member : model_->members) {
    for (int k = 0; k < kOutputs; ++k) {
      const double v = member[k].predict(x);
      mean[k] += v;
      m2[k] += v * v;
    }
  }
  // Distances in scaled input space: how much data lie near the query (n_eff) and the local noise.
  const std::vector<double> scales = inputScales(config_);
  const int n = model_->scaled_inputs.rows;
  const double two_l2 = 2.0 * config_.novelty_length * config_.novelty_length;
  std::vector<std::pair<double, int>> distances(n);
  double n_eff = 0.0;
  for (int i = 0; i < n; ++i) {
    double d2 = 0.0;
    for (int j = 0; j < model_->scaled_inputs.cols; ++j) {
      const double diff = row[j] / scales[j] - model_->scaled_inputs.at<double>(i, j);
      d2 += diff * diff;
    }
    distances[i] = {d2, i};
    n_eff += std::exp(-d2 / two_l2);
  }
  const int k_near = std::min(n, config_.noise_neighbours);
  std::partial_sort(distances.begin(), distances.begin() + k_near, distances.end());

  for (int k = 0; k < kOutputs; ++k) {
    const double mu = mean[k] / members;
    const double spread2 = std::max(0.0, m2[k] / members - mu * mu);
    double noise2 = 0.0;
    for (int i = 0; i < k_near; ++i) noise2 += model_->oob_residual2[distances[i].second][k];
    noise2 /= k_near;
    const double prior2 = std::pow(component(config_.prior_std, k), 2);
    // Posterior variance of a local mean under the prior, from n_eff observations of noise sigma2.
    const double sigma2 = std::max(noise2, std::pow(kNoiseFloor, 2) * prior2);
    const double unexplored2 = prior2 * sigma2 / (sigma2 + n_eff * prior2);
    setComponent(p.mean, k, mu);
    setComponent(p.std, k, std::sqrt(spread2 + noise2 + unexplored2));
  }
  return p;
}

// ---- save / load ---------------------------------------------------------------------------------------

namespace {

void writeSample(cv::FileStorage& out, const PushSample& s, const std::vector<std::string>& features) {
  out << "{";
  out << "object" << marked(s.input.experiment.object) << "side" << marked(s.input.experiment.side);
  out << "offset" << s.input.experiment.offset << "distance" << s.input.experiment.distance;
  out << "pose" << std::vector<double>{s.input.object.x, s.input.object.y, s.input.object.yaw};
  std::vector<double> values;
  for (const auto& name : features) values.push_back(s.input.object.extra.at(name));
  out << "features" << values;
  out << "outcome" << std::vector<double>{s.outcome.dx, s.outcome.dy, s.outcome.dyaw};
  out << "}";
}

}  // namespace

std::string PushLearner::save() const {
  const PushLearnerConfig& c = config_;
  // FileStorage keys must be identifiers, and feature names need not be: write the config as lists.
  cv::FileStorage out(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  out << "format" << kFormat;
  out << "feature_names" << marked(c.feature_names);
  std::vector<std::string> scale_names;
  std::vector<double> scale_values;
  for (const auto& [name, scale] : c.feature_scales) {
    scale_names.push_back(marked(name));
    scale_values.push_back(scale);
  }
  out << "feature_scale_names" << scale_names << "feature_scale_values" << scale_values;
  out << "one_hot_identity" << static_cast<int>(c.one_hot_identity) << "identities" << marked(c.identities);
  out << "ensemble_size" << c.ensemble_size << "trees_per_member" << c.trees_per_member;
  out << "max_depth" << c.max_depth << "min_sample_count" << c.min_sample_count;
  out << "seed" << std::to_string(c.seed);  // 64 bits do not fit FileStorage's int
  out << "prior_std" << std::vector<double>{c.prior_std.dx, c.prior_std.dy, c.prior_std.dyaw};
  out << "novelty_length" << c.novelty_length << "noise_neighbours" << c.noise_neighbours;

  // The samples, most of the bytes, are written once each and kept: a model of 2000 samples took tens of ms to
  // write, every experiment. An item's text does not depend on its neighbours, so cached items splice in.
  if (saved_count_ < samples_.size()) {
    cv::FileStorage items(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    items << "samples" << "[";
    for (std::size_t i = saved_count_; i < samples_.size(); ++i) writeSample(items, samples_[i], c.feature_names);
    items << "]";
    const std::string text = items.releaseAndGetString();
    const std::string key = "\nsamples:\n";
    saved_samples_ += text.substr(text.find(key) + key.size());
    saved_count_ = samples_.size();
  }
  out << "samples" << "[" << "]";
  // Fingerprint: predictions at some sample inputs, to prove after loading that the model is the same.
  out << "fingerprint" << "[";
  for (std::size_t i = 0; i < std::min(kFingerprintProbes, samples_.size()); ++i) {
    const std::size_t at = i * samples_.size() / std::min(kFingerprintProbes, samples_.size());
    const Prediction p = predict(samples_[at].input);
    out << std::vector<double>{static_cast<double>(at), p.mean.dx, p.mean.dy, p.mean.dyaw, p.std.dx, p.std.dy,
                               p.std.dyaw};
  }
  out << "]";
  std::string bytes = out.releaseAndGetString();
  if (!samples_.empty()) {
    // Keys start lines and names are quoted with escaped line breaks: this empty list is the samples'.
    const std::string empty = "\nsamples:\n   []\n";
    const std::size_t at = bytes.find(empty);
    if (at == std::string::npos) throw std::logic_error("PushLearner::save: OpenCV wrote an unexpected layout");
    bytes.replace(at, empty.size(), "\nsamples:\n" + saved_samples_);
  }
  return bytes;
}


namespace {

[[noreturn]] void badModel(const std::string& why) {
  throw ValidationError("model bytes are not a usable PushLearner model: " + why);
}

const cv::FileNode& need(const cv::FileNode& node, const std::string& what) {
  if (node.empty() || node.isNone()) badModel("'" + what + "' is missing");
  return node;
}

std::vector<double> doubles(const cv::FileNode& node, const std::string& what, std::size_t size) {
  need(node, what);
  if (!node.isSeq()) badModel("'" + what + "' is not a list");
  std::vector<double> values;
  for (const auto& item : node) {
    if (!item.isReal() && !item.isInt()) badModel("'" + what + "' holds a non-number");
    values.push_back(static_cast<double>(item));
  }
  if (size && values.size() != size) badModel("'" + what + "' has " + std::to_string(values.size()) + " numbers, not " +
                                              std::to_string(size));
  return values;
}

std::string unmarked(const std::string& text, const std::string& what) {
  if (text.empty() || text[0] != kMark) badModel("'" + what + "' holds an unmarked name");
  return text.substr(1);
}

std::vector<std::string> strings(const cv::FileNode& node, const std::string& what) {
  std::vector<std::string> values;
  if (node.empty() || node.isNone()) return values;  // OpenCV writes an empty list as nothing useful
  if (!node.isSeq()) badModel("'" + what + "' is not a list");
  for (const auto& item : node) {
    if (!item.isString()) badModel("'" + what + "' holds a non-string");
    values.push_back(unmarked(static_cast<std::string>(item), what));
  }
  return values;
}

int integer(const cv::FileNode& node, const std::string& what) {
  need(node, what);
  if (!node.isInt()) badModel("'" + what + "' is not an integer");
  return static_cast<int>(node);
}

double real(const cv::FileNode& node, const std::string& what) {
  need(node, what);
  if (!node.isReal() && !node.isInt()) badModel("'" + what + "' is not a number");
  return static_cast<double>(node);
}

std::string text(const cv::FileNode& node, const std::string& what) {
  need(node, what);
  if (!node.isString()) badModel("'" + what + "' is not a string");
  return static_cast<std::string>(node);
}

}  // namespace

void PushLearner::load(const std::string& bytes) {
  if (bytes.empty()) badModel("they are empty");
  PushLearnerConfig c;
  std::vector<PushSample> samples;
  std::vector<std::vector<double>> fingerprint;
  try {
    cv::FileStorage fs(bytes, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) badModel("OpenCV cannot parse them as YAML");
    const cv::FileNode root = fs.root();
    if (!root.isMap()) badModel("the top level is not a map");
    const std::string format = text(root["format"], "format");
    if (format != kFormat) badModel("the format is '" + format + "', expected '" + kFormat + "'");
    c.feature_names = strings(root["feature_names"], "feature_names");
    const auto scale_names = strings(root["feature_scale_names"], "feature_scale_names");
    const auto scale_values = doubles(root["feature_scale_values"], "feature_scale_values", 0);
    if (scale_names.size() != scale_values.size()) badModel("feature scale names and values differ in number");
    c.feature_scales.clear();
    for (std::size_t i = 0; i < scale_names.size(); ++i) c.feature_scales[scale_names[i]] = scale_values[i];
    c.one_hot_identity = integer(root["one_hot_identity"], "one_hot_identity") != 0;
    c.identities = strings(root["identities"], "identities");
    c.ensemble_size = integer(root["ensemble_size"], "ensemble_size");
    c.trees_per_member = integer(root["trees_per_member"], "trees_per_member");
    c.max_depth = integer(root["max_depth"], "max_depth");
    c.min_sample_count = integer(root["min_sample_count"], "min_sample_count");
    const std::string seed = text(root["seed"], "seed");
    std::size_t used = 0;
    try {
      c.seed = std::stoull(seed, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != seed.size()) badModel("'seed' is not an unsigned integer");
    const auto prior = doubles(root["prior_std"], "prior_std", 3);
    c.prior_std = {prior[0], prior[1], prior[2]};
    c.novelty_length = real(root["novelty_length"], "novelty_length");
    c.noise_neighbours = integer(root["noise_neighbours"], "noise_neighbours");

    const cv::FileNode list = root["samples"];
    if (!list.empty() && !list.isNone()) {
      if (!list.isSeq()) badModel("'samples' is not a list");
      if (list.size() > kMaxSamples) badModel("there are more than " + std::to_string(kMaxSamples) + " samples");
      for (const auto& node : list) {
        if (!node.isMap()) badModel("a sample is not a map");
        const auto pose = doubles(node["pose"], "samples.pose", 3);
        const auto features = doubles(node["features"], "samples.features", c.feature_names.size());
        const auto outcome = doubles(node["outcome"], "samples.outcome", 3);
        samples.push_back(pushSampleFrom(unmarked(text(node["object"], "samples.object"), "samples.object"),
                                         unmarked(text(node["side"], "samples.side"), "samples.side"),
                                         real(node["offset"], "samples.offset"), real(node["distance"], "samples.distance"),
                                         pose, features, c.feature_names, outcome));
      }
    }
    const cv::FileNode probes = root["fingerprint"];
    if (!probes.empty() && !probes.isNone()) {
      if (!probes.isSeq()) badModel("'fingerprint' is not a list");
      for (const auto& node : probes) fingerprint.push_back(doubles(node, "fingerprint", 7));
    }
  } catch (const cv::Exception& e) {
    badModel(std::string("OpenCV cannot read them (") + e.err + ")");
  }

  PushLearner loaded(c);  // validates the config
  try {
    loaded.addSamples(samples);  // validates the samples, trains once
  } catch (const ValidationError& e) {
    badModel(std::string("a sample is invalid: ") + e.what());
  }
  for (const auto& probe : fingerprint) {
    const double at = probe[0];
    if (!(at >= 0) || at >= static_cast<double>(loaded.samples_.size()) || at != std::floor(at)) {
      badModel("the fingerprint names a sample that does not exist");
    }
    const Prediction p = loaded.predict(loaded.samples_[static_cast<std::size_t>(at)].input);
    const double got[6] = {p.mean.dx, p.mean.dy, p.mean.dyaw, p.std.dx, p.std.dy, p.std.dyaw};
    for (int k = 0; k < 6; ++k) {
      if (std::fabs(got[k] - probe[k + 1]) > 1e-9 * (1.0 + std::fabs(probe[k + 1]))) {
        badModel("retrained from its samples it predicts differently from when it was saved (another OpenCV "
                 "version?)");
      }
    }
  }
  *this = std::move(loaded);
}

}  // namespace xpersif::core
