/**
 * @file planner_component.h
 * @brief PLANNER: the operation make_plan, which chains the embodiment's commands and operations into a plan
 *        that reaches a goal, with the STRIPS planner of core/planner.h over the components' own contracts.
 *
 * The operators are the contracts of the components listed in ~components, read through their get_contracts
 * services by a thread of this component after activation (never from a callback), retried until every one
 * has answered. Each operator is named "<component>/<contract>", because several components offer the same
 * operation (OBSERVATION and VISION both offer get_features); components in ~prefer come first, so that
 * among equally short plans the planner picks theirs (VISION's feature vectors carry the further features).
 *
 * make_plan refuses, with a sentence, while the contracts are not loaded and when no plan exists (the
 * planner's reason names the goal literal that cannot be reached). Each returned PlanStep carries the
 * component, the operator's own name, its interface type, its parameters and their values; a parameter
 * the goal does not bind keeps the value "?name" (the message lists such open parameters).
 * `excluded` entries may name an operator with or without its component ("push", "manipulation/push",
 * "push(red_cube, -x, 0.01, 0.05)").
 *
 * The search is a core::PlanSearch chosen by name (doc/plugins.md): ~search_type breadth_first (shortest
 * plans), greedy, or another package's; an undeclared one fails configure with the list of declared searches.
 *
 * With `state_from_knowledge_base`, the initial state is `state` plus the current run's facts, which make_plan
 * asks KNOWLEDGEBASE's get_facts for (a KB that is not offered, or not within ~knowledge_base_timeout, makes the
 * call UNAVAILABLE; one that refuses, FAILED, with its sentence).
 *
 * Parameters: Planner::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md).
 */
#pragma once

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "xpersif/MakePlan.h"
#include "xpersif/PlanStep.h"
#include "xpersif/component/component.h"
#include "xpersif/core/planning/planner.h"
#include "xpersif/ros/algorithm_loader.h"

namespace xpersif {

/// One component's contracts as get_contracts gave them.
struct ComponentContracts {
  std::string component;
  std::vector<core::Contract> contracts;
};

/// Operators named "<component>/<contract name>", the components in @p prefer first (in their order), the
/// others in the order given.
std::vector<core::Contract> qualifiedOperators(const std::vector<ComponentContracts>& components,
                                               const std::vector<std::string>& prefer);

/// Excluded entries with every unqualified operator name expanded to each component offering it.
std::set<std::string> qualifyExcluded(const std::vector<std::string>& excluded,
                                      const std::vector<core::Contract>& operators);

/// The planner's steps as messages (component and operator split at the first '/').
std::vector<PlanStep> toStepMessages(const std::vector<core::PlanStep>& steps,
                                     const std::vector<core::Contract>& operators);

class Planner : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  Planner(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~Planner() override;

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;

 private:
  void startLoader();
  void stopLoader();
  /// The loader thread: get_contracts of every component not loaded yet, every retry_period, until all answer.
  void loadContracts();
  /// "" when the contracts of every component are loaded, else which are missing.
  std::string whyNotLoaded() const;
  void makePlan(const MakePlan::Request& request, MakePlan::Response& response);
  /// The current run's facts from KNOWLEDGEBASE's get_facts; throws UnavailableError or runtime_error.
  std::vector<std::string> knowledgeBaseFacts();

  AlgorithmLoader<core::PlanSearch> searches_;  // before search_: it holds the search's code (configure only)
  mutable std::mutex mutex_;
  std::shared_ptr<const core::PlanSearch> search_;
  std::vector<std::string> components_;
  std::vector<std::string> prefer_;
  int max_depth_ = 8;
  double retry_period_ = 1.0;
  std::string knowledge_base_ = "knowledge_base";
  double knowledge_base_timeout_ = 2.0;
  std::vector<ComponentContracts> loaded_;  // in the order of components_, as they answer
  std::vector<core::Contract> operators_;   // built once every component has answered

  std::mutex loader_mutex_;  // guards the thread object and the stop flag's condition
  std::condition_variable loader_wakeup_;
  std::atomic<bool> loader_stop_{false};
  std::thread loader_;
};

}  // namespace xpersif
