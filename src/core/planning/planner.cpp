/**
 * @file planner.cpp
 * @brief STRIPS planning over contracts: validation, grounding by unification, relaxed reachability (for
 *        the reason sentence), backward relevance pruning, breadth-first search. See planner.h for the rules.
 */
#include "xpersif/core/planning/planner.h"

#include "xpersif/core/common/validation.h"

#include <algorithm>
#include <tuple>
#include <unordered_map>
#include <stdexcept>
#include <unordered_set>

namespace xpersif::core {

namespace {

// By name only: "observed(before)" and "observed(after, red_cube)" are the same notion, so one component
// producing either makes both tracked (keying by arity too would silently assume the other one true).
std::string predicateKey(const Literal& l) { return l.predicate; }

bool isVariable(const std::string& arg) { return !arg.empty() && arg[0] == '?'; }

bool isGround(const Literal& l) { return std::none_of(l.arguments.begin(), l.arguments.end(), isVariable); }

Literal positive(Literal l) {
  l.negated = false;
  return l;
}

std::string quoted(const std::string& s) { return "'" + s + "'"; }

/// Parse a literal of the problem (not of a contract): malformed input is the caller's mistake.
Literal parseProblemLiteral(const std::string& field, const std::string& text) {
  try {
    return parseLiteral(text);
  } catch (const ContractError& e) {
    throw ValidationError(field + " is malformed: " + e.what());
  }
}

/// An operator schema with its literals parsed once.
struct Schema {
  const Contract* contract = nullptr;
  std::vector<Literal> preconditions;  // same order as contract->preconditions
  std::vector<Literal> effects;
};

/// The problem checked and parsed: what every entry point needs.
struct Compiled {
  std::vector<Schema> schemas;
  std::set<std::string> fluent;  // predicate keys the planner tracks
  std::set<std::string> initial;  // canonical positive ground literals
  std::vector<Literal> goal;
};

Compiled compile(const PlanningProblem& problem) {
  Compiled c;
  std::set<std::string> names;
  for (const auto& op : problem.operators) {
    op.validate();
    if (!names.insert(op.name).second) {
      throw ContractError("two operators are named '" + op.name + "'; operator names must be unique");
    }
    Schema s;
    s.contract = &op;
    for (const auto& pre : op.preconditions) s.preconditions.push_back(parseLiteral(pre.literal));
    for (const auto& eff : op.effects) {
      s.effects.push_back(parseLiteral(eff));
      c.fluent.insert(predicateKey(s.effects.back()));
    }
    c.schemas.push_back(std::move(s));
  }
  for (const auto& text : problem.initial_state) {
    const Literal l = parseProblemLiteral("initial_state literal '" + text + "'", text);
    if (l.negated) {
      throw ValidationError("initial_state literal '" + text +
                            "' is negated; list only what holds (absent literals are false)");
    }
    if (!isGround(l)) throw ValidationError("initial_state literal '" + text + "' has a parameter; it must be ground");
    c.fluent.insert(predicateKey(l));
    c.initial.insert(l.toString());
  }
  for (std::size_t i = 0; i < problem.goal.size(); ++i) {
    const std::string field = "goal[" + std::to_string(i) + "] '" + problem.goal[i] + "'";
    const Literal l = parseProblemLiteral(field, problem.goal[i]);
    if (!isGround(l)) throw ValidationError(field + " has a parameter; goal literals must be ground");
    c.fluent.insert(predicateKey(l));
    c.goal.push_back(l);
  }
  for (const auto& [param, values] : problem.parameter_domains) {
    const std::string field = "parameter_domains['" + param + "']";
    if (!isVariable(param) || param.size() < 2) throw ValidationError(field + ": a parameter name must start with '?'");
    if (values.empty()) throw ValidationError(field + " is empty; list at least one value or leave the parameter out");
    for (const auto& v : values) {
      Literal probe;
      try {
        probe = parseLiteral("value(" + v + ")");
      } catch (const ContractError&) {
        throw ValidationError(field + " holds '" + v + "', which is not a valid argument");
      }
      if (probe.arguments.size() != 1 || isVariable(v)) {
        throw ValidationError(field + " holds '" + v + "', which is not a single constant");
      }
    }
  }
  return c;
}

/// Unify a (lifted) literal with a ground one, extending @p b; false when they do not match.
bool unify(const Literal& lifted, const Literal& ground_literal, Bindings& b) {
  if (lifted.predicate != ground_literal.predicate || lifted.arguments.size() != ground_literal.arguments.size()) {
    return false;
  }
  for (std::size_t i = 0; i < lifted.arguments.size(); ++i) {
    const std::string& a = lifted.arguments[i];
    const std::string& v = ground_literal.arguments[i];
    if (!isVariable(a)) {
      if (a != v) return false;
      continue;
    }
    auto it = b.find(a);
    if (it == b.end()) {
      b.emplace(a, v);
    } else if (it->second != v) {
      return false;
    }
  }
  return true;
}

Literal groundLiteral(Literal l, const Bindings& b) {
  for (auto& a : l.arguments) {
    auto it = b.find(a);
    if (it != b.end()) a = it->second;
  }
  return l;
}

std::string stepString(const std::string& name, const std::vector<std::string>& params, const Bindings& b) {
  std::string out = name + "(";
  for (std::size_t i = 0; i < params.size(); ++i) {
    auto it = b.find(params[i]);
    out += (i ? ", " : "") + (it == b.end() ? params[i] : it->second);
  }
  return out + ")";
}

/// One operator instance.
struct GroundOp {
  std::size_t schema = 0;
  Bindings bindings;
  std::string text;  // PlanStep::toString()
  std::vector<int> pre_pos, pre_neg, add, del;
  std::vector<std::string> assumed;
  bool excluded = false;
};

class Grounder {
 public:
  Grounder(const PlanningProblem& problem, const Compiled& compiled) : problem_(problem), c_(compiled) {
    for (const auto& text : problem.excluded_steps) {
      if (text.find('(') == std::string::npos) {
        excluded_names_.insert(text);
      } else {
        excluded_steps_.insert(parseProblemLiteral("excluded_steps entry '" + text + "'", text).toString());
      }
    }
  }

  /// Ground every schema to a fixpoint; false when the grounding limit was hit.
  bool run() {
    std::set<std::string> known;  // positive ground fluent literals seen so far
    std::map<std::string, std::vector<Literal>> known_by_key;
    auto learn = [&](const Literal& l) {
      const Literal p = positive(l);
      if (known.insert(p.toString()).second) known_by_key[predicateKey(p)].push_back(p);
    };
    for (const auto& s : c_.initial) learn(parseLiteral(s));
    for (const auto& g : c_.goal) learn(g);

    bool grew = true;
    while (grew) {
      grew = false;
      const std::size_t known_before = known.size();
      for (std::size_t si = 0; si < c_.schemas.size(); ++si) {
        std::vector<Bindings> instances;
        if (!instancesOf(si, known_by_key, instances)) return false;
        for (auto& b : instances) {
          const std::string text = stepString(c_.schemas[si].contract->name, c_.schemas[si].contract->parameters, b);
          if (!seen_.insert(text).second) continue;
          ops_.push_back(build(si, std::move(b), text));
          if (ops_.size() > problem_.max_groundings) return false;
          const Schema& s = c_.schemas[si];
          for (const auto& l : s.preconditions) {
            if (isFluent(l)) learn(groundLiteral(l, ops_.back().bindings));
          }
          for (const auto& l : s.effects) learn(groundLiteral(l, ops_.back().bindings));
        }
      }
      grew = known.size() != known_before;
    }
    // Declaration order decides between equally short plans, whatever order the fixpoint found instances in.
    std::stable_sort(ops_.begin(), ops_.end(), [](const GroundOp& a, const GroundOp& b) { return a.schema < b.schema; });
    return true;
  }

  int fact(const Literal& positive_ground) {
    const std::string key = positive_ground.toString();
    auto it = ids_.find(key);
    if (it != ids_.end()) return it->second;
    const int id = static_cast<int>(facts_.size());
    ids_.emplace(key, id);
    facts_.push_back(key);
    return id;
  }

  bool isFluent(const Literal& l) const { return c_.fluent.count(predicateKey(l)) > 0; }

  std::vector<GroundOp> ops_;
  std::vector<std::string> facts_;
  std::unordered_map<std::string, int> ids_;

 private:
  /// The candidate bindings of schema @p si; false when their number exceeds the grounding limit.
  bool instancesOf(std::size_t si, const std::map<std::string, std::vector<Literal>>& known_by_key,
                   std::vector<Bindings>& out) {
    const Schema& s = c_.schemas[si];
    std::vector<const Literal*> fluent_literals;
    for (const auto& l : s.preconditions) {
      if (isFluent(l)) fluent_literals.push_back(&l);
    }
    for (const auto& l : s.effects) fluent_literals.push_back(&l);

    std::vector<std::pair<std::string, std::vector<std::string>>> candidates;  // open parameters are left out
    for (const auto& param : s.contract->parameters) {
      auto dom = problem_.parameter_domains.find(param);
      if (dom != problem_.parameter_domains.end()) {
        std::vector<std::string> values;
        for (const auto& v : dom->second) {
          if (std::find(values.begin(), values.end(), v) == values.end()) values.push_back(v);
        }
        candidates.emplace_back(param, values);
        continue;
      }
      bool in_fluent = false;
      std::set<std::string> values;
      for (const Literal* l : fluent_literals) {
        if (std::find(l->arguments.begin(), l->arguments.end(), param) == l->arguments.end()) continue;
        in_fluent = true;
        auto known = known_by_key.find(predicateKey(*l));
        if (known == known_by_key.end()) continue;
        for (const auto& g : known->second) {
          Bindings b;
          if (unify(positive(*l), g, b)) values.insert(b.at(param));
        }
      }
      if (!in_fluent) continue;  // open: supplied by the caller at execution time
      if (values.empty()) return true;  // no instance yet
      candidates.emplace_back(param, std::vector<std::string>(values.begin(), values.end()));
    }
    std::size_t total = 1;
    for (const auto& c : candidates) {
      total *= c.second.size();
      if (total > problem_.max_groundings) return false;
    }
    // Odometer enumeration: deterministic order (parameters in declaration order, values in domain/sorted order).
    std::vector<std::size_t> index(candidates.size(), 0);
    for (std::size_t n = 0; n < total; ++n) {
      Bindings b;
      for (std::size_t i = 0; i < candidates.size(); ++i) b[candidates[i].first] = candidates[i].second[index[i]];
      out.push_back(std::move(b));
      for (std::size_t i = candidates.size(); i-- > 0;) {
        if (++index[i] < candidates[i].second.size()) break;
        index[i] = 0;
      }
    }
    return true;
  }

  GroundOp build(std::size_t si, Bindings b, const std::string& text) {
    const Schema& s = c_.schemas[si];
    GroundOp op;
    op.schema = si;
    op.text = text;
    op.excluded = excluded_names_.count(s.contract->name) > 0 || excluded_steps_.count(text) > 0;
    for (const auto& l : s.preconditions) {
      const Literal g = groundLiteral(l, b);
      if (!isFluent(l)) {
        op.assumed.push_back(g.toString());
      } else {
        (g.negated ? op.pre_neg : op.pre_pos).push_back(fact(positive(g)));
      }
    }
    for (const auto& l : s.effects) {
      const Literal g = groundLiteral(l, b);
      (g.negated ? op.del : op.add).push_back(fact(positive(g)));
    }
    op.bindings = std::move(b);
    return op;
  }

  const PlanningProblem& problem_;
  const Compiled& c_;
  std::set<std::string> excluded_names_, excluded_steps_;
  std::set<std::string> seen_;
};

bool contains(const std::vector<int>& v, int x) { return std::find(v.begin(), v.end(), x) != v.end(); }

/// Relaxed reachability (deletes ignored, both polarities) and the sentence explaining a failure.
class Reachability {
 public:
  Reachability(const Grounder& g, const std::vector<bool>& init) : g_(g) {
    const std::size_t n = g.facts_.size();
    pos_ = init;
    neg_.assign(n, false);
    for (std::size_t f = 0; f < n; ++f) neg_[f] = !init[f];
    reachable_.assign(g.ops_.size(), false);
    bool changed = true;
    while (changed) {
      changed = false;
      for (std::size_t i = 0; i < g.ops_.size(); ++i) {
        const GroundOp& op = g.ops_[i];
        if (reachable_[i] || op.excluded || !applicable(op)) continue;
        reachable_[i] = true;
        changed = true;
        for (int f : op.add) pos_[f] = true;
        for (int f : op.del) neg_[f] = true;
      }
    }
  }

  bool reachable(std::size_t op) const { return reachable_[op]; }
  bool holds(int f, bool negated) const { return negated ? neg_[f] : pos_[f]; }

  /// Why fact @p f (with polarity) cannot be reached; @p depth bounds the chain of "which ..." clauses.
  std::string explain(int f, bool negated, const std::vector<Schema>& schemas, int depth,
                      std::set<std::pair<int, bool>>& visited) const {
    if (!visited.insert({f, negated}).second || depth > 3) return "cannot be reached either";
    std::vector<std::size_t> achievers;
    for (std::size_t i = 0; i < g_.ops_.size(); ++i) {
      if (contains(negated ? g_.ops_[i].del : g_.ops_[i].add, f)) achievers.push_back(i);
    }
    if (achievers.empty()) {
      if (negated) return "holds in the initial state and no operator deletes it";
      const Literal l = parseLiteral(g_.facts_[f]);
      for (const auto& s : schemas) {
        for (const auto& e : s.effects) {
          Bindings b;
          if (!e.negated && unify(e, l, b)) {
            return "is not in the initial state, and operator '" + s.contract->name +
                   "' has a matching effect but its parameters cannot take those values (check parameter_domains)";
          }
        }
      }
      return "is not in the initial state and no operator's effect produces it";
    }
    const auto usable = std::find_if(achievers.begin(), achievers.end(),
                                     [&](std::size_t i) { return !g_.ops_[i].excluded; });
    if (usable == achievers.end()) {
      return std::string(negated ? "is deleted" : "is produced") + " only by the excluded step " +
             quoted(g_.ops_[achievers.front()].text);
    }
    const GroundOp& op = g_.ops_[*usable];
    for (int p : op.pre_pos) {
      if (!pos_[p]) {
        return std::string(negated ? "would be deleted by " : "would be produced by ") + quoted(op.text) +
               ", which needs " + quoted(g_.facts_[p]) + ", which " + explain(p, false, schemas, depth + 1, visited);
      }
    }
    for (int p : op.pre_neg) {
      if (!neg_[p]) {
        return std::string(negated ? "would be deleted by " : "would be produced by ") + quoted(op.text) +
               ", which needs " + quoted("not " + g_.facts_[p]) + ", which " +
               explain(p, true, schemas, depth + 1, visited);
      }
    }
    return "cannot be reached";
  }

 private:
  bool applicable(const GroundOp& op) const {
    for (int f : op.pre_pos) {
      if (!pos_[f]) return false;
    }
    for (int f : op.pre_neg) {
      if (!neg_[f]) return false;
    }
    return true;
  }

  const Grounder& g_;
  std::vector<bool> pos_, neg_;
  std::vector<bool> reachable_;
};

PlanStep makeStep(const Compiled& c, const GroundOp& op) {
  PlanStep step;
  step.operator_name = c.schemas[op.schema].contract->name;
  step.bindings = op.bindings;
  step.parameters = c.schemas[op.schema].contract->parameters;
  step.assumed = op.assumed;
  return step;
}

const Schema* findSchema(const Compiled& c, const std::string& name) {
  for (const auto& s : c.schemas) {
    if (s.contract->name == name) return &s;
  }
  return nullptr;
}

}  // namespace

std::string PlanStep::toString() const { return stepString(operator_name, parameters, bindings); }

std::vector<std::string> PlanStep::openParameters() const {
  std::vector<std::string> open;
  for (const auto& p : parameters) {
    if (!bindings.count(p)) open.push_back(p);
  }
  return open;
}

PlanResult plan(const PlanningProblem& problem, const PlanSearch& search) {
  const Compiled c = compile(problem);
  PlanResult result;

  Grounder g(problem, c);
  if (!g.run()) {
    result.reason = "grounding stopped at the limit of " + std::to_string(problem.max_groundings) +
                    " operator instances; narrow parameter_domains or raise max_groundings";
    return result;
  }
  // Intern the goal and initial literals (they may appear in no operator).
  std::vector<std::pair<int, bool>> goal;
  for (const auto& l : c.goal) goal.emplace_back(g.fact(positive(l)), l.negated);
  for (const auto& s : c.initial) g.fact(parseLiteral(s));
  const std::size_t n = g.facts_.size();
  std::vector<bool> init(n, false);
  for (const auto& s : c.initial) init[g.ids_.at(s)] = true;

  auto satisfied = [&](const std::vector<bool>& state) {
    return std::all_of(goal.begin(), goal.end(), [&](const auto& lit) { return state[lit.first] != lit.second; });
  };
  if (satisfied(init)) {
    result.found = true;
    return result;
  }

  const Reachability reach(g, init);
  for (std::size_t i = 0; i < goal.size(); ++i) {
    if (!reach.holds(goal[i].first, goal[i].second)) {
      std::set<std::pair<int, bool>> visited;
      result.reason = "goal literal " + quoted(c.goal[i].toString()) + " cannot be reached: it " +
                      reach.explain(goal[i].first, goal[i].second, c.schemas, 0, visited);
      return result;
    }
  }

  // Backward relevance: keep the reachable instances that add a needed fact or delete a fact needed false.
  std::vector<bool> rel_pos(n, false), rel_neg(n, false);
  for (const auto& [f, negated] : goal) (negated ? rel_neg : rel_pos)[f] = true;
  std::vector<bool> relevant(g.ops_.size(), false);
  for (bool changed = true; changed;) {
    changed = false;
    for (std::size_t i = 0; i < g.ops_.size(); ++i) {
      const GroundOp& op = g.ops_[i];
      if (relevant[i] || !reach.reachable(i)) continue;
      const bool helps = std::any_of(op.add.begin(), op.add.end(), [&](int f) { return rel_pos[f]; }) ||
                         std::any_of(op.del.begin(), op.del.end(), [&](int f) { return rel_neg[f]; });
      if (!helps) continue;
      relevant[i] = changed = true;
      for (int f : op.pre_pos) rel_pos[f] = true;
      for (int f : op.pre_neg) rel_neg[f] = true;
    }
  }
  std::vector<std::size_t> ops;
  for (std::size_t i = 0; i < g.ops_.size(); ++i) {
    if (relevant[i]) ops.push_back(i);
  }
  result.groundings = ops.size();

  // The search itself is the configured algorithm's (plan_search.h): it sees facts and actions as numbers.
  SearchSpace space;
  space.initial = init;
  space.goal = goal;
  space.max_depth = problem.max_depth;
  space.max_expansions = problem.max_expansions;
  for (std::size_t i : ops) {
    const GroundOp& op = g.ops_[i];
    space.actions.push_back({op.pre_pos, op.pre_neg, op.add, op.del});
  }
  const SearchResult found = search.search(space);
  result.expanded = found.expanded;
  switch (found.outcome) {
    case SearchResult::Outcome::Found:
      for (std::size_t a : found.plan) {
        if (a >= ops.size()) throw std::logic_error("the plan search returned an action that does not exist");
        result.steps.push_back(makeStep(c, g.ops_[ops[a]]));
      }
      result.found = true;
      break;
    case SearchResult::Outcome::ExpansionLimit:
      result.reason = "the search expanded its limit of " + std::to_string(problem.max_expansions) +
                      " states without reaching the goal; raise max_expansions or narrow parameter_domains";
      break;
    case SearchResult::Outcome::DepthLimit:
      result.reason = "no plan of at most " + std::to_string(problem.max_depth) +
                      (problem.max_depth == 1 ? " step" : " steps") +
                      " reaches the goal (the search stopped at max_depth; a longer plan may exist)";
      break;
    case SearchResult::Outcome::Exhausted:
      result.reason =
          "each goal literal can be reached on its own, but no sequence of steps makes them all hold together "
          "(the steps' delete effects undo one another)";
      break;
  }
  return result;
}

PlanResult plan(const PlanningProblem& problem) {
  if (problem.search == SearchStrategy::GreedyGoalCount) return plan(problem, GreedyGoalCountSearch());
  return plan(problem, BreadthFirstSearch());
}

std::set<std::string> applyStep(const PlanningProblem& problem, const std::set<std::string>& state,
                                const PlanStep& step) {
  const Contract* op = nullptr;
  for (const auto& o : problem.operators) {
    if (o.name == step.operator_name) op = &o;
  }
  if (!op) throw ContractError("there is no operator named '" + step.operator_name + "'");
  std::set<std::string> next = state;
  std::vector<Literal> effects;
  for (const auto& e : op->effects) effects.push_back(groundLiteral(parseLiteral(e), step.bindings));
  for (const auto& e : effects) {
    if (e.negated) next.erase(positive(e).toString());
  }
  for (const auto& e : effects) {
    if (!e.negated) next.insert(e.toString());
  }
  return next;
}

std::string validatePlan(const PlanningProblem& problem, const std::vector<PlanStep>& steps) {
  const Compiled c = compile(problem);
  std::set<std::string> state = c.initial;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const std::string where = "step " + std::to_string(i + 1) + " " + quoted(steps[i].toString());
    const Schema* s = findSchema(c, steps[i].operator_name);
    if (!s) return where + ": there is no operator named " + quoted(steps[i].operator_name);
    for (std::size_t k = 0; k < s->preconditions.size(); ++k) {
      const Literal& pre = s->preconditions[k];
      if (!c.fluent.count(predicateKey(pre))) continue;  // static: the component checks it
      const Literal g = groundLiteral(pre, steps[i].bindings);
      if (!isGround(g)) {
        return where + ": precondition " + quoted(g.toString()) + " has an unbound parameter";
      }
      const bool present = state.count(positive(g).toString()) > 0;
      if (present == g.negated) {
        return where + ": precondition " + quoted(g.toString()) + " (" + s->contract->preconditions[k].description +
               ") does not hold";
      }
    }
    state = applyStep(problem, state, steps[i]);
  }
  for (const auto& l : c.goal) {
    if ((state.count(positive(l).toString()) > 0) == l.negated) {
      return "after the last step the goal literal " + quoted(l.toString()) + " does not hold";
    }
  }
  return "";
}

PlanResult replan(const PlanningProblem& problem, const std::set<std::string>& current_state,
                  const PlanStep& failed_step, const PlanSearch* search) {
  PlanningProblem again = problem;
  again.initial_state = current_state;
  again.excluded_steps.insert(failed_step.toString());
  PlanResult result = search ? plan(again, *search) : plan(again);
  if (!result.found) {
    result.reason = "no plan avoids the failed step " + quoted(failed_step.toString()) + ": " + result.reason;
  }
  return result;
}

}  // namespace xpersif::core
