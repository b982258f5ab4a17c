/**
 * @file planner.h
 * @brief The PLANNER's algorithm: a STRIPS planner whose operators are the components' own contracts,
 *        so that a goal or an experiment becomes a sequence of commands that the components accept.
 *
 * Each Contract is an operator schema: its parameters are variables, its preconditions must hold before
 * it runs, its effects are added (and its "not ..." effects deleted) after it ran. The planner grounds the
 * schemas, keeps only the instances that can matter for the goal, and searches breadth-first over states,
 * so a plan it returns is a shortest one (or, on request, greedily on the number of unmet goal literals,
 * for goals made of many independent parts).
 *
 * Rules (they decide what the planner can and cannot promise):
 *  - Fluent and static predicates. A predicate (by name) is FLUENT when an operator's effect, an
 *    initial-state literal or a goal literal uses it; the planner tracks it under the closed-world
 *    assumption (absent means false). Every other predicate is STATIC: the planner cannot evaluate it
 *    (e.g. "finite(?offset)", "reachable(?object)" when no component asserts reachability), assumes it true,
 *    and lists the grounded literal in PlanStep::assumed; the component checks it when the goal arrives.
 *    To make the planner reason about such a predicate, put its true instances into the initial state.
 *    The flip side: if the only component that produces a predicate is left out of `operators`, the
 *    predicate becomes static and is assumed; its consumer then rejects the goal at execution time.
 *  - Grounding. A parameter listed in parameter_domains takes exactly the values listed there. Any other
 *    parameter takes the values found by unifying the operator's fluent literals (preconditions and effects)
 *    with known ground literals: the initial state, the goal, and, transitively, the literals of operator
 *    instances already grounded (so the goal "recorded(red_cube, +x)" binds ?object/?side of "record", whose
 *    precondition "pushed(red_cube, +x)" then binds those of "push"). A parameter with no domain that occurs
 *    in no fluent literal stays OPEN: the step keeps "?name" in its toString() and has no binding for it; the
 *    caller supplies its value when it executes the step (e.g. the push's offset from the chosen experiment).
 *  - Excluded steps are compared with PlanStep::toString(); an entry without '(' excludes every instance of
 *    the operator of that name.
 *  - Effects are applied as in STRIPS/PDDL: deletes first, then adds.
 */
#pragma once

#include "xpersif/core/common/contract.h"
#include "xpersif/core/planning/plan_search.h"

#include <cstddef>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace xpersif::core {

/// The two built-in searches by name, for plan(problem); any PlanSearch (plan_search.h) goes to plan(problem, search).
enum class SearchStrategy {
  BreadthFirst,     ///< shortest plans; explores every state up to the plan's length (exponential in it)
  GreedyGoalCount,  ///< best-first on the number of unmet goal literals: fast on independent subgoals,
                    ///< plans not always shortest
};

struct PlanningProblem {
  std::vector<Contract> operators;        ///< the contracts of the commands (and operations) that may be used
  std::set<std::string> initial_state;    ///< positive ground literals, e.g. "observed(before)"
  std::vector<std::string> goal;          ///< ground literals that must hold at the end; "not p(..)" allowed
  /// Candidate values per parameter name, e.g. "?object" -> {"red_cube", "green_cube"}.
  std::map<std::string, std::vector<std::string>> parameter_domains;
  std::set<std::string> excluded_steps;   ///< step strings (PlanStep::toString()) or operator names not to use
  std::size_t max_depth = 16;             ///< longest plan considered (steps)
  std::size_t max_expansions = 200000;    ///< states expanded before the search gives up
  std::size_t max_groundings = 20000;     ///< operator instances before grounding gives up
  SearchStrategy search = SearchStrategy::BreadthFirst;
};

struct PlanStep {
  std::string operator_name;
  Bindings bindings;                    ///< bound parameters; open ones are absent
  std::vector<std::string> parameters;  ///< the operator's parameters, in declaration order
  std::vector<std::string> assumed;     ///< grounded static preconditions the component will check

  /// "push(red_cube, +x, ?offset)": the operator and its parameter values in declaration order.
  std::string toString() const;
  /// Parameters without a binding (the caller provides them at execution time).
  std::vector<std::string> openParameters() const;
};

struct PlanResult {
  bool found = false;
  std::vector<PlanStep> steps;
  std::string reason;         ///< when !found: one sentence naming the unreachable goal literal or the limit hit
  std::size_t expanded = 0;   ///< states expanded by the search
  std::size_t groundings = 0; ///< operator instances considered after relevance pruning
};

/**
 * Plan from problem.initial_state to problem.goal.
 * Throws ContractError when an operator is malformed (or two share a name), ValidationError when the
 * state, goal or domains are (non-ground literals, negated initial literals, empty domains).
 */
PlanResult plan(const PlanningProblem& problem);
/// The same with @p search instead of problem.search: the search algorithm chosen by name (a PlanSearch plugin).
PlanResult plan(const PlanningProblem& problem, const PlanSearch& search);

/**
 * Simulate @p steps from problem.initial_state. Returns "" when every step's fluent preconditions hold when
 * it runs and the goal holds at the end; otherwise one sentence naming the first step (1-based) whose
 * precondition fails, or the goal literal that does not hold.
 */
std::string validatePlan(const PlanningProblem& problem, const std::vector<PlanStep>& steps);

/// Apply @p step's effects to @p state (deletes, then adds); throws ContractError for an unknown operator.
std::set<std::string> applyStep(const PlanningProblem& problem, const std::set<std::string>& state,
                                const PlanStep& step);

/**
 * Plan again after @p failed_step failed: from @p current_state (what holds now), with the failed step
 * excluded, so the new plan avoids it or takes an alternative. The reason, when no plan is found, says that
 * the failed step was excluded. @p search, when given, replaces problem.search.
 */
PlanResult replan(const PlanningProblem& problem, const std::set<std::string>& current_state,
                  const PlanStep& failed_step, const PlanSearch* search = nullptr);

}  // namespace xpersif::core
