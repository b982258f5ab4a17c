#include "xpersif/cognition/machine_learning.h"

#include "xpersif/component/parameter_reader.h"

#include <algorithm>
#include <cmath>

#include "xpersif/core/evaluation/experiment_samples.h"
#include "xpersif/core/perception/vision.h"
#include "xpersif/ros/experiment_conversions.h"
#include "xpersif/ros/setup_loader.h"

namespace xpersif {

namespace {

/// A literal's tuple argument, "(a, b)"; "none" for no names.
std::string tuple(const std::vector<std::string>& names) {
  std::string text;
  for (const auto& n : names) text += (text.empty() ? "" : ", ") + n;
  return names.empty() ? "none" : "(" + text + ")";
}

/// One unit of a feature in the learner's input distance where ~feature_scales names none: what tells two objects
/// apart (30 degrees of hue, 1 cm of edge, ...).
double defaultScale(const std::string& feature) {
  static const std::map<std::string, double> scales = {
      {"hue", 30.0},     {"saturation", 0.1}, {"color_r", 0.1}, {"color_g", 0.1},     {"color_b", 0.1},
      {"size", 0.01},    {"area", 0.0004},    {"elongation", 0.25}, {"orientation", 0.2}, {"x", 0.05},
      {"y", 0.05},       {"distance_to_robot", 0.05}, {"bearing_from_robot", 0.2}, {"distance_to_wall", 0.05},
      {"confidence", 0.1}};
  const auto it = scales.find(feature);
  return it == scales.end() ? 1.0 : it->second;
}

core::Bindings pushBindings(const Experiment& e) {
  return {{"?object", e.object},
          {"?side", e.side},
          {"?offset", core::describeNumber(e.offset)},
          {"?distance", core::describeNumber(e.distance)}};
}
}  // namespace

std::string MachineLearning::sampleOf(const ExperimentRecord& record, core::PushSample* sample) {
  // The one rule shared with offline training (core/experiment_samples.h).
  std::string why;
  try {
    const auto made = core::pushSampleOf(fromMsg(record), &why);
    if (!made) return why;
    *sample = *made;
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

MachineLearning::MachineLearning(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/MachineLearningNodelet"),
      loader_("xpersif::core::PushModel", "push model") {
  core::Contract predict;
  predict.name = "predict";
  predict.kind = core::Contract::Kind::Operation;
  predict.interface_type = "xpersif/Predict";
  predict.description = "the predicted motion (dx, dy, dyaw in the push frame; mean and std) of a push";
  predict.parameters = {"?object", "?side", "?offset", "?distance"};
  predict.preconditions = {
      {"described(?object)", "the object's features must name the pushed object and carry every feature the model uses"}};
  predict.effects = {"predicted(?object, ?side, ?offset, ?distance)"};
  ContractChecker<Predict::Request> contract(predict);
  contract.bind([](const Predict::Request& r) { return pushBindings(r.experiment); })
      .check("described(?object)", [this](const Predict::Request& r) {
        if (r.object.name != r.experiment.object) {
          return "object.name '" + r.object.name + "' is not the pushed object '" + r.experiment.object + "'";
        }
        std::lock_guard<std::mutex> lock(mutex_);
        for (const auto& feature : config_.feature_names) {
          if (std::find(r.object.feature_names.begin(), r.object.feature_names.end(), feature) ==
              r.object.feature_names.end()) {
            return "object.feature_names lacks '" + feature + "', an input of the model";
          }
        }
        return std::string();
      });
  addOperation<Predict>(
      contract,
      [](const Predict::Request& r) {
        core::requireExperiment("experiment", fromMsg(r.experiment));
        core::throwIfInvalid(checkObjectFeatures("object", r.object));
      },
      [this](const Predict::Request& r, Predict::Response& response) {
        core::PushInput input{fromMsg(r.experiment), fromMsg(r.object)};
        std::lock_guard<std::mutex> lock(mutex_);
        if (!learner_) throw std::runtime_error("the model is not configured");
        // A model of the run before would make the prediction (and the surprise curiosity follows) depend on how
        // soon the follower restored this run.
        if (r.run_id != 0 && r.run_id != run_id_) {
          throw core::UnavailableError("the model is of run " + std::to_string(run_id_) + ", not yet of run " +
                                      std::to_string(r.run_id));
        }
        const core::Prediction p = learner_->predict(input);
        response.mean = {p.mean.dx, p.mean.dy, p.mean.dyaw};
        response.std = {p.std.dx, p.std.dy, p.std.dyaw};
        response.samples = static_cast<std::uint32_t>(learner_->sampleCount());
        response.message = "from " + std::to_string(response.samples) + " samples";
      });

  core::Contract use;
  use.name = "use_features";
  use.kind = core::Contract::Kind::Operation;
  use.interface_type = "xpersif/UseFeatures";
  use.description = "learn from these features of the pushed object (initial: ~features), retrained at once";
  use.parameters = {"?features"};
  use.effects = {"learns_from(machine_learning, ?features)"};
  ContractChecker<UseFeatures::Request> use_contract(use);
  addOperation<UseFeatures>(
      use_contract,
      [](const UseFeatures::Request& r) {
        core::requireMaxSize("names", r.names.size(), core::kMaxExtraFeatures);
        if (r.initial && !r.names.empty()) {
          throw core::ValidationError("initial is set and names are given; ask for one or the other");
        }
        std::vector<std::string> known;
        for (const auto& f : core::availableFeatures()) known.push_back(f.name);
        for (std::size_t i = 0; i < r.names.size(); ++i) {
          core::requireKnownName("names[" + std::to_string(i) + "]", r.names[i], known);
          if (std::find(r.names.begin(), r.names.begin() + static_cast<std::ptrdiff_t>(i), r.names[i]) !=
              r.names.begin() + static_cast<std::ptrdiff_t>(i)) {
            throw core::ValidationError("names[" + std::to_string(i) + "] '" + r.names[i] + "' is named twice");
          }
        }
      },
      [this](const UseFeatures::Request& r, UseFeatures::Response& response) { useFeatures(r.names, r.initial, response); }, true,
      [](const UseFeatures::Request&, const UseFeatures::Response& response) {
        return core::Bindings{{"?features", tuple(response.features)}};
      });
}

void MachineLearning::useFeatures(const std::vector<std::string>& names, bool initial, UseFeatures::Response& response) {
  std::shared_ptr<core::PushModel> learner;
  std::vector<ExperimentRecord> records;
  core::PushModelConfig config;
  std::string type;
  std::uint64_t run = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!learner_) throw core::UnavailableError("the model is not configured yet");
    config = config_;
    config.feature_names = initial ? configured_features_ : names;
    for (const auto& f : config.feature_names) {
      if (!config.feature_scales.count(f)) config.feature_scales[f] = defaultScale(f);
    }
    type = learner_type_;
    records = records_;
    run = run_id_;
  }
  learner = rebuild(type, config, run, records);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    config_ = config;
    ++config_generation_;
    // A run restored meanwhile: learn its records; records that arrived meanwhile: learn them too.
    if (run_id_ != run || records_.size() < records.size()) learner = rebuild(type, config, run_id_, records_);
    for (std::size_t i = run_id_ != run ? records_.size() : records.size(); i < records_.size(); ++i) {
      core::PushSample sample;
      if (!sampleOf(records_[i], &sample).empty()) continue;
      try {
        learner->addSample(sample.input, sample.outcome);
      } catch (const std::exception& e) {
        ROS_WARN("%s: skipping experiment %u: %s", name().c_str(), records_[i].seq, e.what());
      }
    }
    learner_ = learner;
    response.features = config_.feature_names;
    response.samples = static_cast<std::uint32_t>(learner_->sampleCount());
  }
  response.message = "learns from " + (response.features.empty() ? std::string("the push and the identity alone")
                                                                  : tuple(response.features)) +
                     ", retrained on " + std::to_string(response.samples) + " samples";
  publish();
}

MachineLearning::~MachineLearning() {
  // The follower's thread calls back into this object: stop it while the object is whole.
  if (follower_) follower_->stop();
}

const core::ParameterTable& MachineLearning::parameters() {
  using core::ParameterSpec;
  static const core::ParameterTable table = [] {
    const core::PushModelConfig d;
    core::ParameterTable own(
        "machine_learning",
        {core::textParameter("learner_type", "random_forest",
                             "the push model plugin: random_forest, per_object_forest, gaussian_process or another package's (doc/plugins.md)"),
         core::namesParameter("features", d.feature_names, core::kMaxExtraFeatures,
                              "the object's features the model learns from, besides the push"),
         ParameterSpec{"feature_scales", ParameterSpec::Type::Dictionary, {}, "{hue: 30, size: 0.01}", -INFINITY, INFINITY, {},
                       "a scale per feature name (the model divides the feature by it)"},
         core::flagParameter("one_hot_identity", true, "encode the object's identity as an input"),
         core::intParameter("seed", 1, 0, 2147483647, "the learner's seed"),
         ParameterSpec{"learner_options", ParameterSpec::Type::Dictionary, {}, "{}", -INFINITY, INFINITY, {},
                       "options of the learner plugin, name to number (doc/plugins.md)"},
         ParameterSpec{"ensemble_size", ParameterSpec::Type::Int, {}, "the plugin's (8)", 1, 256, {},
                       "random_forest: forests in the bootstrap ensemble (also ~learner_options/ensemble_size)"},
         ParameterSpec{"trees_per_member", ParameterSpec::Type::Int, {}, "the plugin's (16)", 1, 1024, {},
                       "random_forest: trees per forest (also ~learner_options/trees_per_member)"}});
    own.include(ExperimentFollower::Options::parameters()).include(setupCatalogueParameters());
    return own;
  }();
  return table;
}

void MachineLearning::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, MachineLearning::parameters());
  core::PushModelConfig config;
  // The identities to encode: the objects of XPERSim's scene, in world-file order (~objects may restrict them).
  config.identities = loadSetupCatalogue(nodeHandle(), pnh).names();
  const std::string learner_type = parameters.get<std::string>("learner_type");
  config.feature_names = parameters.get<std::vector<std::string>>("features");
  if (parameters.has("feature_scales")) config.feature_scales = parameters.get<std::map<std::string, double>>("feature_scales");
  config.one_hot_identity = parameters.get<bool>("one_hot_identity");
  config.seed = static_cast<std::uint64_t>(parameters.get<int>("seed"));
  if (parameters.has("learner_options")) {
    for (const auto& [option, value] : parameters.get<std::map<std::string, double>>("learner_options")) {
      config.options[option] = value;
    }
  }
  // The forest's own parameters, kept from before learners were plugins.
  if (learner_type == "random_forest" || learner_type == "per_object_forest") {
    for (const std::string option : {"ensemble_size", "trees_per_member"}) {
      if (parameters.has(option)) config.options[option] = parameters.get<int>(option, 0);
    }
  }
  auto learner = makeModel(learner_type, config);  // throws with the reason for an unknown type or a bad config

  const ExperimentFollower::Options follow = ExperimentFollower::Options::fromParameters(pnh, name());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    learner_type_ = learner_type;
    config_ = config;
    configured_features_ = config.feature_names;
    ++config_generation_;
    learner_ = std::move(learner);
    records_.clear();
    run_id_ = 0;
    follow_ = follow;
    if (!model_pub_) {
      model_pub_ = pnh.advertise<LearnedModel>("model", 1, true);
      notions_pub_ = pnh.advertise<Notions>("notions", 1, true);
    }
  }
}

void MachineLearning::onActivate() {
  if (follower_) follower_->stop();
  follower_ = std::make_unique<ExperimentFollower>(
      nodeHandle(), follow_, [this](std::uint64_t run, const std::vector<ExperimentRecord>& records) { reset(run, records); },
      [this](const ExperimentRecord& record) { add(record); });
  follower_->start();
}

void MachineLearning::onDeactivate() {
  if (follower_) follower_->stop();
}

void MachineLearning::onShutdown() {
  if (follower_) follower_->stop();
  follower_.reset();
  std::lock_guard<std::mutex> lock(mutex_);
  learner_.reset();
}

std::shared_ptr<core::PushModel> MachineLearning::makeModel(const std::string& type,
                                                           const core::PushModelConfig& config) {
  std::shared_ptr<core::PushModel> model;
  {
    std::lock_guard<std::mutex> lock(loader_mutex_);
    model = loader_.create("~learner_type", type);
  }
  model->configure(config);
  return model;
}

std::shared_ptr<core::PushModel> MachineLearning::rebuild(const std::string& type, const core::PushModelConfig& config,
                                                         std::uint64_t run_id,
                                                         const std::vector<ExperimentRecord>& records) {
  std::vector<core::PushSample> samples;
  auto learner = makeModel(type, config);
  for (const auto& record : records) {
    core::PushSample sample;
    if (!sampleOf(record, &sample).empty()) continue;
    // Validate one by one so that one bad record does not lose the others.
    try {
      learner->check(sample.input);  // validates without training
      core::requireOutcome("outcome", sample.outcome);
      samples.push_back(sample);
    } catch (const std::exception& e) {
      ROS_WARN("%s: skipping experiment %u of run %lu: %s", name().c_str(), record.seq,
               static_cast<unsigned long>(run_id), e.what());
    }
  }
  learner->addSamples(samples);  // trained once, outside the lock: predict goes on meanwhile
  return learner;
}

void MachineLearning::reset(std::uint64_t run_id, const std::vector<ExperimentRecord>& records) {
  core::PushModelConfig config;
  std::string type;
  std::uint64_t generation = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    config = config_;
    type = learner_type_;
    generation = config_generation_;
  }
  auto learner = rebuild(type, config, run_id, records);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // use_features changed the inputs meanwhile: learn the records again with them (rare; under the lock).
    if (generation != config_generation_) learner = rebuild(learner_type_, config_, run_id, records);
    learner_ = std::move(learner);
    records_ = records;
    run_id_ = run_id;
  }
  publish();
}

void MachineLearning::add(const ExperimentRecord& record) {
  core::PushSample sample;
  const std::string why = sampleOf(record, &sample);
  if (!why.empty()) {
    ROS_DEBUG("%s: experiment %u is no sample: %s", name().c_str(), record.seq, why.c_str());
    return;
  }
  try {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!learner_) return;
    records_.push_back(record);  // before learning it: use_features learns every record of the run again
    learner_->addSample(sample.input, sample.outcome);
    run_id_ = record.run_id;
  } catch (const std::exception& e) {
    ROS_WARN("%s: skipping experiment %u of run %lu: %s", name().c_str(), record.seq,
             static_cast<unsigned long>(record.run_id), e.what());
    return;
  }
  publish();
}

void MachineLearning::publish() {
  auto model = boost::make_shared<LearnedModel>();
  auto notions = boost::make_shared<Notions>();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!learner_) return;
    model->header.stamp = notions->header.stamp = ros::Time::now();
    model->run_id = notions->run_id = run_id_;
    model->samples = notions->samples = static_cast<std::uint32_t>(learner_->sampleCount());
    model->format = learner_->format();
    model->data = learner_->save();
    model->features = config_.feature_names;
    for (const auto& n : learner_->notions()) notions->notions.push_back(toMsg(n));
  }
  model_pub_.publish(model);
  notions_pub_.publish(notions);
}

}  // namespace xpersif
