#include "xpersif/decision/planner_component.h"

#include "xpersif/component/parameter_reader.h"

#include <algorithm>
#include <chrono>

#include "xpersif/GetContracts.h"
#include "xpersif/GetFacts.h"
#include "xpersif/decision/decision_common.h"

namespace xpersif {

namespace {
std::string shortName(const std::string& qualified) {
  const auto slash = qualified.find('/');
  return slash == std::string::npos ? qualified : qualified.substr(slash + 1);
}
}  // namespace

std::vector<core::Contract> qualifiedOperators(const std::vector<ComponentContracts>& components,
                                               const std::vector<std::string>& prefer) {
  std::vector<const ComponentContracts*> ordered;
  for (const auto& p : prefer) {
    for (const auto& c : components) {
      if (c.component == p) ordered.push_back(&c);
    }
  }
  for (const auto& c : components) {
    if (std::find(prefer.begin(), prefer.end(), c.component) == prefer.end()) ordered.push_back(&c);
  }
  std::vector<core::Contract> operators;
  for (const auto* c : ordered) {
    for (core::Contract contract : c->contracts) {
      contract.name = c->component + "/" + contract.name;
      operators.push_back(std::move(contract));
    }
  }
  return operators;
}

std::set<std::string> qualifyExcluded(const std::vector<std::string>& excluded,
                                      const std::vector<core::Contract>& operators) {
  std::set<std::string> out;
  for (const auto& entry : excluded) {
    const auto open = entry.find('(');
    const std::string name = entry.substr(0, open);
    if (name.find('/') != std::string::npos) {
      out.insert(entry);
      continue;
    }
    bool matched = false;
    for (const auto& op : operators) {
      if (shortName(op.name) != name) continue;
      out.insert(op.name.substr(0, op.name.size() - name.size()) + entry);
      matched = true;
    }
    if (!matched) out.insert(entry);  // excludes nothing, but the planner still validates it
  }
  return out;
}

std::vector<PlanStep> toStepMessages(const std::vector<core::PlanStep>& steps,
                                     const std::vector<core::Contract>& operators) {
  std::vector<PlanStep> out;
  for (const auto& step : steps) {
    PlanStep m;
    const auto slash = step.operator_name.find('/');
    m.component = step.operator_name.substr(0, slash);
    m.operator_name = step.operator_name.substr(slash + 1);
    for (const auto& op : operators) {
      if (op.name == step.operator_name) m.interface_type = op.interface_type;
    }
    for (const auto& p : step.parameters) {
      m.parameters.push_back(p);
      const auto bound = step.bindings.find(p);
      m.values.push_back(bound == step.bindings.end() ? p : bound->second);
    }
    out.push_back(std::move(m));
  }
  return out;
}

namespace {
/// "" when @p goal is one or more ground literals; otherwise why not.
std::string whyNotGround(const std::vector<std::string>& goal) {
  if (goal.empty()) return "the goal is empty";
  for (const auto& text : goal) {
    try {
      const core::Literal l = core::parseLiteral(text);
      for (const auto& a : l.arguments) {
        if (a[0] == '?') return "goal literal '" + text + "' has the variable " + a + "; give a value";
      }
    } catch (const std::exception& e) {
      return e.what();
    }
  }
  return "";
}
}  // namespace

Planner::Planner(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/PlannerNodelet"),
      searches_("xpersif::core::PlanSearch", "plan search") {
  core::Contract declared;
  declared.name = "make_plan";
  declared.kind = core::Contract::Kind::Operation;
  declared.interface_type = "xpersif/MakePlan";
  declared.description = "a plan of the embodiment's commands and operations that reaches the goal";
  declared.parameters = {"?goal"};
  declared.preconditions = {
      {"contracts_loaded(operators)", "the contracts of every component in ~components must have been read"},
      {"ground(?goal)", "the goal must be one or more ground literals, such as pushed(box_1, -x, 0.01, 0.05)"}};
  declared.effects = {"planned(?goal)"};
  ContractChecker<MakePlan::Request> contract(declared);
  contract
      .bind([](const MakePlan::Request& r) {
        return core::Bindings{{"?goal", std::to_string(r.goal.size()) + "_literals"}};
      })
      .check("contracts_loaded(operators)", [this](const MakePlan::Request&) { return whyNotLoaded(); })
      .check("ground(?goal)", [](const MakePlan::Request& r) { return whyNotGround(r.goal); });
  addOperation<MakePlan>(
      contract,
      [](const MakePlan::Request& r) {
        // A malformed goal is a bad request (INVALID), not a condition that may come to hold: checked here first.
        const std::string why = whyNotGround(r.goal);
        if (!why.empty()) throw core::ValidationError(why);
        core::requireMaxSize("goal", r.goal.size(), 64);
        core::requireMaxSize("state", r.state.size(), 256);
        core::requireMaxSize("excluded", r.excluded.size(), 256);
      },
      [this](const MakePlan::Request& request, MakePlan::Response& response) { makePlan(request, response); });
}

Planner::~Planner() { stopLoader(); }

const core::ParameterTable& Planner::parameters() {
  static const core::ParameterTable table(
      "planner",
      {core::textParameter("search_type", "breadth_first",
                           "the plan search plugin: breadth_first, greedy or another package's (doc/plugins.md)"),
       core::namesParameter("components", {"observation", "vision", "manipulation", "relocation"}, 64,
                            "the components whose contracts are the planning operators"),
       core::namesParameter("prefer", {"vision"}, 64, "components preferred when operators tie"),
       core::intParameter("max_depth", 8, 1, 64, "the longest plan, in steps"),
       core::numberParameter("retry_period", 1.0, 0.01, 60.0, "s of wall time between tries to read missing contracts"),
       core::textParameter("knowledge_base", "knowledge_base", "namespace of the knowledge base's get_facts"),
       core::numberParameter("knowledge_base_timeout", 2.0, 0.01, 60.0,
                             "s of wall time to wait for the knowledge base's facts")});
  return table;
}

void Planner::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, Planner::parameters());
  const std::string search_type = parameters.get<std::string>("search_type");
  const std::vector<std::string> components = parameters.get<std::vector<std::string>>("components");
  const std::vector<std::string> prefer = parameters.get<std::vector<std::string>>("prefer");
  const int max_depth = parameters.get<int>("max_depth");
  const double retry_period = parameters.get<double>("retry_period");
  const std::string knowledge_base = parameters.get<std::string>("knowledge_base");
  const double knowledge_base_timeout = parameters.get<double>("knowledge_base_timeout");
  core::requireIdentifier("~knowledge_base", knowledge_base);
  if (components.empty()) throw core::ValidationError("~components is empty; list the components to plan with");
  for (const auto& c : components) core::requireIdentifier("~components entry", c);
  std::shared_ptr<const core::PlanSearch> search = searches_.create("~search_type", search_type);
  ROS_INFO("%s: search %s: %s", name().c_str(), search_type.c_str(), search->description().c_str());
  stopLoader();
  std::lock_guard<std::mutex> lock(mutex_);
  search_ = std::move(search);
  components_ = components;
  prefer_ = prefer;
  max_depth_ = max_depth;
  retry_period_ = retry_period;
  knowledge_base_ = knowledge_base;
  knowledge_base_timeout_ = knowledge_base_timeout;
  loaded_.clear();
  operators_.clear();
}

void Planner::onActivate() { startLoader(); }
void Planner::onDeactivate() { stopLoader(); }
void Planner::onShutdown() { stopLoader(); }

void Planner::startLoader() {
  std::lock_guard<std::mutex> lock(loader_mutex_);
  if (loader_.joinable()) return;
  loader_stop_ = false;
  loader_ = std::thread([this] { loadContracts(); });
}

void Planner::stopLoader() {
  std::thread loader;
  {
    std::lock_guard<std::mutex> lock(loader_mutex_);
    loader_stop_ = true;
    loader_wakeup_.notify_all();
    loader = std::move(loader_);
  }
  if (loader.joinable()) loader.join();
}

void Planner::loadContracts() {
  while (!loader_stop_ && ros::ok()) {
    std::vector<std::string> missing;
    double period;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& c : components_) {
        const bool have = std::any_of(loaded_.begin(), loaded_.end(), [&](const auto& l) { return l.component == c; });
        if (!have) missing.push_back(c);
      }
      period = retry_period_;
    }
    for (const auto& component : missing) {
      if (loader_stop_) return;
      const std::string service = nodeHandle().resolveName(component + "/get_contracts");
      if (!ros::service::waitForService(service, ros::Duration(0.05))) continue;
      GetContracts call;
      if (!ros::service::call(service, call) || !call.response.success) continue;
      ComponentContracts got{component, {}};
      try {
        for (const auto& c : call.response.contracts) got.contracts.push_back(fromContractMsg(c));
      } catch (const std::exception& e) {
        ROS_WARN_STREAM(name() << ": contracts of " << component << " are unusable: " << e.what());
        continue;
      }
      std::lock_guard<std::mutex> lock(mutex_);
      loaded_.push_back(std::move(got));
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (loaded_.size() == components_.size()) {
        // Keep the order of ~components whatever the order of the answers.
        std::vector<ComponentContracts> ordered;
        for (const auto& c : components_) {
          for (const auto& l : loaded_) {
            if (l.component == c) ordered.push_back(l);
          }
        }
        operators_ = qualifiedOperators(ordered, prefer_);
        std::size_t count = operators_.size();
        ROS_INFO_STREAM(name() << ": loaded " << count << " operators from " << joinNames(components_));
        return;
      }
    }
    std::unique_lock<std::mutex> lock(loader_mutex_);
    loader_wakeup_.wait_for(lock, std::chrono::duration<double>(period), [this] { return loader_stop_.load(); });
  }
}

std::string Planner::whyNotLoaded() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!operators_.empty()) return "";
  std::vector<std::string> missing;
  for (const auto& c : components_) {
    if (std::none_of(loaded_.begin(), loaded_.end(), [&](const auto& l) { return l.component == c; })) {
      missing.push_back(c);
    }
  }
  return "the contracts of " + joinNames(missing) + " have not been read yet (their get_contracts did not answer)";
}

void Planner::makePlan(const MakePlan::Request& request, MakePlan::Response& response) {
  core::PlanningProblem problem;
  std::shared_ptr<const core::PlanSearch> search;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    search = search_;
    problem.operators = operators_;
    problem.max_depth = static_cast<std::size_t>(max_depth_);
  }
  problem.goal = request.goal;
  problem.initial_state.insert(request.state.begin(), request.state.end());
  if (request.state_from_knowledge_base) {
    const std::vector<std::string> facts = knowledgeBaseFacts();
    problem.initial_state.insert(facts.begin(), facts.end());
  }
  problem.excluded_steps = qualifyExcluded(request.excluded, problem.operators);
  if (!search) throw core::UnavailableError("not configured");
  const core::PlanResult result = core::plan(problem, *search);  // ValidationError for bad literals: a refusal
  if (!result.found) throw std::runtime_error("no plan: " + result.reason);
  response.steps = toStepMessages(result.steps, problem.operators);
  std::string text;
  std::vector<std::string> open;
  for (const auto& step : result.steps) {
    text += (text.empty() ? "" : ", ") + step.toString();
    for (const auto& p : step.openParameters()) open.push_back(step.operator_name + " " + p);
  }
  response.message = std::to_string(result.steps.size()) + " steps: " + text;
  if (!open.empty()) response.message += "; open parameters (the goal binds none): " + joinNames(open);
}

std::vector<std::string> Planner::knowledgeBaseFacts() {
  std::string service;
  double timeout;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    service = nodeHandle().resolveName(knowledge_base_ + "/get_facts");
    timeout = knowledge_base_timeout_;
  }
  // A blocking call is fine here: make_plan runs on the manager's threads, and the KB lives in its own manager.
  if (!ros::service::waitForService(service, ros::Duration(timeout))) {
    throw core::UnavailableError("the knowledge base's " + service + " is not offered, so its facts cannot be the state");
  }
  GetFacts call;  // run_id 0: the current run
  if (!ros::service::call(service, call)) throw core::UnavailableError("the call of " + service + " did not go through");
  if (!call.response.success) throw std::runtime_error(service + " refused: " + call.response.message);
  return call.response.facts;
}

}  // namespace xpersif
