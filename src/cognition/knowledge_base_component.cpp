#include "xpersif/ros/setup_loader.h"
#include "xpersif/cognition/knowledge_base_component.h"

#include "xpersif/component/parameter_reader.h"

#include <std_msgs/UInt64.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>

#include "xpersif/core/common/validation.h"
#include "xpersif/ros/experiment_conversions.h"

namespace xpersif {

namespace {
constexpr std::size_t kMaxNotions = 1000;

core::Contract operation(const std::string& name, const std::string& type, const std::string& description) {
  core::Contract c;
  c.name = name;
  c.kind = core::Contract::Kind::Operation;
  c.interface_type = type;
  c.description = description;
  return c;
}

std::string runText(std::uint64_t run_id) { return run_id == 0 ? std::string("current") : std::to_string(run_id); }

constexpr std::uint32_t kDefaultCallLimit = 100;

CallRecord toMsg(const core::CallRecord& call) {
  CallRecord m;
  m.id = static_cast<std::uint64_t>(call.id);
  m.run_id = static_cast<std::uint64_t>(call.run_id);
  m.time = call.time;
  m.component = call.component;
  m.kind = call.kind;
  m.name = call.name;
  m.outcome = call.outcome;
  m.code = call.code ? static_cast<std::uint8_t>(*call.code) : static_cast<std::uint8_t>(ComponentEvent::NO_CODE);
  m.reason = call.reason;
  m.effects = call.effects;
  m.duration = call.duration;
  return m;
}

// ---- what each operation refuses before anything is stored --------------------------------------------

/// start_run: a name within the store's length, a design name, a seed that fits the store's signed column.
void validateStartRun(const StartRun::Request& r) {
  core::throwIfInvalid(core::checkMaxLength("name", r.name, core::KnowledgeBase::kMaxTextLength));
  if (r.name.empty()) throw core::ValidationError("name is empty; a run needs a name");
  core::throwIfInvalid(core::checkMaxLength("design", r.design, core::kMaxNameLength));
  if (r.seed > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
    throw core::ValidationError("seed " + std::to_string(r.seed) + " is larger than 2^63 - 1");
  }
}

/// finish_run: the status is finished or stopped.
void validateFinishRun(const FinishRun::Request& r) { core::requireOneOf("status", r.status, {"finished", "stopped"}); }

/// record_experiment: the record converts (every number finite, sizes within the caps, a failed one says why).
void validateRecordExperiment(const RecordExperiment::Request& r) { fromMsg(r.record); }

/// get_experiments: the status filter is empty, done or failed.
void validateGetExperiments(const GetExperiments::Request& r) {
  core::requireOneOf("status", r.status, {"", "done", "failed"});
}

/// record_goal: an object's name, a finite target and a final error within reason.
void validateRecordGoal(const RecordGoal::Request& r) {
  core::requireIdentifier("object", r.object, core::kMaxNameLength);
  core::requireFinite("target_x", r.target_x);
  core::requireFinite("target_y", r.target_y);
  core::requireInRange("final_error", r.final_error, 0.0, 1e6);
}

/// record_world_state: a state, not larger than the store keeps.
void validateRecordWorldState(const RecordWorldState::Request& r) {
  if (r.state.empty()) throw core::ValidationError("state is empty; it is required");
  core::requireMaxLength("state", r.state, core::KnowledgeBase::kMaxWorldStateBytes);
}

/// get_calls: the same checks the store makes, here so that a bad filter is refused before anything is flushed.
void validateGetCalls(const GetCalls::Request& r) {
  core::requireOneOf("kind", r.kind, {"", "command", "operation"});
  core::throwIfInvalid(core::checkMaxLength("component", r.component, core::kMaxNameLength));
  core::requireFinite("since", r.since);
  core::requireInRange("limit", r.limit, 0, static_cast<double>(core::KnowledgeBase::kMaxCallsPerQuery));
}
}  // namespace

std::string KnowledgeBaseComponent::defaultDatabasePath() {
  const char* ros_home = std::getenv("ROS_HOME");
  std::string base;
  if (ros_home && *ros_home) {
    base = ros_home;
  } else {
    const char* home = std::getenv("HOME");
    base = std::string(home && *home ? home : ".") + "/.ros";
  }
  return base + "/xpersif/knowledge.db";
}

KnowledgeBaseComponent::KnowledgeBaseComponent(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/KnowledgeBaseNodelet") {
  addOperation<StartRun>(startRunContract(), validateStartRun, [this](auto& r, auto& out) { startRun(r, out); });
  addOperation<FinishRun>(finishRunContract(), validateFinishRun, [this](auto& r, auto& out) { finishRun(r, out); });
  addOperation<RecordExperiment>(recordExperimentContract(), validateRecordExperiment,
                                 [this](auto& r, auto& out) { recordExperiment(r, out); });
  addOperation<GetExperiments>(
      runQueryContract<GetExperiments::Request>(
          operation("get_experiments", "xpersif/GetExperiments", "a run's experiments in seq order"),
          {"known(experiments, ?run)"}),
      validateGetExperiments, [this](auto& r, auto& out) { getExperiments(r, out); });
  addOperation<RecordGoal>(recordGoalContract(), validateRecordGoal,
                           [this](auto& r, auto& out) { recordGoal(r, out); });
  addOperation<RecordWorldState>(recordWorldStateContract(), validateRecordWorldState,
                                 [this](auto& r, auto& out) { recordWorldState(r, out); });
  addOperation<GetWorldState>(
      runQueryContract<GetWorldState::Request>(
          operation("get_world_state", "xpersif/GetWorldState", "the world state stored for a step of a run"), {}),
      nullptr, [this](auto& r, auto& out) { getWorldState(r, out); });
  addOperation<GetNotions>(
      runQueryContract<GetNotions::Request>(
          operation("get_notions", "xpersif/GetNotions", "the notions learned in a run"), {"known(notions, ?run)"}),
      nullptr, [this](auto& r, auto& out) { getNotions(r, out); });
  addOperation<GetCalls>(
      runQueryContract<GetCalls::Request>(
          operation("get_calls", "xpersif/GetCalls",
                    "the stored command and operation calls of a run, oldest first, filtered"),
          {"known(calls, ?run)"}),
      validateGetCalls, [this](auto& r, auto& out) { getCalls(r, out); });
  addOperation<GetFacts>(
      runQueryContract<GetFacts::Request>(
          operation("get_facts", "xpersif/GetFacts",
                    "the ground facts of a run: the latest stored effect per predicate and subject"),
          {"known(facts, ?run)"}),
      nullptr, [this](auto& r, auto& out) { getFacts(r, out); });
}

// ---- contracts --------------------------------------------------------------------------------------------

ContractChecker<StartRun::Request> KnowledgeBaseComponent::startRunContract() {
  core::Contract start = operation("start_run", "xpersif/StartRun",
                                   "start a run (or resume the latest unfinished run of that name); it becomes the current run");
  start.parameters = {"?name"};
  start.effects = {"running(current_run)"};
  ContractChecker<StartRun::Request> contract(start);
  contract.bind([](const StartRun::Request& r) { return core::Bindings{{"?name", r.name}}; });
  return contract;
}

ContractChecker<FinishRun::Request> KnowledgeBaseComponent::finishRunContract() {
  core::Contract finish = operation("finish_run", "xpersif/FinishRun", "mark a run finished or stopped");
  finish.parameters = {"?run", "?status"};
  finish.preconditions = {{"running(?run)", "the run must exist and still be running"}};
  finish.effects = {"not running(?run)", "ended(?run, ?status)"};
  ContractChecker<FinishRun::Request> contract(finish);
  contract
      .bind([](const FinishRun::Request& r) { return core::Bindings{{"?run", runText(r.run_id)}, {"?status", r.status}}; })
      .check("running(?run)", [this](const FinishRun::Request& r) { return checkRun(r.run_id, true); });
  return contract;
}

ContractChecker<RecordExperiment::Request> KnowledgeBaseComponent::recordExperimentContract() {
  core::Contract record = operation("record_experiment", "xpersif/RecordExperiment",
                                    "store an experiment in one transaction, then publish it on ~experiments");
  record.parameters = {"?run", "?object", "?side"};
  record.preconditions = {{"running(?run)", "the experiment's run (0: the current one) must be running"},
                          {"in_setup(?object, ?side)",
                           "the push must fit the set-up: a known object, its side, offset and distance within its limits"}};
  record.effects = {"recorded(?run, ?object, ?side)"};
  ContractChecker<RecordExperiment::Request> contract(record);
  contract
      .bind([](const RecordExperiment::Request& r) {
        return core::Bindings{{"?run", runText(r.record.run_id)},
                              {"?object", r.record.experiment.object},
                              {"?side", r.record.experiment.side}};
      })
      .check("running(?run)", [this](const RecordExperiment::Request& r) { return checkRun(r.record.run_id, true); })
      .check("in_setup(?object, ?side)", [this](const RecordExperiment::Request& r) {
        try {
          return catalogue().checkExperiment("record.experiment", fromMsg(r.record.experiment));
        } catch (const std::exception& e) {
          return std::string("the set-up is unknown: ") + e.what();
        }
      });
  return contract;
}

ContractChecker<RecordGoal::Request> KnowledgeBaseComponent::recordGoalContract() {
  core::Contract goal = operation("record_goal", "xpersif/RecordGoal", "store the outcome of a goal-directed episode");
  goal.parameters = {"?run", "?object"};
  goal.preconditions = {{"exists(?run)", "the run (0: the current one) must exist"}};
  goal.effects = {"goal_recorded(?run, ?object)"};
  ContractChecker<RecordGoal::Request> contract(goal);
  contract
      .bind([](const RecordGoal::Request& r) { return core::Bindings{{"?run", runText(r.run_id)}, {"?object", r.object}}; })
      .check("exists(?run)", [this](const RecordGoal::Request& r) { return checkRun(r.run_id, false); });
  return contract;
}

ContractChecker<RecordWorldState::Request> KnowledgeBaseComponent::recordWorldStateContract() {
  core::Contract record_state = operation("record_world_state", "xpersif/RecordWorldState",
                                          "store XPERSim's world state at the start of a step of a run");
  record_state.parameters = {"?run", "?step"};
  record_state.preconditions = {{"running(?run)", "the run (0: the current one) must exist and be running"}};
  record_state.effects = {"world_state_recorded(?run, ?step)"};
  ContractChecker<RecordWorldState::Request> contract(record_state);
  contract
      .bind([](const RecordWorldState::Request& r) {
        return core::Bindings{{"?run", runText(r.run_id)}, {"?step", std::to_string(r.step)}};
      })
      .check("running(?run)", [this](const RecordWorldState::Request& r) { return checkRun(r.run_id, true); });
  return contract;
}

template <class Request>
ContractChecker<Request> KnowledgeBaseComponent::runQueryContract(core::Contract contract,
                                                                  std::vector<std::string> effects) {
  contract.parameters = {"?run"};
  contract.preconditions = {{"exists(?run)", "the run (0: the current one) must exist"}};
  contract.effects = std::move(effects);
  ContractChecker<Request> checker(contract);
  checker.bind([](const Request& r) { return core::Bindings{{"?run", runText(r.run_id)}}; })
      .check("exists(?run)", [this](const Request& r) { return checkRun(r.run_id, false); });
  return checker;
}

// ---- handlers ---------------------------------------------------------------------------------------------

void KnowledgeBaseComponent::startRun(const StartRun::Request& r, StartRun::Response& response) {
  auto kb = store();
  std::optional<core::RunInfo> run;
  if (r.resume) run = kb->resumeRun(r.name);
  response.resumed = run.has_value();
  if (!run) {
    run = kb->createRun(r.name, r.parameters.empty() ? "{}" : r.parameters, static_cast<std::int64_t>(r.seed),
                        r.design);
  }
  response.run_id = static_cast<std::uint64_t>(run->id);
  response.experiments_done = static_cast<std::uint32_t>(kb->experimentCount(run->id, "done"));
  for (const auto& e : kb->experiments(run->id)) response.experiments_designed += e.design != "goal";
  response.goals_done = static_cast<std::uint32_t>(kb->goals(run->id).size());
  response.message = (response.resumed ? "resumed run " : "started run ") + std::to_string(run->id) + " (" +
                     run->name + ")";
  announceRun(run->id);
}

void KnowledgeBaseComponent::finishRun(const FinishRun::Request& r, FinishRun::Response& response) {
  const std::int64_t run = resolveRun(r.run_id);
  store()->finishRun(run, r.status);
  response.message = "run " + std::to_string(run) + " " + r.status;
}

void KnowledgeBaseComponent::recordExperiment(const RecordExperiment::Request& r,
                                              RecordExperiment::Response& response) {
  core::ExperimentRecord input = fromMsg(r.record);
  input.run_id = resolveRun(r.record.run_id);
  const core::ExperimentRecord stored = store()->recordExperiment(input);
  ExperimentRecord published = toMsg(stored);
  // The stored form, so that followers see live exactly what get_experiments gives them on a restore.
  published.design = r.record.design;
  response.id = published.id;
  response.seq = published.seq;
  response.message = "stored experiment " + std::to_string(stored.seq) + " of run " + std::to_string(stored.run_id);
  experiments_pub_.publish(published);
}

void KnowledgeBaseComponent::getExperiments(const GetExperiments::Request& r, GetExperiments::Response& response) {
  const std::int64_t run = resolveRun(r.run_id);
  for (const auto& e : store()->experiments(run, r.status)) response.experiments.push_back(toMsg(e));
  response.message = std::to_string(response.experiments.size()) + " experiments of run " + std::to_string(run);
}

void KnowledgeBaseComponent::recordGoal(const RecordGoal::Request& r, RecordGoal::Response& response) {
  core::GoalRecord g;
  g.run_id = resolveRun(r.run_id);
  g.object = r.object;
  g.target_x = r.target_x;
  g.target_y = r.target_y;
  g.reached = r.reached;
  g.final_error = r.final_error;
  g.pushes_used = static_cast<int>(std::min<std::uint32_t>(r.pushes, 1u << 30));
  const core::GoalRecord stored = store()->recordGoal(g);
  response.message = "stored goal " + std::to_string(stored.id) + " of run " + std::to_string(stored.run_id);
}

void KnowledgeBaseComponent::recordWorldState(const RecordWorldState::Request& r,
                                              RecordWorldState::Response& response) {
  const std::int64_t run = resolveRun(r.run_id);
  store()->recordWorldState(run, r.step, r.state);
  response.message = "stored the world state at step " + std::to_string(r.step) + " of run " + std::to_string(run);
}

void KnowledgeBaseComponent::getWorldState(const GetWorldState::Request& r, GetWorldState::Response& response) {
  const std::int64_t run = resolveRun(r.run_id);
  const auto state = store()->worldState(run, r.step);
  response.found = state.has_value();
  if (state) response.state = *state;
  response.message = (state ? "the world state at step " : "no world state stored for step ") +
                     std::to_string(r.step) + " of run " + std::to_string(run);
}

void KnowledgeBaseComponent::getNotions(const GetNotions::Request& r, GetNotions::Response& response) {
  const std::int64_t run = resolveRun(r.run_id);
  for (const auto& n : store()->notions(run)) response.notions.push_back(toMsg(n));
  response.message = std::to_string(response.notions.size()) + " notions of run " + std::to_string(run);
}

void KnowledgeBaseComponent::getCalls(const GetCalls::Request& r, GetCalls::Response& response) {
  flushCalls();  // what has arrived is answered, not only what the last period wrote
  core::CallFilter filter;
  filter.run_id = resolveRun(r.run_id);
  // A relative name is a component beside the knowledge base, as the events name them (fully resolved).
  filter.component = r.component.empty() ? "" : nodeHandle().resolveName(r.component);
  filter.kind = r.kind;
  filter.since = r.since;
  filter.limit = r.limit == 0 ? kDefaultCallLimit : r.limit;
  bool more = false;
  for (const auto& c : store()->calls(filter, &more)) response.calls.push_back(toMsg(c));
  response.truncated = more;
  response.message = std::to_string(response.calls.size()) + " calls of run " + std::to_string(filter.run_id) +
                     (more ? " (more match: ask again from the last one's time)" : "");
}

void KnowledgeBaseComponent::getFacts(const GetFacts::Request& r, GetFacts::Response& response) {
  flushCalls();
  const std::int64_t run = resolveRun(r.run_id);
  for (const auto& f : store()->facts(run)) response.facts.push_back(f.literal);
  response.message = std::to_string(response.facts.size()) + " facts of run " + std::to_string(run);
}

const core::SetupCatalogue& KnowledgeBaseComponent::catalogue() {
  std::lock_guard<std::mutex> lock(catalogue_mutex_);
  if (!catalogue_) catalogue_ = loadSetupCatalogue(nodeHandle(), privateNodeHandle());
  return *catalogue_;
}

const core::ParameterTable& KnowledgeBaseComponent::parameters() {
  static const core::ParameterTable table = [] {
    core::ParameterTable own(
        "knowledge_base",
        {core::derivedParameter(core::ParameterSpec::Type::String, "database", "$ROS_HOME/xpersif/knowledge.db", 0, INFINITY,
                                "the SQLite file (created with its directory), or :memory:"),
         core::textParameter("model_topic", "machine_learning/model", "MACHINELEARNING's models, stored"),
         core::textParameter("notions_topic", "machine_learning/notions", "MACHINELEARNING's notions, stored"),
         core::textParameter("events_topic", kSharedEventsTopic, "every component's events (calls and their effects), stored"),
         core::numberParameter("event_flush_period", 0.2, 0.01, 10.0, "s of wall time between writes of buffered calls"),
         core::intParameter("max_pending_calls", 10000, 1, 1000000, "calls buffered at most (the oldest are dropped)")});
    own.include(setupCatalogueParameters());
    return own;
  }();
  return table;
}

void KnowledgeBaseComponent::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, KnowledgeBaseComponent::parameters());
  const std::string path = parameters.get<std::string>("database", defaultDatabasePath());
  const std::string model_topic = parameters.get<std::string>("model_topic");
  const std::string notions_topic = parameters.get<std::string>("notions_topic");
  const std::string events_topic = parameters.get<std::string>("events_topic");
  const double event_flush_period = parameters.get<double>("event_flush_period");
  const int max_pending_calls = parameters.get<int>("max_pending_calls");
  if (events_topic.empty()) throw core::ValidationError("~events_topic is empty; give the topic of the components' events");
  if (path.empty()) throw core::ValidationError("~database is empty; give a file path (or :memory:)");
  if (path != ":memory:") {
    const std::filesystem::path parent = std::filesystem::path(path).parent_path();
    std::error_code error;
    if (!parent.empty()) std::filesystem::create_directories(parent, error);
    if (error) {
      throw std::runtime_error("~database: cannot create the directory " + parent.string() + ": " + error.message());
    }
  }
  std::shared_ptr<core::KnowledgeBase> kb;
  try {
    kb = core::KnowledgeBase::open(path);
  } catch (const std::exception& e) {
    throw std::runtime_error("~database " + path + " cannot be used: " + e.what());
  }
  // Restarted (after a crash, or by a supervisor), it goes on with the latest run as the current one, so that a
  // caller asking for run 0 keeps getting the run it started.
  const std::vector<core::RunInfo> runs = kb->runs();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    kb_ = std::move(kb);
    current_run_ = runs.empty() ? 0 : runs.back().id;
    model_topic_ = model_topic;
    notions_topic_ = notions_topic;
    events_topic_ = events_topic;
    event_flush_period_ = event_flush_period;
    max_pending_calls_ = static_cast<std::size_t>(max_pending_calls);
    if (!experiments_pub_) {
      // Latched: a follower that (re)connects after the KB came back gets the latest record; one it missed
      // before shows as a gap, and it restores from the KB (ExperimentFollower).
      experiments_pub_ = privateNodeHandle().advertise<ExperimentRecord>("experiments", 100, true);
      run_pub_ = privateNodeHandle().advertise<std_msgs::UInt64>("run", 1, true);
    }
  }
  ROS_INFO("%s: knowledge base %s", name().c_str(), path.c_str());
}

void KnowledgeBaseComponent::onActivate() {
  std::string model_topic, notions_topic, events_topic;
  double flush_period;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    model_topic = model_topic_;
    notions_topic = notions_topic_;
    events_topic = events_topic_;
    flush_period = event_flush_period_;
  }
  model_sub_ = nodeHandle().subscribe<LearnedModel>(model_topic, 10, [this](const LearnedModel::ConstPtr& m) { onModel(m); });
  notions_sub_ = nodeHandle().subscribe<Notions>(notions_topic, 10, [this](const Notions::ConstPtr& n) { onNotions(n); });
  // Events come in bursts (a plan's steps, a lockstep tick's calls): a deep queue, drained by a cheap callback.
  events_sub_ = nodeHandle().subscribe<ComponentEvent>(events_topic, 1000,
                                                       [this](const ComponentEvent::ConstPtr& e) { onEvent(e); });
  flush_timer_ = nodeHandle().createWallTimer(ros::WallDuration(flush_period), [this](const ros::WallTimerEvent&) {
    flushCalls();
  });
}

void KnowledgeBaseComponent::onDeactivate() {
  model_sub_.shutdown();
  notions_sub_.shutdown();
  events_sub_.shutdown();
  flush_timer_.stop();
  flushCalls();
}

void KnowledgeBaseComponent::onShutdown() {
  onDeactivate();
  std::lock_guard<std::mutex> lock(mutex_);
  kb_.reset();
  current_run_ = 0;
}

std::shared_ptr<core::KnowledgeBase> KnowledgeBaseComponent::store() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!kb_) throw std::runtime_error("the knowledge base is not configured");
  return kb_;
}

std::int64_t KnowledgeBaseComponent::resolveRun(std::uint64_t run_id) const {
  if (run_id != 0) return static_cast<std::int64_t>(run_id);
  std::lock_guard<std::mutex> lock(mutex_);
  if (current_run_ == 0) throw core::ValidationError("run_id is 0 (the current run) but no run has been started; call start_run first");
  return current_run_;
}

std::string KnowledgeBaseComponent::checkRun(std::uint64_t run_id, bool must_run) const {
  try {
    if (run_id > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
      return "run_id " + std::to_string(run_id) + " is not a run of this knowledge base";
    }
    const std::int64_t run = resolveRun(run_id);
    const auto info = store()->run(run);
    if (!info) return "run " + std::to_string(run) + " is not a run of this knowledge base";
    if (must_run && info->status != "running") return "run " + std::to_string(run) + " is " + info->status;
    return "";
  } catch (const std::exception& e) {
    return e.what();
  }
}

void KnowledgeBaseComponent::announceRun(std::int64_t run_id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    current_run_ = run_id;
  }
  std_msgs::UInt64 message;
  message.data = static_cast<std::uint64_t>(run_id);
  run_pub_.publish(message);
}

void KnowledgeBaseComponent::onModel(const LearnedModel::ConstPtr& model) {
  if (model->run_id == 0 || model->data.empty()) return;  // no run yet, or nothing learned
  try {
    store()->storeModel(static_cast<std::int64_t>(model->run_id), "push_learner", model->format, model->data,
                        model->samples);
  } catch (const std::exception& e) {
    ROS_WARN("%s: did not store the model of run %lu: %s", name().c_str(), static_cast<unsigned long>(model->run_id),
             e.what());
  }
}

void KnowledgeBaseComponent::onNotions(const Notions::ConstPtr& notions) {
  if (notions->run_id == 0) return;
  try {
    core::throwIfInvalid(core::checkMaxSize("notions", notions->notions.size(), kMaxNotions));
    std::vector<core::Notion> converted;
    for (const auto& n : notions->notions) converted.push_back(fromMsg(n));
    store()->replaceNotions(static_cast<std::int64_t>(notions->run_id), converted);
  } catch (const std::exception& e) {
    ROS_WARN("%s: did not store the notions of run %lu: %s", name().c_str(),
             static_cast<unsigned long>(notions->run_id), e.what());
  }
}

void KnowledgeBaseComponent::onEvent(const ComponentEvent::ConstPtr& event) {
  // Command acceptances are half a call (the outcome follows); lifecycle and supervision are not calls.
  const bool command = event->kind == ComponentEvent::COMMAND;
  if (!(command || event->kind == ComponentEvent::OPERATION) || (command && event->outcome == "accepted")) return;
  core::CallRecord call;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    call.run_id = current_run_;
  }
  call.time = event->header.stamp.toSec();
  call.component = event->component;
  call.kind = command ? "command" : "operation";
  call.name = event->name;
  call.outcome = event->outcome;
  if (!command && event->code != ComponentEvent::NO_CODE) call.code = event->code;
  call.reason = core::shortenText(event->reason, core::KnowledgeBase::kMaxTextLength);
  call.effects = event->effects;
  call.duration = std::isfinite(event->duration) && event->duration > 0.0 ? event->duration : 0.0;
  std::size_t dropped = 0;
  {
    std::lock_guard<std::mutex> lock(pending_mutex_);
    pending_calls_.push_back(std::move(call));
    if (pending_calls_.size() > max_pending_calls_) {
      dropped = pending_calls_.size() - max_pending_calls_;
      pending_calls_.erase(pending_calls_.begin(), pending_calls_.begin() + static_cast<std::ptrdiff_t>(dropped));
    }
  }
  if (dropped) {
    ROS_WARN_THROTTLE(5.0, "%s: more than ~max_pending_calls calls wait to be written; dropped the oldest",
                      name().c_str());
  }
}

void KnowledgeBaseComponent::flushCalls() {
  std::lock_guard<std::mutex> flushing(flush_mutex_);
  std::vector<core::CallRecord> batch;
  {
    std::lock_guard<std::mutex> lock(pending_mutex_);
    batch.swap(pending_calls_);
  }
  if (batch.empty()) return;
  std::shared_ptr<core::KnowledgeBase> kb;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    kb = kb_;
  }
  if (!kb) return;  // shut down: nothing to write to
  try {
    kb->recordCalls(batch);
    return;
  } catch (const core::ValidationError& e) {
    ROS_WARN("%s: a batch of %zu calls was refused (%s); storing them one by one", name().c_str(), batch.size(),
             e.what());
  } catch (const std::exception& e) {
    ROS_ERROR("%s: could not store %zu calls: %s", name().c_str(), batch.size(), e.what());
    return;
  }
  // One bad call (a component's malformed effect) must not cost the others their place.
  for (const auto& call : batch) {
    try {
      kb->recordCalls({call});
    } catch (const std::exception& e) {
      ROS_WARN("%s: did not store %s's call of %s: %s", name().c_str(), call.component.c_str(), call.name.c_str(),
               e.what());
    }
  }
}

}  // namespace xpersif
