// design_replay: a design's campaign replayed offline on a study's pushes, for many seeds at once (bench/loop.md,
// "Learning progress offline"). ROS-free.
//
//   design_replay --world FILE --evaluation-database FILE --pool DB [--pool DB ...] [--budget N (200)]
//                 [--seeds S (20)] [--every K (10)] [--learner shared|per_object (per_object)]
//                 [--design NAME (learning_progress)] [--region-max-size N (15)] [--window W (10)]
//                 [--confidence Z (0)] [--per-object 0|1 (0)] [--at-most-error 0|1 (0)] [--temperature T (0.1)]
//                 [--random-share R (0.2)]
//
// The pool is every successful designed experiment of the pool's knowledge bases (a study's random cells), by
// object. Each seed runs random design and the named design for N experiments as the loop does, except that the
// simulator is replaced by the pool: the design chooses (object, side, offset, distance) from the history of held-out
// errors, and the push done is the pool's push of that object nearest to the choice (same side first, then offset
// fraction and distance) not used yet in this campaign (once an object's pushes are all used, the nearest of them
// again: a repeated push teaches nothing new). Its held-out error is that of the learner trained on the campaign's
// pushes so far (core::surprise, as LOOPMODEL's `surprise`). The campaign's learning curve on the study's evaluation
// set is computed as the study does (core::learningCurve). What it cannot show: outcomes that differ from every
// pooled one, and the time a push takes. Printed: per design, the mean curve, the experiments needed to reach the
// same seed's random final error (median, never), and each object's share after the first 50 experiments.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>

#include "xpersif/core/evaluation/evaluation.h"
#include "xpersif/core/planning/experiment_design.h"
#include "xpersif/core/learning/motivation.h"
#include "xpersif/core/learning/per_object_push_model.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/learning/push_learner.h"
#include "xpersif/core/common/random_stream.h"
#include "xpersif/core/common/setup.h"
#include "xpersif/core/sim/world_spec.h"

using namespace xpersif::core;

namespace {

struct Campaign {
  std::vector<PushSample> pushes;
  LearningCurve curve;
};

/// The pool's push of @p object nearest to @p choice, preferring unused ones; marks it used.
const PushSample& nearest(const std::vector<PushSample>& pushes, std::vector<bool>& used, const ExperimentChoice& choice,
                          const Footprint& footprint, double max_distance) {
  auto cost = [&](const PushSample& s) {
    const Experiment& e = s.input.experiment;
    const double limit = maxPushOffset(footprint, e.side);
    const double choice_limit = maxPushOffset(footprint, choice.side);
    const double u = limit > 0 ? e.offset / limit : 0.0, v = choice_limit > 0 ? choice.offset / choice_limit : 0.0;
    return (e.side == choice.side ? 0.0 : 10.0) + std::fabs(u - v) + std::fabs(e.distance - choice.distance) / max_distance;
  };
  std::size_t best = pushes.size();
  for (int pass = 0; pass < 2 && best == pushes.size(); ++pass) {
    for (std::size_t i = 0; i < pushes.size(); ++i) {
      if (pass == 0 && used[i]) continue;
      if (best == pushes.size() || cost(pushes[i]) < cost(pushes[best])) best = i;
    }
  }
  used[best] = true;
  return pushes[best];
}

}  // namespace

int main(int argc, char** argv) {
  std::string world, evaluation_database, learner = "per_object", design_name = "learning_progress";
  std::vector<std::string> pool_databases;
  int budget = 200, seeds = 20, every = 10;
  DesignOptions options;
  options.region_max_size = 15;
  for (int i = 1; i < argc; i += 2) {
    const std::string key = argv[i];
    if (i + 1 >= argc) {
      std::cerr << "design_replay: " << key << " needs a value\n";
      return 2;
    }
    const std::string value = argv[i + 1];
    if (key == "--world") world = value;
    else if (key == "--evaluation-database") evaluation_database = value;
    else if (key == "--pool") pool_databases.push_back(value);
    else if (key == "--budget") budget = std::atoi(value.c_str());
    else if (key == "--seeds") seeds = std::atoi(value.c_str());
    else if (key == "--every") every = std::atoi(value.c_str());
    else if (key == "--learner") learner = value;
    else if (key == "--design") design_name = value;
    else if (key == "--region-max-size") options.region_max_size = std::strtoul(value.c_str(), nullptr, 10);
    else if (key == "--window") options.progress_window = std::strtoul(value.c_str(), nullptr, 10);
    else if (key == "--confidence") options.progress_confidence = std::atof(value.c_str());
    else if (key == "--per-object") options.regions_per_object = value == "1" || value == "true";
    else if (key == "--at-most-error") options.progress_at_most_error = value == "1" || value == "true";
    else if (key == "--temperature") options.temperature = std::atof(value.c_str());
    else if (key == "--random-share") options.random_share = std::atof(value.c_str());
    else {
      std::cerr << "design_replay: unknown option " << key << "\n";
      return 2;
    }
  }
  if (world.empty() || evaluation_database.empty() || pool_databases.empty() || budget < 1 || seeds < 1 ||
      every < 1 || (learner != "shared" && learner != "per_object")) {
    std::cerr << "usage: design_replay --world FILE --evaluation-database FILE --pool DB [--pool DB ...] [--budget N] "
                 "[--seeds S] [--every K] [--learner shared|per_object] [--design NAME] [--region-max-size N] "
                 "[--window W] [--confidence Z] [--per-object 0|1] [--at-most-error 0|1] [--temperature T] "
                 "[--random-share R]\n";
    return 2;
  }
  try {
    PhysicsWorld physics(loadWorldFile(world));
    const SetupCatalogue catalogue = SetupCatalogue::fromScene(physics.scene());
    options.min_distance = catalogue.minPushDistance();
    options.max_distance = catalogue.maxPushDistance();
    options.validate();

    const EvaluationSet evaluation_set = loadEvaluationSet(evaluation_database);
    const std::vector<std::string>& identities = evaluation_set.identities;
    const std::vector<PushSample>& evaluation = evaluation_set.samples;
    const PushLearnerConfig config = loopLearnerConfig(identities);
    const LearnerScope scope = learner == "per_object" ? LearnerScope::PerObject : LearnerScope::Shared;

    std::map<std::string, std::vector<PushSample>> pool;
    for (const auto& database : pool_databases) {
      for (const auto& s : designedSamples(database)) pool[s.input.experiment.object].push_back(s);
    }
    std::vector<DesignObject> objects;
    std::map<std::string, Footprint> footprints;
    for (const auto& o : catalogue.objects) {
      if (!pool.count(o.name)) continue;  // the pool never pushed it: nothing to replay
      objects.push_back({o.name, true, o.footprint});
      footprints[o.name] = o.footprint;
    }
    std::cout << "pool:";
    for (const auto& [object, pushes] : pool) std::cout << " " << object << " " << pushes.size();
    std::cout << "; evaluation set " << evaluation.size() << " pushes; learner " << learner << "; " << seeds
              << " seeds x " << budget << " experiments\n";

    std::vector<int> checkpoints;
    for (int k = 0; k <= budget; k += every) checkpoints.push_back(k);
    if (checkpoints.back() != budget) checkpoints.push_back(budget);

    auto run = [&](const std::string& name, unsigned long seed) {
      auto design = makeDesign(name, seed, options);
      std::unique_ptr<PushModel> model;
      if (scope == LearnerScope::PerObject) model = std::make_unique<PerObjectPushModel>(config);
      else model = std::make_unique<PushLearner>(config);
      std::map<std::string, std::vector<bool>> used;
      for (const auto& [object, pushes] : pool) used[object].assign(pushes.size(), false);
      DesignContext context;
      context.objects = objects;
      Campaign campaign;
      for (int i = 0; i < budget; ++i) {
        context.history_count = static_cast<std::size_t>(i);
        context.stream = streamSeed(seed, 1, static_cast<std::uint64_t>(i), StreamPurpose::Design);
        const ExperimentChoice choice = design->next(context);
        const PushSample& push = nearest(pool.at(choice.object), used[choice.object], choice,
                                         footprints.at(choice.object), options.max_distance);
        Prediction prediction;  // an empty model predicts no motion, as MACHINELEARNING's does
        if (model->sampleCount() > 0) prediction = model->predict(push.input);
        const double error = surprise(prediction, push.outcome).error;
        model->addSamples({push});
        const Experiment& e = push.input.experiment;
        context.history.push_back({e.object, e.side, e.offset, e.distance, error, push.outcome.dx, push.outcome.dy});
        campaign.pushes.push_back(push);
      }
      campaign.curve = learningCurve(name, campaign.pushes, evaluation, config, checkpoints, scope);
      return campaign;
    };

    const std::vector<std::string> designs{"random", design_name};
    std::map<std::string, std::vector<Campaign>> campaigns;
    for (int s = 1; s <= seeds; ++s) {
      for (const auto& name : designs) campaigns[name].push_back(run(name, static_cast<unsigned long>(s)));
      std::cerr << "seed " << s << " done\n";
    }
    std::cout << std::fixed << std::setprecision(4) << "k random " << design_name << "\n";
    for (std::size_t i = 0; i < checkpoints.size(); ++i) {
      std::cout << checkpoints[i];
      for (const auto& name : designs) {
        double sum = 0;
        for (const auto& c : campaigns[name]) sum += c.curve.error[i];
        std::cout << " " << sum / seeds;
      }
      std::cout << "\n";
    }
    // The study's primary measure (doc/studies.md): the area under the log of the error averaged with equal weight
    // over the evaluation objects that move, and a design's ratio to random.
    const std::vector<std::string> moving = movingObjects(evaluation);
    std::map<std::string, double> area;
    for (const auto& name : designs) {
      for (const auto& c : campaigns[name]) area[name] += logArea(c.curve.experiments, balancedError(c.curve, moving)) / seeds;
    }
    std::cout << std::setprecision(3) << "area ratio to random (objects that move, weighed equally): "
              << std::exp(area[design_name] - area["random"]) << "\n";
    std::vector<double> reach;
    int never = 0;
    for (int s = 0; s < seeds; ++s) {
      const double target = campaigns["random"][static_cast<std::size_t>(s)].curve.error.back();
      const int k = experimentsToReach(campaigns[design_name][static_cast<std::size_t>(s)].curve, target);
      if (k < 0) ++never;
      reach.push_back(k < 0 ? 1e9 : 100.0 * k / budget);
    }
    std::sort(reach.begin(), reach.end());
    const std::size_t half = reach.size() / 2;  // a pair across "never" has the median "never"
    const double median = reach.size() % 2 || reach[half] >= 1e9 ? reach[half] : 0.5 * (reach[half - 1] + reach[half]);
    std::cout << std::setprecision(0) << design_name << " reaches the same seed's random final error: median ";
    if (median >= 1e9) std::cout << "never";
    else std::cout << median << " %";
    std::cout << " of the budget; never in " << never << " of " << seeds << " seeds; per seed:";
    for (double r : reach) {
      if (r >= 1e9) std::cout << " never";
      else std::cout << " " << r;
    }
    std::cout << "\n" << std::setprecision(3);
    for (const auto& name : designs) {
      std::map<std::string, double> share;
      for (const auto& c : campaigns[name]) {
        for (std::size_t i = 50; i < c.pushes.size(); ++i) {
          share[c.pushes[i].input.experiment.object] += 1.0 / ((c.pushes.size() - 50) * seeds);
        }
      }
      std::cout << name << " share after 50:";
      for (const auto& [object, v] : share) std::cout << " " << object << " " << v;
      std::cout << "\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "design_replay: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
