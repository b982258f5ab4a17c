#include "xpersif/decision/goal_design.h"

#include "xpersif/component/parameter_reader.h"

#include <algorithm>
#include <cmath>

#include "xpersif/decision/decision_common.h"
#include "xpersif/embodiment/robot_pose_source.h"  // sceneObstacles
#include "xpersif/ros/setup_loader.h"

namespace xpersif {

GoalDesign::GoalDesign(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/GoalDesignNodelet"),
      loader_("xpersif::core::PushModel", "push model") {
  // ---- design_goal -------------------------------------------------------------------------------------
  core::Contract goal;
  goal.name = "design_goal";
  goal.kind = core::Contract::Kind::Operation;
  goal.interface_type = "xpersif/DesignGoal";
  goal.description = "a goal to reach with what has been learned: a movable object and a target one to several pushes away";
  goal.preconditions = {{"learned(model)", "MACHINELEARNING must have published a model"},
                        {"valid(scene)", "the scene must be finite numbers"},
                        {"valid(tolerance)", "the tolerance must be 0..1 m"}};
  goal.effects = {"designed(goal)"};
  ContractChecker<DesignGoal::Request> goal_contract(goal);
  goal_contract.check("learned(model)", [this](const DesignGoal::Request&) { return whyNoModel(); })
      .check("valid(scene)", [](const DesignGoal::Request& r) { return checkScene(r.scene); })
      .check("valid(tolerance)",
             [](const DesignGoal::Request& r) { return core::checkInRange("tolerance", r.tolerance, 0.0, 1.0); });
  addOperation<DesignGoal>(
      goal_contract, nullptr,
      [this](const DesignGoal::Request& request, DesignGoal::Response& response) { designGoal(request, response); });

  // ---- choose_push -------------------------------------------------------------------------------------
  core::Contract choose;
  choose.name = "choose_push";
  choose.kind = core::Contract::Kind::Operation;
  choose.interface_type = "xpersif/ChoosePush";
  choose.description =
      "the push the learned model expects to bring the object closest to the target, its uncertainty counted";
  choose.parameters = {"?object"};
  choose.preconditions = {{"learned(model)", "MACHINELEARNING must have published a model"},
                          {"valid(scene)", "the scene must be finite numbers"},
                          {"in_scene(?object)", "the object must be in the scene"},
                          {"finite(target)", "the target must be finite numbers"}};
  choose.effects = {"chosen(?object)"};
  ContractChecker<ChoosePush::Request> choose_contract(choose);
  choose_contract.bind([](const ChoosePush::Request& r) { return core::Bindings{{"?object", r.object}}; })
      .check("learned(model)", [this](const ChoosePush::Request&) { return whyNoModel(); })
      .check("valid(scene)", [](const ChoosePush::Request& r) { return checkScene(r.scene); })
      .check("in_scene(?object)",
             [](const ChoosePush::Request& r) {
               return findObject(r.scene, r.object) ? std::string()
                                                    : "the scene has no object named '" + r.object + "'";
             })
      .check("finite(target)",
             [](const ChoosePush::Request& r) { return core::checkAllFinite("target", {r.target_x, r.target_y}); });
  addOperation<ChoosePush>(
      choose_contract, nullptr,
      [this](const ChoosePush::Request& request, ChoosePush::Response& response) { choosePush(request, response); });
}

const core::ParameterTable& GoalDesign::parameters() {
  using core::ParameterSpec;
  static const core::ParameterTable table = [] {
    core::ParameterTable own(
        "goal_design",
        {core::intParameter("seed", 1, 0, 2147483647, "the campaign's seed; goals and candidates draw from (seed, run, goal)"),
         core::derivedParameter(ParameterSpec::Type::Double, "min_target_distance", "L / 3 (L the longest push)", 0.001,
                                1.0, "m: nearest target from the object"),
         core::derivedParameter(ParameterSpec::Type::Double, "max_target_distance", "L", 0.001, 1.0,
                                "m: farthest target from the object (at least ~min_target_distance)"),
         core::derivedParameter(ParameterSpec::Type::Double, "wall_clearance", "c + 1.5 R", 0.0, 1.0,
                                "m: a target's distance from the walls"),
         core::derivedParameter(ParameterSpec::Type::Double, "object_clearance", "2 c", 0.0, 1.0,
                                "m: a target's distance from the other objects"),
         core::numbersParameter("offsets", {-0.75, -0.375, 0.0, 0.375, 0.75}, -1.0, 1.0,
                                "candidate pushes' offsets, fractions of each face's limit"),
         core::numbersParameter("distances", {0.15, 0.3, 0.45, 0.6, 0.75, 0.9}, 1e-3, 1.0,
                                "candidate pushes' distances, fractions of the longest push"),
         core::intParameter("random_candidates", 256, 0, 100000, "seeded random candidate pushes besides the grid"),
         core::numberParameter("uncertainty_weight", 1.0, 0.0, 100.0,
                               "weight of the predicted end's variance against its squared distance to the target"),
         core::textParameter("model_topic", "machine_learning/model", "MACHINELEARNING's published model"),
         core::textParameter("notions_topic", "machine_learning/notions", "MACHINELEARNING's notions")});
    own.include(setupCatalogueParameters());
    return own;
  }();
  return table;
}

void GoalDesign::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, GoalDesign::parameters());
  // Objects, the arena and every distance below come from XPERSim's scene (~objects may leave some out).
  const core::SetupCatalogue catalogue = loadSetupCatalogue(nodeHandle(), pnh);
  double largest = 0;  // the largest object's circumradius
  for (const auto& o : catalogue.objects) largest = std::max(largest, o.footprint.circumradius());
  const double max_push = catalogue.maxPushDistance();
  // Targets one to several pushes away (a third of the longest push to the longest: 5-15 cm in a 0.6 m arena);
  // a target keeps the object's own size plus room for the robot to reach round it from the walls, and an
  // object's width from the others.
  const int seed = parameters.get<int>("seed");
  const double min_target = parameters.get<double>("min_target_distance", max_push / 3);
  const double max_target = parameters.get<double>("max_target_distance", max_push);
  core::requireInRange("~max_target_distance", max_target, min_target, 1.0);
  const double wall_clearance = parameters.get<double>("wall_clearance", largest + 1.5 * catalogue.robot_radius);
  const double object_clearance = parameters.get<double>("object_clearance", 2 * largest);
  const std::vector<double> offsets = parameters.get<std::vector<double>>("offsets");
  const std::vector<double> distances = parameters.get<std::vector<double>>("distances");
  const int random_candidates = parameters.get<int>("random_candidates");
  const double uncertainty_weight = parameters.get<double>("uncertainty_weight");
  const std::string model_topic = parameters.get<std::string>("model_topic");
  const std::string notions_topic = parameters.get<std::string>("notions_topic");
  if (offsets.empty() && distances.empty() && random_candidates == 0) {
    throw core::ValidationError("~offsets, ~distances and ~random_candidates leave no candidate push");
  }
  model_sub_.shutdown();  // outside the lock: a callback may hold it
  notions_sub_.shutdown();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    objects_ = catalogue.names();
    footprints_.clear();
    for (const auto& o : catalogue.objects) footprints_[o.name] = o.footprint;
    max_push_ = max_push;
    min_push_ = catalogue.minPushDistance();
    min_target_ = min_target;
    max_target_ = max_target;
    wall_clearance_ = wall_clearance;
    object_clearance_ = object_clearance;
    offsets_ = offsets;
    distances_ = distances;
    random_candidates_ = random_candidates;
    uncertainty_weight_ = uncertainty_weight;
    arena_.size_x = catalogue.arena_size_x;
    arena_.size_y = catalogue.arena_size_y;
    robot_radius_ = catalogue.robot_radius;
    rng_.seed(static_cast<std::uint64_t>(seed));
    learner_.reset();
    model_problem_.clear();
    immobile_.clear();
    model_topic_ = nodeHandle().resolveName(model_topic);
  }
  model_sub_ = nodeHandle().subscribe<LearnedModel>(model_topic, 1, &GoalDesign::onModel, this);
  notions_sub_ = nodeHandle().subscribe<Notions>(notions_topic, 1, &GoalDesign::onNotions, this);
}

void GoalDesign::onShutdown() {
  model_sub_.shutdown();
  notions_sub_.shutdown();
}

void GoalDesign::onModel(const LearnedModel::ConstPtr& model) {
  // Load outside the lock (it retrains): operations keep answering with the previous model meanwhile.
  std::string problem;
  auto learner = modelFor(model->format, &problem);
  if (learner) {
    try {
      learner->load(model->data);
    } catch (const std::exception& e) {
      problem = std::string("the model could not be loaded: ") + e.what();
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  model_problem_ = problem;
  if (!problem.empty()) {
    ROS_WARN_STREAM(name() << ": " << problem);
    return;
  }
  learner_ = std::move(learner);
  model_run_ = model->run_id;
  model_features_ = model->features;
  modelled_.notify_all();
}

std::shared_ptr<core::PushModel> GoalDesign::modelFor(const std::string& format, std::string* why) {
  std::lock_guard<std::mutex> lock(loader_mutex_);
  auto known = formats_.find(format);
  if (known == formats_.end()) {
    // Ask every declared class not asked yet which format it reads (a default-constructed instance is cheap).
    for (const auto& type : loader_.declared()) {
      bool asked = false;
      for (const auto& [f, t] : formats_) asked = asked || t == type;
      if (asked) continue;
      try {
        formats_.emplace(loader_.create("push model", type)->format(), type);
      } catch (const std::exception& e) {
        ROS_WARN("%s: the declared push model '%s' cannot be made: %s", name().c_str(), type.c_str(), e.what());
      }
    }
    known = formats_.find(format);
  }
  if (known == formats_.end()) {
    std::string formats;
    for (const auto& [f, t] : formats_) formats += (formats.empty() ? "" : ", ") + f + " (" + t + ")";
    *why = "the model's format is '" + format + "', which no declared push model reads; they read: " + formats;
    return nullptr;
  }
  try {
    return loader_.create("push model", known->second);
  } catch (const std::exception& e) {
    *why = e.what();
    return nullptr;
  }
}

void GoalDesign::onNotions(const Notions::ConstPtr& notions) {
  std::set<std::string> immobile;
  for (const auto& n : notions->notions) {
    if (n.predicate == "does_not_move_when_pushed") immobile.insert(n.subject);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  immobile_ = std::move(immobile);
}

std::string GoalDesign::whyNoModel() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (learner_) return "";
  return "no learned model has arrived on " + model_topic_ + " yet" +
         (model_problem_.empty() ? "" : " (" + model_problem_ + ")");
}

void GoalDesign::waitForSamples(std::unique_lock<std::mutex>& lock, std::uint32_t samples,
                                const std::vector<std::string>& features) {
  if (samples == 0 && features.empty()) return;
  // The features too: a model retrained on FEATURESELECTION's choice has as many samples as the one before it.
  if (!modelled_.wait_for(lock, std::chrono::seconds(20), [&] {
        return learner_ && learner_->sampleCount() >= samples && (features.empty() || model_features_ == features);
      })) {
    ROS_WARN("%s: no model of %u samples (and the features asked for) within 20 s; going on with the one it has",
             name().c_str(), samples);
  }
}

void GoalDesign::designGoal(const DesignGoal::Request& request, DesignGoal::Response& response) {
  std::unique_lock<std::mutex> lock(mutex_);
  waitForSamples(lock, request.samples, request.features);
  std::vector<const ObjectFeatures*> movable;
  std::vector<std::string> skipped;
  for (const auto& o : request.scene.objects) {
    if (std::find(objects_.begin(), objects_.end(), o.name) == objects_.end()) continue;
    if (immobile_.count(o.name)) {
      skipped.push_back(o.name);
      continue;
    }
    movable.push_back(&o);
  }
  if (movable.empty()) {
    throw std::runtime_error("no movable object in the scene (of ~objects " + joinNames(objects_) + "; " +
                             joinNames(skipped) + " do not move when pushed)");
  }
  // A goal the model cannot reach on purpose proves nothing: keep the objects whose pushes it predicts within
  // the tolerance; while none is (early on), those predicted at most twice as loosely as the best one.
  std::string loose;
  if (request.tolerance > 0 && learner_ && learner_->sampleCount() > 0) {
    std::vector<double> spreads;
    for (const ObjectFeatures* o : movable) spreads.push_back(predictedSpread(fromMsg(*o)));
    const double best = *std::min_element(spreads.begin(), spreads.end());
    const double limit = std::max(request.tolerance, 2 * best);
    std::vector<const ObjectFeatures*> predictable;
    for (std::size_t i = 0; i < movable.size(); ++i) {
      if (spreads[i] <= limit) {
        predictable.push_back(movable[i]);
      } else {
        loose += (loose.empty() ? "" : ", ") + movable[i]->name + " (+-" + core::describeNumber(spreads[i]) + " m)";
      }
    }
    movable = predictable;
    if (!loose.empty()) loose += ": the model predicts their pushes more loosely than " + core::describeNumber(limit) + " m";
  }
  if (request.seeded) rng_.seed(request.stream);
  std::shuffle(movable.begin(), movable.end(), rng_);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), distance(min_target_, max_target_);
  const double half_x = arena_.size_x / 2 - wall_clearance_, half_y = arena_.size_y / 2 - wall_clearance_;
  for (const ObjectFeatures* object : movable) {
    for (int attempt = 0; attempt < 200; ++attempt) {
      const double a = angle(rng_), d = distance(rng_);
      const double x = object->position.x + d * std::cos(a), y = object->position.y + d * std::sin(a);
      if (std::abs(x) > half_x || std::abs(y) > half_y) continue;
      const bool crowded = std::any_of(request.scene.objects.begin(), request.scene.objects.end(), [&](const auto& o) {
        return &o != object && std::hypot(o.position.x - x, o.position.y - y) < object_clearance_;
      });
      if (crowded) continue;
      response.object = object->name;
      response.target_x = x;
      response.target_y = y;
      response.message = "bring " + object->name + " " + core::describeNumber(d) + " m to (" +
                         core::describeNumber(x) + ", " + core::describeNumber(y) + ")" +
                         (skipped.empty() ? "" : "; not " + joinNames(skipped) + ": they do not move when pushed") +
                         (loose.empty() ? "" : "; not " + loose);
      return;
    }
  }
  throw std::runtime_error("no target " + core::describeNumber(min_target_) + "-" + core::describeNumber(max_target_) +
                           " m from a movable object lies " + core::describeNumber(wall_clearance_) +
                           " m inside the walls and away from the other objects");
}

std::vector<core::Experiment> GoalDesign::gridPushes(const std::string& object,
                                                     const core::Footprint& footprint) const {
  std::vector<core::Experiment> pushes;
  for (const auto& side : core::pushSides()) {
    const double limit = core::maxPushOffset(footprint, side);
    for (double offset : offsets_) {
      for (double distance : distances_) pushes.push_back({object, side, offset * limit, distance * max_push_});
    }
  }
  return pushes;
}

double GoalDesign::predictedSpread(const core::ObjectFeatures& object) const {
  const auto footprint = footprints_.find(object.name);
  if (footprint == footprints_.end()) return INFINITY;
  return core::predictedSpread(*learner_, object, gridPushes(object.name, footprint->second));
}

void GoalDesign::choosePush(const ChoosePush::Request& request, ChoosePush::Response& response) {
  std::unique_lock<std::mutex> lock(mutex_);
  waitForSamples(lock, request.samples, request.features);
  if (!learner_) throw core::UnavailableError("no learned model has arrived yet");
  const core::ObjectFeatures object = fromMsg(*findObject(request.scene, request.object));
  const auto footprint = footprints_.find(request.object);
  if (footprint == footprints_.end()) {
    throw core::ValidationError("object '" + request.object + "' is not one of ~objects " + joinNames(objects_));
  }
  std::vector<core::Experiment> candidates = gridPushes(request.object, footprint->second);
  if (request.seeded) rng_.seed(request.stream);
  std::uniform_int_distribution<std::size_t> side(0, core::pushSides().size() - 1);
  std::uniform_real_distribution<double> offset(-1.0, 1.0), distance(min_push_, max_push_);
  for (int i = 0; i < random_candidates_; ++i) {
    const std::string& s = core::pushSides()[side(rng_)];
    const double o = offset(rng_) * core::maxPushOffset(footprint->second, s);
    candidates.push_back({request.object, s, o, distance(rng_)});
  }
  // Only pushes MANIPULATION would accept from here (its planner: a free approach spot, no wall or object in
  // the way): a refused push teaches nothing and, chosen again from the same scene, would be refused again.
  const core::Obstacle pushed{request.object, object.x, object.y, object.yaw, footprint->second};
  const std::vector<core::Obstacle> others = sceneObstacles(request.scene, footprints_);  // planPush skips `pushed`
  core::PushOptions options;
  options.max_distance = max_push_;
  std::string refused;
  candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                  [&](const core::Experiment& c) {
                                    const core::PushPlan plan = core::planPush(
                                        pushed, {c.object, c.side, c.offset, c.distance}, robot_radius_, arena_,
                                        others, options);
                                    if (!plan.ok && refused.empty()) refused = plan.reason;
                                    return !plan.ok;
                                  }),
                   candidates.end());
  if (candidates.empty()) {
    throw std::runtime_error("no push of " + request.object + " is possible from where it is (for example: " +
                             refused + ")");
  }
  // The least expected squared distance to the target, the end's variance counted: a push the model is sure of
  // beats one that only might land closer.
  const core::PushChoice best =
      core::bestPush(*learner_, object, request.target_x, request.target_y, candidates, uncertainty_weight_);
  response.experiment = toMsg(best.experiment);
  response.expected_error = best.expected_error;
  response.message = "push " + request.object + " on " + response.experiment.side + ", offset " +
                     core::describeNumber(response.experiment.offset) + " m, distance " +
                     core::describeNumber(response.experiment.distance) + " m: expected " +
                     core::describeNumber(best.expected_error) + " m from the target, give or take " +
                     core::describeNumber(best.spread) + " m (" + std::to_string(candidates.size()) +
                     " candidates, model of " + std::to_string(learner_->sampleCount()) + " samples)";
}

}  // namespace xpersif
