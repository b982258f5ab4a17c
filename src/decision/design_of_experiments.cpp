#include "xpersif/decision/design_of_experiments.h"

#include "xpersif/component/parameter_reader.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>

#include "xpersif/core/motion/push_motion.h"
#include "xpersif/decision/decision_common.h"
#include "xpersif/embodiment/robot_pose_source.h"  // sceneObstacles
#include "xpersif/ros/setup_loader.h"

namespace xpersif {

DesignOfExperiments::DesignOfExperiments(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/DesignOfExperimentsNodelet"),
      loader_("xpersif::core::ExperimentDesign", "experiment design") {
  core::Contract declared;
  declared.name = "design_experiment";
  declared.kind = core::Contract::Kind::Operation;
  declared.interface_type = "xpersif/DesignExperiment";
  declared.description = "the next push experiment, by the configured design or the request's (a declared design)";
  declared.parameters = {"?reachable"};
  declared.preconditions = {
      {"known_objects(?reachable)", "every object listed as reachable must be one of ~objects"},
      {"some_reachable(?reachable)", "at least one object must be reachable (listed, or seen by vision)"}};
  declared.effects = {"designed(experiment)"};
  ContractChecker<DesignExperiment::Request> contract(declared);
  contract
      .bind([](const DesignExperiment::Request& r) {
        return core::Bindings{{"?reachable", r.reachable.empty() ? "seen" : joinNames(r.reachable)}};
      })
      .check("known_objects(?reachable)",
             [this](const DesignExperiment::Request& r) {
               std::lock_guard<std::mutex> lock(mutex_);
               for (const auto& name : r.reachable) {
                 const std::string why = core::checkKnownName("reachable", name, objects_);
                 if (!why.empty()) return why;
               }
               return std::string();
             })
      .check("some_reachable(?reachable)", [this](const DesignExperiment::Request& r) {
        std::vector<std::string> objects;
        return candidates(r, &objects);
      });
  addOperation<DesignExperiment>(
      contract,
      [this](const DesignExperiment::Request& r) {
        core::requireMaxSize("reachable", r.reachable.size(), 64);
        core::requireMaxSize("scene_objects", r.scene_objects.size(), core::kMaxObjectsPerFeatureVector);
        core::requireMaxSize("scene_poses", r.scene_poses.size(), core::kMaxObjectsPerFeatureVector);
        if (r.scene_poses.size() != r.scene_objects.size()) {
          throw core::ValidationError("scene_poses has " + std::to_string(r.scene_poses.size()) + " poses for " +
                                      std::to_string(r.scene_objects.size()) +
                                      " scene_objects; they must be parallel");
        }
        for (std::size_t i = 0; i < r.scene_objects.size(); ++i) {
          const std::string at = "scene_poses[" + std::to_string(i) + "]";
          core::requireMaxLength("scene_objects[" + std::to_string(i) + "]", r.scene_objects[i], core::kMaxNameLength);
          core::requireFinite(at + ".x", r.scene_poses[i].x);
          core::requireFinite(at + ".y", r.scene_poses[i].y);
          core::requireFinite(at + ".theta", r.scene_poses[i].theta);
        }
        if (r.design.empty()) return;
        std::lock_guard<std::mutex> lock(loader_mutex_);
        const std::string why = loader_.whyNot("design", r.design);
        if (!why.empty()) throw core::ValidationError(why);
      },
      [this](const DesignExperiment::Request& request, DesignExperiment::Response& response) {
        design(request, response);
      });
}

const core::ParameterTable& DesignOfExperiments::parameters() {
  using core::ParameterSpec;
  static const core::ParameterTable table = [] {
    const core::DesignOptions d;
    core::ParameterTable own(
        "design_of_experiments",
        {core::textParameter("design", "curiosity",
                             "the design plugin: curiosity, random, grid, learning_progress, error_max or another "
                             "package's (doc/plugins.md)"),
         core::intParameter("seed", 1, 0, 2147483647, "the campaign's seed; every choice draws from (seed, run, experiment)"),
         core::numberParameter("min_offset", d.min_offset, -1.0, 1.0, "smallest offset, as a fraction of the face's limit"),
         core::numberParameter("max_offset", d.max_offset, -1.0, 1.0, "largest offset, as a fraction of the face's limit"),
         core::derivedParameter(ParameterSpec::Type::Double, "min_distance", "A / 40, from the scene", 1e-6, 100.0,
                                "m: shortest push after contact"),
         core::derivedParameter(ParameterSpec::Type::Double, "max_distance", "A / 4, from the scene", 1e-6, 100.0,
                                "m: longest push after contact"),
         core::numbersParameter("grid_offsets", d.grid_offsets, -1.0, 1.0, "grid design: offsets, fractions of the face's limit"),
         core::numbersParameter("grid_distances", d.grid_distances, 1e-6, 1.0,
                                "grid design: distances, fractions of ~max_distance"),
         core::intParameter("candidates", static_cast<int>(d.candidates), 1, 10000,
                            "curiosity design: candidate pushes sampled per decision"),
         core::numberParameter("epsilon", d.epsilon, 0.0, 1.0,
                               "probability of a random candidate (curiosity) or region (region_choice greedy)"),
         core::intParameter("offset_bins", 3, 1, 100, "offset bins per face of curiosity's regions (as MOTIVATION's)"),
         core::numberParameter("optimistic_curiosity", 1.0, -1e9, 1e9, "curiosity of a region not yet visited"),
         core::numberParameter("input_wait", 5.0, 0.01, 600.0,
                               "s a request waits for MOTIVATION's and the history's view of its run before it is "
                               "refused as UNAVAILABLE (LOOPMODEL asks again)"),
         core::intParameter("region_max_size", static_cast<int>(d.region_max_size), 4, 10000,
                            "region designs: a region holding more experiments is split"),
         core::intParameter("progress_window", static_cast<int>(d.progress_window), 1, 1000,
                            "region designs: held-out errors per window of the learning progress"),
         core::textParameter("region_choice", d.region_choice, "region designs: how a region is chosen",
                             {"softmax", "greedy"}),
         core::numberParameter("temperature", d.temperature, 0.001, 100.0,
                               "region designs: softmax temperature, relative to the largest interest"),
         core::numberParameter("random_share", d.random_share, 0.0, 1.0,
                               "region designs: probability of a uniformly random push over the whole space; "
                               "strategic_student and replicate_screening: the share of their choices spread evenly over the "
                               "objects"),
         core::numberParameter("progress_confidence", d.progress_confidence, 0.0, 10.0,
                               "learning_progress: progress counts only beyond this many standard errors of the "
                               "windows' difference (0: the plain difference)"),
         core::flagParameter("progress_at_most_error", d.progress_at_most_error,
                             "learning_progress: a region's progress counts at most its recent mean error (what is left "
                             "to learn)"),
         core::flagParameter("regions_per_object", d.regions_per_object,
                             "region designs: start with one region per object instead of one for the whole space"),
         core::flagParameter("feasible_only", true,
                             "choose only pushes MANIPULATION's planner would accept from the request's scene (a free "
                             "approach spot, no wall or object in the way): a refused push costs an experiment"),
         core::textParameter("features_topic", "vision/features", "VISION's feature vectors (which objects are seen)"),
         core::textParameter("motivation_topic", "motivation/motivation", "MOTIVATION's regions and curiosity")});
    own.include(ExperimentFollower::Options::parameters()).include(setupCatalogueParameters());
    return own;
  }();
  return table;
}

void DesignOfExperiments::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, DesignOfExperiments::parameters());
  // The objects and the push limits come from XPERSim's scene (~objects may leave some out).
  const core::SetupCatalogue scene = loadSceneCatalogue(nodeHandle(), pnh);
  const core::SetupCatalogue catalogue = restrictedToObjectsParameter(scene, pnh);
  core::DesignOptions options;
  const std::string design = parameters.get<std::string>("design");
  const int seed = parameters.get<int>("seed");
  options.min_offset = parameters.get<double>("min_offset");
  options.max_offset = parameters.get<double>("max_offset");
  options.min_distance = parameters.get<double>("min_distance", catalogue.minPushDistance());
  options.max_distance = parameters.get<double>("max_distance", catalogue.maxPushDistance());
  options.grid_offsets = parameters.get<std::vector<double>>("grid_offsets");
  options.grid_distances = parameters.get<std::vector<double>>("grid_distances");
  options.candidates = static_cast<std::size_t>(parameters.get<int>("candidates"));
  options.epsilon = parameters.get<double>("epsilon");
  const int offset_bins = parameters.get<int>("offset_bins");
  const double optimistic = parameters.get<double>("optimistic_curiosity");
  const double input_wait = parameters.get<double>("input_wait");
  options.region_max_size = static_cast<std::size_t>(parameters.get<int>("region_max_size"));
  options.progress_window = static_cast<std::size_t>(parameters.get<int>("progress_window"));
  options.region_choice = parameters.get<std::string>("region_choice");
  options.temperature = parameters.get<double>("temperature");
  options.random_share = parameters.get<double>("random_share");
  options.progress_confidence = parameters.get<double>("progress_confidence");
  options.regions_per_object = parameters.get<bool>("regions_per_object");
  options.progress_at_most_error = parameters.get<bool>("progress_at_most_error");
  const bool feasible_only = parameters.get<bool>("feasible_only");
  const ExperimentFollower::Options follow = ExperimentFollower::Options::fromParameters(pnh, name());
  const std::string features_topic = parameters.get<std::string>("features_topic");
  const std::string motivation_topic = parameters.get<std::string>("motivation_topic");
  // Throws for an undeclared design (listing the declared ones) or bad options.
  auto made = makeDesign("~design", design, static_cast<unsigned long>(seed), options);
  core::CuriosityConfig regions;
  regions.objects = catalogue.names();
  for (const auto& object : catalogue.objects) regions.footprints[object.name] = object.footprint;
  regions.offset_bins = offset_bins;
  auto map = std::make_unique<core::CuriosityMap>(regions);  // throws for bad objects or bins

  // Resubscribe outside the lock (a callback may hold it).
  features_sub_.shutdown();
  motivation_sub_.shutdown();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    design_name_ = design;
    design_ = std::move(made);
    seed_ = static_cast<unsigned long>(seed);
    options_ = options;
    regions_ = std::move(map);
    objects_ = catalogue.names();
    footprints_.clear();
    for (const auto& object : scene.objects) footprints_[object.name] = object.footprint;
    arena_.size_x = catalogue.arena_size_x;
    arena_.size_y = catalogue.arena_size_y;
    robot_radius_ = catalogue.robot_radius;
    feasible_only_ = feasible_only;
    optimistic_ = optimistic;
    input_wait_ = input_wait;
    designed_ = 0;
    curiosity_.clear();
    have_motivation_ = false;
    motivation_run_ = 0;
    motivation_scored_ = 0;
    latest_features_.reset();
    features_topic_ = nodeHandle().resolveName(features_topic);
    follow_ = follow;
  }
  features_sub_ = nodeHandle().subscribe<FeatureVector>(features_topic, 2, &DesignOfExperiments::onFeatures, this);
  motivation_sub_ = nodeHandle().subscribe<Motivation>(motivation_topic, 2, &DesignOfExperiments::onMotivation, this);
}

std::shared_ptr<core::ExperimentDesign> DesignOfExperiments::makeDesign(const std::string& parameter,
                                                                       const std::string& type, unsigned long seed,
                                                                       const core::DesignOptions& options) {
  std::shared_ptr<core::ExperimentDesign> made;
  {
    std::lock_guard<std::mutex> lock(loader_mutex_);
    made = loader_.create(parameter, type);
  }
  made->initialize(seed, options);
  return made;
}

void DesignOfExperiments::onActivate() {
  if (follower_) follower_->stop();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    history_run_ = 0;
    history_.clear();
    history_done_ = 0;
  }
  follower_ = std::make_unique<ExperimentFollower>(
      nodeHandle(), follow_,
      [this](std::uint64_t run, const std::vector<ExperimentRecord>& records) { resetHistory(run, records); },
      [this](const ExperimentRecord& record) { addHistory(record); });
  follower_->start();
}

void DesignOfExperiments::onDeactivate() {
  if (follower_) follower_->stop();
}

void DesignOfExperiments::onShutdown() {
  if (follower_) follower_->stop();
  follower_.reset();
  features_sub_.shutdown();
  motivation_sub_.shutdown();
}

namespace {
/// A record as the region designs see it: a successful experiment and its held-out error; none otherwise.
std::optional<core::PastExperiment> pastExperiment(const ExperimentRecord& r) {
  if (r.status != "done" || r.predicted_mean.size() != 3 || !std::isfinite(r.surprise) || r.surprise < 0 ||
      !std::isfinite(r.dx) || !std::isfinite(r.dy)) {
    return std::nullopt;
  }
  return core::PastExperiment{r.experiment.object, r.experiment.side, r.experiment.offset, r.experiment.distance,
                              r.surprise, r.dx, r.dy};
}
}  // namespace

void DesignOfExperiments::resetHistory(std::uint64_t run_id, const std::vector<ExperimentRecord>& records) {
  std::lock_guard<std::mutex> lock(mutex_);
  history_run_ = run_id;
  history_.clear();
  history_done_ = 0;
  for (const auto& r : records) {
    if (r.status == "done") ++history_done_;
    if (auto past = pastExperiment(r)) history_.push_back(*past);
  }
  history_grew_.notify_all();
}

void DesignOfExperiments::addHistory(const ExperimentRecord& record) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (record.run_id != history_run_) {  // the follower resets first; this only guards against a stray record
    history_run_ = record.run_id;
    history_.clear();
    history_done_ = 0;
  }
  if (record.status == "done") ++history_done_;
  if (auto past = pastExperiment(record)) history_.push_back(*past);
  history_grew_.notify_all();
}

void DesignOfExperiments::onFeatures(const FeatureVector::ConstPtr& features) {
  std::lock_guard<std::mutex> lock(mutex_);
  latest_features_ = features;
}

void DesignOfExperiments::onMotivation(const Motivation::ConstPtr& motivation) {
  std::map<std::string, double> curiosity;
  const std::size_t n = std::min(motivation->regions.size(), motivation->curiosity.size());
  for (std::size_t i = 0; i < n; ++i) curiosity[motivation->regions[i]] = motivation->curiosity[i];
  std::lock_guard<std::mutex> lock(mutex_);
  curiosity_ = std::move(curiosity);
  have_motivation_ = true;
  motivation_run_ = motivation->run_id;
  motivation_scored_ = motivation->experiments;
  motivated_.notify_all();
}

std::string DesignOfExperiments::candidates(const DesignExperiment::Request& request,
                                            std::vector<std::string>* objects) const {
  std::lock_guard<std::mutex> lock(mutex_);
  objects->clear();
  if (!request.reachable.empty()) {
    for (const auto& name : request.reachable) {
      if (std::find(objects_.begin(), objects_.end(), name) != objects_.end()) objects->push_back(name);
    }
    return objects->empty() ? "none of the listed objects is one of ~objects " + joinNames(objects_) : "";
  }
  // The request's scene, when it has one: what the caller observed at this step, not the latest vector heard,
  // which may be of another moment (during the last push) from one run of the same campaign to the next.
  if (!request.scene_objects.empty()) {
    for (const auto& name : request.scene_objects) {
      if (std::find(objects_.begin(), objects_.end(), name) != objects_.end()) objects->push_back(name);
    }
    return objects->empty() ? "the request's scene shows none of ~objects " + joinNames(objects_) : "";
  }
  if (!latest_features_) {
    return "the request lists no reachable object and no feature vector has arrived on " +
           features_topic_ + " yet";
  }
  for (const auto& o : latest_features_->objects) {
    if (std::find(objects_.begin(), objects_.end(), o.name) != objects_.end()) objects->push_back(o.name);
  }
  return objects->empty() ? "the latest feature vector shows none of ~objects " + joinNames(objects_) : "";
}

std::string DesignOfExperiments::awaitInputs(const DesignExperiment::Request& request,
                                             std::unique_lock<std::mutex>& lock) {
  const auto wait = std::chrono::duration<double>(input_wait_);
  const auto of_run = [&](std::uint64_t run) { return request.run_id == 0 || run == request.run_id; };
  if (design_->usesCuriosity() &&
      !motivated_.wait_for(lock, wait, [&] { return of_run(motivation_run_) && motivation_scored_ >= request.scored; })) {
    const std::string latest = have_motivation_ ? "its latest message: run " + std::to_string(motivation_run_) + ", " +
                                                      std::to_string(motivation_scored_) + " experiments"
                                                : "no message from it heard yet";
    return "MOTIVATION has not yet spoken of the run's first " + std::to_string(request.scored) +
           " successful experiments (" + latest + "; this request: run " + std::to_string(request.run_id) + ")";
  }
  if (design_->usesHistory() &&
      !history_grew_.wait_for(lock, wait, [&] { return of_run(history_run_) && history_done_ >= request.scored; })) {
    return "the knowledge base's successful experiments of run " + std::to_string(request.run_id) +
           " have not all arrived (" + std::to_string(of_run(history_run_) ? history_done_ : 0) + " of " +
           std::to_string(request.scored) + ")";
  }
  return "";
}

void DesignOfExperiments::design(const DesignExperiment::Request& request, DesignExperiment::Response& response) {
  std::vector<std::string> reachable;
  const std::string why = candidates(request, &reachable);
  if (!why.empty()) throw core::ValidationError(why);
  std::unique_lock<std::mutex> lock(mutex_);
  if (!design_) throw std::runtime_error("not configured");
  // A run may ask for another design than ~design (LOOPMODEL passes the run's): switch, seeded as configured.
  if (!request.design.empty() && request.design != design_name_) {
    design_ = makeDesign("design", request.design, seed_, options_);
    design_name_ = request.design;
    designed_ = 0;
  }
  const std::string missing = awaitInputs(request, lock);
  if (!missing.empty()) throw core::UnavailableError(missing);
  core::DesignContext context;
  if (design_->usesHistory() && (request.run_id == 0 || history_run_ == request.run_id)) context.history = history_;
  const std::set<std::string> can(reachable.begin(), reachable.end());
  for (const auto& name : objects_) context.objects.push_back({name, can.count(name) > 0, footprints_.at(name)});
  context.history_count = request.seeded ? request.experiment : designed_;
  if (request.seeded) context.stream = request.stream;
  // Only pushes MANIPULATION's planner would accept from where the request's scene has the objects (as GOALDESIGN
  // chooses its pushes). An object of ~objects the scene lacks cannot be pushed; every object of the scene, in
  // ~objects or not, is in the way (MANIPULATION refuses a push into any of them).
  if (feasible_only_ && !request.scene_objects.empty()) {
    auto others = sceneObstacles(request.scene_objects, request.scene_poses, footprints_);
    context.feasible = [this, others = std::move(others)](const core::ExperimentChoice& c) {
      const auto seen = std::find_if(others.begin(), others.end(), [&](const auto& o) { return o.name == c.object; });
      if (seen == others.end()) return false;
      core::PushOptions push;
      push.max_distance = c.distance;  // the distance's limit is MANIPULATION's valid_push, not checked here
      return core::planPush(*seen, {c.object, c.side, c.offset, c.distance}, robot_radius_, arena_, others, push).ok;
    };
  }
  // Curiosity of a candidate: MOTIVATION's value for its region, optimistic where it has none.
  context.curiosity = [this](const core::ExperimentChoice& c) {
    const core::RegionKey key = regions_->regionOf(core::Experiment{c.object, c.side, c.offset, c.distance});
    const auto found = curiosity_.find(key.toString());
    return found == curiosity_.end() ? optimistic_ : found->second;
  };
  const core::ExperimentChoice choice = design_->next(context);
  ++designed_;
  response.experiment = toMsg(core::Experiment{choice.object, choice.side, choice.offset, choice.distance});
  response.design = design_name_;
  response.rationale = choice.rationale;
  if (design_->usesCuriosity()) {
    const core::RegionKey key = regions_->regionOf(fromMsg(response.experiment));
    const auto found = curiosity_.find(key.toString());
    response.rationale += "; region " + key.toString() + " curiosity " +
                          core::describeNumber(found == curiosity_.end() ? optimistic_ : found->second) +
                          (have_motivation_ ? "" : " (no motivation yet: every region unexplored)");
  }
  response.message = choice.toString();
  // The inputs beside the choice, one line per design: when two runs of one seed part, their logs say which input
  // differed (the determinism test prints these lines of both).
  std::ostringstream scene;
  scene.precision(5);
  for (std::size_t i = 0; i < request.scene_objects.size() && i < request.scene_poses.size(); ++i) {
    scene << (i ? " " : "") << request.scene_objects[i] << "@" << request.scene_poses[i].x << ","
          << request.scene_poses[i].y << "," << request.scene_poses[i].theta;
  }
  ROS_INFO("%s: designed run %lu experiment %u: %s; %s; stream %llu; scene %s", name().c_str(),
           static_cast<unsigned long>(request.run_id), request.experiment + 1, response.message.c_str(),
           response.rationale.c_str(), static_cast<unsigned long long>(request.stream), scene.str().c_str());
}

}  // namespace xpersif
