#include "xpersif/perception/feature_selection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "xpersif/GetExperiments.h"
#include "xpersif/core/evaluation/experiment_samples.h"
#include "xpersif/core/common/validation.h"
#include "xpersif/component/parameter_reader.h"
#include "xpersif/ros/experiment_conversions.h"

namespace xpersif {

namespace {

std::string joined(const std::vector<std::string>& names) {
  std::string text;
  for (const auto& n : names) text += (text.empty() ? "" : ", ") + n;
  return text;
}

/// A literal's tuple argument, "(a, b)"; "none" for no names (a tuple is never empty).
std::string tuple(const std::vector<std::string>& names) { return names.empty() ? "none" : "(" + joined(names) + ")"; }

std::string threeDecimals(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f", value);
  return text;
}

std::string shortName(const std::string& name) { return name.size() > 64 ? name.substr(0, 64) + "..." : name; }

/// "" when every name is one of @p candidates and none repeats, else the sentence.
std::string checkCandidates(const std::string& field, const std::vector<std::string>& names,
                            const std::vector<std::string>& candidates) {
  std::string why = core::checkMaxSize(field, names.size(), 64);
  for (std::size_t i = 0; why.empty() && i < names.size(); ++i) {
    const std::string at = field + "[" + std::to_string(i) + "]";
    if (std::find(candidates.begin(), candidates.end(), names[i]) == candidates.end()) {
      why = at + " '" + shortName(names[i]) + "' is not a candidate; the candidates (features of the object itself) are: " +
            joined(candidates);
    } else if (std::find(names.begin(), names.begin() + static_cast<std::ptrdiff_t>(i), names[i]) !=
               names.begin() + static_cast<std::ptrdiff_t>(i)) {
      why = at + " '" + shortName(names[i]) + "' is named twice";
    }
  }
  return why;
}

}  // namespace

FeatureSelection::FeatureSelection(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/FeatureSelectionNodelet") {
  core::Contract select;
  select.name = "select_features";
  select.kind = core::Contract::Kind::Operation;
  select.interface_type = "xpersif/SelectFeatures";
  select.description = "choose the further features VISION computes (empty: ~features)";
  select.parameters = {"?names", "?selected"};
  select.preconditions = {{"available(?names)", "every name must be one of the available features"}};
  select.effects = {"selected(vision, ?selected)"};
  ContractChecker<SelectFeatures::Request> contract(select);
  contract.bind([](const SelectFeatures::Request& r) { return core::Bindings{{"?names", tuple(r.names)}}; })
      .check("available(?names)", [](const SelectFeatures::Request& r) {
        if (r.names.empty()) return std::string();
        try {
          core::FeatureSelection probe(r.names);
        } catch (const std::exception& e) {
          return std::string(e.what());
        }
        return std::string();
      });
  addOperation<SelectFeatures>(
      contract, [](const SelectFeatures::Request& r) { core::requireMaxSize("names", r.names.size(), 64); },
      [this](const SelectFeatures::Request& request, SelectFeatures::Response& response) {
        {
          std::lock_guard<std::mutex> lock(mutex_);
          selection_.set(request.names.empty() ? initial_ : request.names);
          response.selected = selection_.names();
        }
        publish();
      },
      false,
      [](const SelectFeatures::Request&, const SelectFeatures::Response& response) {
        return core::Bindings{{"?selected", tuple(response.selected)}};
      });

  core::Contract choose;
  choose.name = "choose_features";
  choose.kind = core::Contract::Kind::Operation;
  choose.interface_type = "xpersif/ChooseFeatures";
  choose.description =
      "rank the object's own features by how much they help predict a push's outcome on the run's first experiments, "
      "choose the best and make VISION extract them";
  choose.parameters = {"?run", "?experiments", "?chosen", "?scores", "?selected"};
  choose.effects = {"features_chosen(?run, ?chosen, ?experiments)", "feature_scores(?run, ?scores)",
                    "selected(vision, ?selected)"};
  ContractChecker<ChooseFeatures::Request> choose_contract(choose);
  choose_contract.bind([](const ChooseFeatures::Request& r) {
    return core::Bindings{{"?run", std::to_string(r.run_id)}, {"?experiments", std::to_string(r.experiments)}};
  });
  addOperation<ChooseFeatures>(
      choose_contract,
      [](const ChooseFeatures::Request& r) {
        if (r.run_id == 0) throw core::ValidationError("run_id is 0; name the run whose experiments are ranked on");
        if (r.experiments == 0) throw core::ValidationError("experiments is 0; rank on at least the run's first one");
        core::throwIfInvalid(checkCandidates("candidates", r.candidates, core::objectFeatureNames()));
      },
      [this](const ChooseFeatures::Request& request, ChooseFeatures::Response& response) { this->choose(request, response); },
      true,
      [](const ChooseFeatures::Request&, const ChooseFeatures::Response& response) {
        std::vector<std::string> scores;
        for (std::size_t i = 0; i < response.names.size() && i < response.scores.size(); ++i) {
          scores.push_back(response.names[i] + "/" + threeDecimals(response.scores[i]));
        }
        return core::Bindings{
            {"?chosen", tuple(response.chosen)}, {"?scores", tuple(scores)}, {"?selected", tuple(response.selected)}};
      });
}

const core::ParameterTable& FeatureSelection::parameters() {
  static const core::ParameterTable table(
      "feature_selection",
      {core::namesParameter("features", core::FeatureSelection::defaultNames(), 64,
                            "the features VISION always computes (names from ~available); until a choice, every "
                            "candidate too"),
       core::namesParameter("candidates", core::objectFeatureNames(), 64,
                            "the object's own features choose_features ranks (core::objectFeatureNames)"),
       core::intParameter("count", static_cast<int>(core::FeatureRankingOptions().count), 1, 16,
                          "choose_features keeps at most this many of the best scoring"),
       core::numberParameter("min_score", core::FeatureRankingOptions().min_score, 0.0, 1.0,
                             "choose_features keeps only features scoring at least this (share of the outcome's variance)"),
       core::textParameter("knowledge_base", "knowledge_base", "namespace of the knowledge base's get_experiments"),
       core::numberParameter("knowledge_base_timeout", 5.0, 0.1, 600.0,
                             "s of wall time to wait for the knowledge base"),
       core::outputParameter(core::ParameterSpec::Type::StringList, "available",
                             "the features one can choose, \"name [unit]: description\"")});
  return table;
}

void FeatureSelection::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, FeatureSelection::parameters());
  const std::vector<std::string> candidates = parameters.get<std::vector<std::string>>("candidates");
  if (candidates.empty()) throw core::ValidationError("~candidates is empty; name at least one feature of the object");
  core::throwIfInvalid(checkCandidates("~candidates", candidates, core::objectFeatureNames()));
  // VISION always extracts ~features; until a choice, every candidate too: the run's first experiments must carry
  // them to be ranked on.
  const core::FeatureSelection probe(parameters.get<std::vector<std::string>>("features"));  // throws with the unknown name (or an empty list): configure fails
  std::vector<std::string> names = probe.names();
  for (const auto& c : candidates) {
    if (std::find(names.begin(), names.end(), c) == names.end()) names.push_back(c);
  }
  const core::FeatureSelection selection(names);  // throws with the unknown name: configure fails
  core::FeatureRankingOptions ranking;
  ranking.count = static_cast<std::size_t>(parameters.get<int>("count"));
  ranking.min_score = parameters.get<double>("min_score");
  const std::string knowledge_base = parameters.get<std::string>("knowledge_base");
  const double timeout = parameters.get<double>("knowledge_base_timeout");
  std::vector<std::string> available;
  for (const auto& f : core::availableFeatures()) available.push_back(f.name + " [" + f.unit + "]: " + f.description);
  pnh.setParam("available", available);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    selection_ = selection;
    base_ = probe.names();
    initial_ = selection.names();
    candidates_ = candidates;
    ranking_ = ranking;
    knowledge_base_ = knowledge_base;
    knowledge_base_timeout_ = timeout;
    if (!selection_pub_) selection_pub_ = pnh.advertise<FeatureNames>("selection", 1, true);
  }
  publish();
}

void FeatureSelection::choose(const ChooseFeatures::Request& request, ChooseFeatures::Response& response) {
  std::vector<std::string> candidates;
  core::FeatureRankingOptions options;
  std::string knowledge_base;
  double timeout = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    candidates = request.candidates.empty() ? candidates_ : request.candidates;
    options = ranking_;
    knowledge_base = knowledge_base_;
    timeout = knowledge_base_timeout_;
  }
  options.seed = request.seed;

  // The run's experiments as the knowledge base has them: the same on a resumed run as on an uninterrupted one.
  const std::string service = ros::names::resolve(nodeHandle().getNamespace(), knowledge_base + "/get_experiments");
  GetExperiments call;
  call.request.run_id = request.run_id;
  call.request.status = "done";
  if (!ros::service::waitForService(service, ros::Duration(timeout))) {
    throw core::UnavailableError("the knowledge base's " + service + " is not offered; try again when it is");
  }
  if (!ros::service::call(service, call)) throw core::UnavailableError("the knowledge base's " + service + " did not answer");
  if (!call.response.success) throw std::runtime_error("the knowledge base refused: " + call.response.message);

  std::vector<core::PushSample> samples;
  std::uint32_t skipped = 0;
  for (const auto& record : call.response.experiments) {
    if (record.seq == 0 || record.seq > request.experiments) continue;
    const auto sample = core::pushSampleOf(fromMsg(record));
    bool complete = sample.has_value();
    for (std::size_t j = 0; complete && j < candidates.size(); ++j) {
      const auto it = sample->input.object.extra.find(candidates[j]);
      complete = it != sample->input.object.extra.end() && std::isfinite(it->second);
    }
    if (complete) {
      samples.push_back(*sample);
    } else {
      ++skipped;
    }
  }
  if (samples.size() < core::kMinRankingRows) {
    throw std::runtime_error("run " + std::to_string(request.run_id) + " has " + std::to_string(samples.size()) +
                             " done experiments among its first " + std::to_string(request.experiments) +
                             " that carry every candidate (" + joined(candidates) + "; " + std::to_string(skipped) +
                             " lack one); ranking needs at least " + std::to_string(core::kMinRankingRows));
  }
  const core::FeatureRanking ranking = core::rankFeatures(samples, candidates, options);

  std::vector<std::string> names;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // ~features (what VISION computes for every use), then the chosen ones.
    names = base_;
    for (const auto& n : ranking.chosen) {
      if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
    }
    selection_.set(names);
    response.selected = selection_.names();
  }
  publish();
  response.chosen = ranking.chosen;
  for (const auto& s : ranking.scores) {
    response.names.push_back(s.name);
    response.scores.push_back(s.score);
  }
  response.rows = static_cast<std::uint32_t>(ranking.rows);
  response.skipped = skipped;
  std::string scores;
  for (const auto& s : ranking.scores) scores += (scores.empty() ? "" : ", ") + s.name + " " + threeDecimals(s.score);
  response.message = "chose " + (ranking.chosen.empty() ? std::string("no feature") : joined(ranking.chosen)) +
                     " from " + std::to_string(ranking.rows) + " experiments of run " + std::to_string(request.run_id) +
                     " (scores: " + scores + ")";
}

void FeatureSelection::publish() {
  FeatureNames message;
  std::lock_guard<std::mutex> lock(mutex_);
  message.names = selection_.names();
  selection_pub_.publish(message);
}

}  // namespace xpersif
