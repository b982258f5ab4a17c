/**
 * @file loop_model_features.cpp
 * @brief LOOPMODEL and learning: MACHINELEARNING's latest model (its samples, the features it learns from), the
 *        wait for it to learn an experiment, and the features a run learns from (the initial ones, then
 *        FEATURESELECTION's choice once the run has its first ~select_features_after experiments).
 */
#include "xpersif/loop/loop_model.h"

#include <algorithm>
#include <cctype>
#include <condition_variable>
#include <memory>

#include "xpersif/ChooseFeatures.h"
#include "xpersif/GetFeatures.h"
#include "xpersif/SelectFeatures.h"
#include "xpersif/UseFeatures.h"
#include "xpersif/core/common/random_stream.h"
#include "xpersif/ros/algorithm_loader.h"
#include "service_call.h"

namespace xpersif {

using loop::call;
using loop::callPatiently;

std::vector<std::string> LoopModel::learningFeatures() {
  std::lock_guard<std::mutex> lock(mutex_);
  return learning_features_;
}

std::uint32_t LoopModel::modelSamples() {
  std::lock_guard<std::mutex> lock(mutex_);
  return model_samples_;
}

void LoopModel::waitForLearning(std::uint64_t run_id, std::uint32_t samples, Run::Context& context) {
  Spending spending(wall_spent_, "learning");
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(learning_timeout_);
  while (ros::WallTime::now() < deadline && !context.stopRequested()) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (model_run_ == run_id && model_samples_ >= samples) return;
    }
    ros::WallDuration(0.01).sleep();
  }
  ROS_WARN("%s: MACHINELEARNING has not learned experiment %u of run %lu within %.0f s; going on", name().c_str(),
           samples, static_cast<unsigned long>(run_id), learning_timeout_);
}

std::string LoopModel::waitForSelection(const std::vector<std::string>& selection) {
  Spending spending(wall_spent_, "features");
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(20.0);
  std::string why;
  while (ros::ok()) {
    GetFeatures features;
    features.request.max_age = 0.0;
    why = call(nodeHandle(), "vision/get_features", features);
    if (why.empty()) {
      const FeatureVector& vector = features.response.features;
      const auto lacking = std::find_if(vector.objects.begin(), vector.objects.end(),
                                        [&](const ObjectFeatures& o) { return o.feature_names != selection; });
      if (!vector.objects.empty() && lacking == vector.objects.end()) return "";
      // What VISION has instead: a stale vector (no new frames) reads differently from a fresh one without it.
      why = "its latest vector (image " + std::to_string(vector.header.seq) + ", t = " +
            core::describeNumber(vector.header.stamp.toSec()) + " s) " +
            (vector.objects.empty() ? "has no objects (" + std::to_string(vector.missing.size()) + " missing)"
                                    : "carries [" + joinWithCommas(lacking->feature_names) + "] for " + lacking->name) +
            ", not the selection [" + joinWithCommas(selection) + "]";
    }
    if (ros::WallTime::now() > deadline) break;
    // (In lockstep the clock's idle ticks bring new frames of the standing world.)
    ros::WallDuration(0.02).sleep();
  }
  return "VISION did not take up the selection within 20 s (the clock at t = " +
         core::describeNumber(ros::Time::now().toSec()) + " s): " + why;
}

namespace {

/// The latest status a component publishes on @p topic, waiting up to @p seconds of wall time for one.
std::optional<ComponentStatus> statusOf(ros::NodeHandle& nh, const std::string& topic, double seconds) {
  struct Heard {
    std::mutex mutex;
    std::condition_variable arrived;
    std::optional<ComponentStatus> status;
  };
  auto heard = std::make_shared<Heard>();
  ros::Subscriber subscriber = nh.subscribe<ComponentStatus>(topic, 1, [heard](const ComponentStatus::ConstPtr& s) {
    std::lock_guard<std::mutex> lock(heard->mutex);
    heard->status = *s;
    heard->arrived.notify_all();
  });
  std::unique_lock<std::mutex> lock(heard->mutex);
  heard->arrived.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return heard->status.has_value(); });
  return heard->status;
}

/// A component's name as the sentences write it: "/xpersif/observation" is OBSERVATION.
std::string upper(const std::string& resolved) {
  std::string name = resolved.substr(resolved.rfind('/') + 1);
  for (char& c : name) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return name;
}

}  // namespace

std::string LoopModel::perceptionRefusal() {
  std::map<std::string, std::vector<PartStatus>> erroring;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    erroring = erroring_parts_;
  }
  std::string said;
  const auto say = [&](const std::string& sentence) { said += (said.empty() ? "" : "; ") + sentence; };
  for (const auto& [component, parts] : erroring) {
    for (const auto& part : parts) {
      // A supervised component's part is a component of its own (ROBOTMODEL's OBSERVATION): its status names
      // which of its parts refuses and why. A part that publishes no status is described by its supervisor.
      std::string why;
      if (const auto status = statusOf(nodeHandle(), part.name + "/status", 2.0)) {
        for (const auto& inner : status->parts) {
          if (inner.health != ComponentStatus::HEALTH_ERROR) continue;
          why += (why.empty() ? "" : "; ") + upper(part.name) + "'s " + inner.name + " refuses to work: " + inner.message;
        }
        if (why.empty() && status->state == ComponentStatus::ERROR && !status->last_error.empty()) {
          why = upper(part.name) + " is in ERROR: " + status->last_error;
        }
      }
      if (why.empty() && !part.message.empty()) why = upper(component) + "'s " + part.name + ": " + part.message;
      if (!why.empty()) say(why);
    }
  }
  return said;
}

void LoopModel::onComponentStatus(const std::string& name, const ComponentStatus& status) {
  std::vector<PartStatus> erroring;
  for (const auto& part : status.parts) {
    if (part.health == ComponentStatus::HEALTH_ERROR) erroring.push_back(part);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (erroring.empty()) {
    erroring_parts_.erase(name);
  } else {
    erroring_parts_[name] = std::move(erroring);
  }
}

std::string LoopModel::ensureFeatures(std::uint64_t run_id, std::uint64_t seed, std::uint32_t done,
                                      std::uint32_t experiments, FeatureStage& stage) {
  const std::uint32_t after = std::min(select_features_after_, experiments);
  const int target = after > 0 && done >= after ? 1 : 0;
  const std::uint64_t losses = losses_;
  if (stage.applied == target && stage.losses == losses) return "";
  std::string why;
  std::vector<std::string> learn, selection;  // learn empty: MACHINELEARNING's ~features
  bool chosen = false;
  if (target == 1) {
    // Ranked on what the knowledge base holds of the run's first experiments: a resumed run chooses the same.
    ChooseFeatures choose;
    choose.request.run_id = run_id;
    choose.request.experiments = after;
    choose.request.seed = core::streamSeed(seed, run_id, after, core::StreamPurpose::Features);
    {
      Spending spending(wall_spent_, "features");
      why = callPatiently(nodeHandle(), "feature_selection/choose_features", choose);
    }
    if (why.empty()) {
      chosen = true;
      learn = choose.response.chosen;
      selection = choose.response.selected;
      ROS_INFO("%s: run %lu: %s", name().c_str(), static_cast<unsigned long>(run_id), choose.response.message.c_str());
    } else if (choose.response.code == ResultCode::FAILED) {
      ROS_WARN("%s: run %lu goes on with the initial features: FEATURESELECTION made no choice: %s", name().c_str(),
               static_cast<unsigned long>(run_id), why.c_str());
    } else {
      return "FEATURESELECTION's choose_features: " + why;
    }
  }
  if (!chosen) {
    SelectFeatures initial;  // none: FEATURESELECTION's initial selection
    {
      Spending spending(wall_spent_, "features");
      why = callPatiently(nodeHandle(), "feature_selection/select_features", initial);
    }
    if (!why.empty()) return "FEATURESELECTION's select_features: " + why;
    selection = initial.response.selected;
  }
  UseFeatures use;
  use.request.names = learn;
  use.request.initial = !chosen;
  {
    Spending spending(wall_spent_, "features");
    why = callPatiently(nodeHandle(), "machine_learning/use_features", use);
  }
  if (!why.empty()) return "MACHINELEARNING's use_features: " + why;
  why = waitForSelection(selection);
  if (!why.empty()) return why;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    learning_features_ = use.response.features;
  }
  stage.applied = target;
  stage.losses = losses;
  return "";
}

}  // namespace xpersif
