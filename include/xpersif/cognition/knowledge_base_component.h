/**
 * @file knowledge_base_component.h
 * @brief KNOWLEDGEBASE: the loop's memory as a component — runs, experiments, models, notions and goals in one
 *        SQLite file (core::KnowledgeBase), so that nothing committed is lost and a run can be resumed.
 *
 * It lives alone in kb_manager, so that any component may call its operations, even blocking, from anywhere.
 *
 * Operations (all need ACTIVE; bad input is refused with one sentence and writes nothing):
 *  - `start_run` (StartRun): resume=true returns the latest run still marked running with its count of done
 *    experiments; otherwise (or when there is none) a new run. Either way it becomes the CURRENT run, announced
 *    latched on `~run` (std_msgs/UInt64).
 *  - `finish_run` (FinishRun): mark a run (0: the current one) finished or stopped.
 *  - `record_experiment` (RecordExperiment): validate (every number finite, sizes within the caps, status done
 *    or failed, a failed one says why), commit in one transaction, then publish the stored record (id, seq
 *    set) on `~experiments` (not latched, queue 100). run_id 0 means the current run.
 *  - `get_experiments` (GetExperiments): a run's records in seq order, optionally of one status.
 *  - `record_goal` (RecordGoal), `get_notions` (GetNotions).
 *  - `get_calls` (GetCalls): the stored command and operation calls of a run (0: the current one), oldest
 *    first, filtered by component, kind and since, at most `limit` (1..1000, 0: 100); a bad filter is INVALID.
 *  - `get_facts` (GetFacts): the run's facts, the latest effect per predicate and subject (core::Fact).
 * It stores what MACHINELEARNING publishes: the models on `~model_topic` (default machine_learning/model) and
 * the notions on `~notions_topic` (machine_learning/notions), for the run each names.
 * It stores every component's command outcomes (not their acceptance) and operation calls from the shared
 * `~events_topic` (default component_events, where every component's EventSink publishes) under the run that
 * is current when they arrive: buffered, and written in one transaction every `~event_flush_period` s of wall
 * time (and before get_calls and get_facts answer), so the loop's many calls cost one commit each period and a
 * slow disk never holds a component up (it only publishes). Calls that arrive while the KB is down are lost.
 *
 * Parameters: KnowledgeBaseComponent::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md).
 *
 * Not kept: the record's `design` is published with the record but not stored (the core schema has no column
 * for it), so get_experiments returns it empty.
 */
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "xpersif/ComponentEvent.h"
#include "xpersif/FinishRun.h"
#include "xpersif/GetCalls.h"
#include "xpersif/GetExperiments.h"
#include "xpersif/GetFacts.h"
#include "xpersif/GetNotions.h"
#include "xpersif/GetWorldState.h"
#include "xpersif/LearnedModel.h"
#include "xpersif/Notions.h"
#include "xpersif/RecordExperiment.h"
#include "xpersif/RecordGoal.h"
#include "xpersif/RecordWorldState.h"
#include "xpersif/StartRun.h"
#include "xpersif/component/component.h"
#include "xpersif/core/kb/knowledge_base.h"
#include "xpersif/core/common/setup.h"

namespace xpersif {

class KnowledgeBaseComponent : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  KnowledgeBaseComponent(ros::NodeHandle nh, ros::NodeHandle private_nh);

  /// The default database file: $ROS_HOME (or ~/.ros) /xpersif/knowledge.db.
  static std::string defaultDatabasePath();

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onShutdown() override;

 private:
  // The operations' contracts (their preconditions read the store and the set-up), bound in the constructor.
  ContractChecker<StartRun::Request> startRunContract();
  ContractChecker<FinishRun::Request> finishRunContract();
  ContractChecker<RecordExperiment::Request> recordExperimentContract();
  ContractChecker<RecordGoal::Request> recordGoalContract();
  ContractChecker<RecordWorldState::Request> recordWorldStateContract();
  /// A query of one run: @p contract with parameter ?run, precondition exists(?run) and @p effects.
  template <class Request>
  ContractChecker<Request> runQueryContract(core::Contract contract, std::vector<std::string> effects);

  // The operations' handlers, called once the contract's checks passed (Component::addOperation).
  /// start_run: resume the latest unfinished run of that name (if asked) or create one; it becomes the current run.
  void startRun(const StartRun::Request& request, StartRun::Response& response);
  /// finish_run: mark the run finished or stopped.
  void finishRun(const FinishRun::Request& request, FinishRun::Response& response);
  /// record_experiment: store the record in one transaction, then publish the stored form on ~experiments.
  void recordExperiment(const RecordExperiment::Request& request, RecordExperiment::Response& response);
  /// get_experiments: the run's records in seq order, optionally of one status.
  void getExperiments(const GetExperiments::Request& request, GetExperiments::Response& response);
  /// record_goal: store the outcome of a goal-directed episode.
  void recordGoal(const RecordGoal::Request& request, RecordGoal::Response& response);
  /// record_world_state: store XPERSim's world state at a step of the run.
  void recordWorldState(const RecordWorldState::Request& request, RecordWorldState::Response& response);
  /// get_world_state: the world state stored for a step of the run, if any.
  void getWorldState(const GetWorldState::Request& request, GetWorldState::Response& response);
  /// get_notions: the notions learned in the run.
  void getNotions(const GetNotions::Request& request, GetNotions::Response& response);
  /// get_calls: the run's stored calls (after a flush of the buffered ones), filtered.
  void getCalls(const GetCalls::Request& request, GetCalls::Response& response);
  /// get_facts: the run's facts (after a flush of the buffered calls).
  void getFacts(const GetFacts::Request& request, GetFacts::Response& response);

  /// The open store, or throws when not configured.
  std::shared_ptr<core::KnowledgeBase> store() const;
  /// @p run_id, or the current run for 0 (throws when there is none).
  std::int64_t resolveRun(std::uint64_t run_id) const;
  /// "" when the run (0: current) exists [and is running], else why not.
  std::string checkRun(std::uint64_t run_id, bool must_run) const;
  void announceRun(std::int64_t run_id);
  void onModel(const LearnedModel::ConstPtr& model);
  void onNotions(const Notions::ConstPtr& notions);
  /// Buffer a command outcome or operation call for the next flush.
  void onEvent(const ComponentEvent::ConstPtr& event);
  /// Write the buffered calls in one transaction (one by one, dropping the bad ones, if the batch is refused).
  void flushCalls();

  mutable std::mutex mutex_;
  /// The set-up's catalogue, read from XPERSim's scene the first time a record needs it (so that the knowledge
  /// base can start before the simulator). @throws std::runtime_error when it cannot be had
  const core::SetupCatalogue& catalogue();
  std::mutex catalogue_mutex_;
  std::optional<core::SetupCatalogue> catalogue_;
  std::shared_ptr<core::KnowledgeBase> kb_;
  std::int64_t current_run_ = 0;
  std::string model_topic_ = "machine_learning/model", notions_topic_ = "machine_learning/notions";
  std::string events_topic_ = kSharedEventsTopic;
  double event_flush_period_ = 0.2;
  std::size_t max_pending_calls_ = 10000;
  std::mutex pending_mutex_;
  std::vector<core::CallRecord> pending_calls_;  // guarded by pending_mutex_
  std::mutex flush_mutex_;                       // one flush at a time, in arrival order

  // ROS handles last.
  ros::Publisher experiments_pub_, run_pub_;
  ros::Subscriber model_sub_, notions_sub_, events_sub_;
  ros::WallTimer flush_timer_;
};

}  // namespace xpersif
