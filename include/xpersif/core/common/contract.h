/**
 * @file contract.h
 * @brief Contracts of commands and operations: preconditions and effects, as the paper asks, written
 *        as STRIPS-style literals so that the PLANNER can chain them.
 *
 * A literal is `predicate(arg, ...)` or `not predicate(arg, ...)`; arguments starting with '?' are the
 * contract's parameters, bound from a goal or request when the command is called. Each precondition
 * also carries a check that the component evaluates on the goal (a goal whose check fails is rejected
 * with a sentence that names the precondition); effects are grounded and recorded on success.
 */
#pragma once

#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace xpersif::core {

/// A parsed literal: `not at(robot, ?pose)` -> {negated, "at", {"robot", "?pose"}}.
struct Literal {
  bool negated = false;
  std::string predicate;
  std::vector<std::string> arguments;

  std::string toString() const;
  bool operator==(const Literal& other) const {
    return negated == other.negated && predicate == other.predicate && arguments == other.arguments;
  }
};

/// Thrown when a contract is declared wrongly (a programming error in a component).
class ContractError : public std::logic_error {
 public:
  explicit ContractError(const std::string& what) : std::logic_error(what) {}
};

/// Parse a literal; throws ContractError with the reason when it is malformed.
Literal parseLiteral(const std::string& text);

/// Parameter name -> value, e.g. {"?object": "red_cube"}.
using Bindings = std::map<std::string, std::string>;

/// Replace every bound parameter in @p literal by its value; unbound parameters stay as they are.
std::string ground(const std::string& literal, const Bindings& bindings);
std::vector<std::string> ground(const std::vector<std::string>& literals, const Bindings& bindings);

/// One precondition: its literal and a sentence for people.
struct Condition {
  std::string literal;      ///< e.g. "above(?target, total)"
  std::string description;  ///< e.g. "the target must exceed the current total"
};

/// The declared contract of one command or operation, readable by any component (and the PLANNER).
struct Contract {
  enum class Kind { Command, Operation };

  std::string name;            ///< the command's action name or the operation's service name, e.g. "count_to"
  Kind kind = Kind::Operation;
  std::string interface_type;  ///< ROS type, e.g. "xpersif/CountToAction"
  std::string description;
  std::vector<std::string> parameters;  ///< e.g. {"?target"}
  std::vector<Condition> preconditions;
  std::vector<std::string> effects;     ///< literals that hold after success; "not ..." ones stop holding

  /// Throw ContractError unless every literal parses and uses only declared parameters.
  void validate() const;
};

const char* toString(Contract::Kind kind);

/**
 * @brief The checkable side of a contract for one input type (a goal or a request).
 *
 * Each check returns "" when its precondition holds, or a sentence saying what is wrong. The checker
 * evaluates them in declaration order and reports the first that fails, naming it.
 */
template <class Input>
class ContractChecker {
 public:
  using Check = std::function<std::string(const Input&)>;
  using Binder = std::function<Bindings(const Input&)>;

  explicit ContractChecker(Contract contract) : contract_(std::move(contract)) { contract_.validate(); }

  /// Attach the check of the precondition whose literal is @p literal (it must be declared).
  ContractChecker& check(const std::string& literal, Check check) {
    for (const auto& condition : contract_.preconditions) {
      if (condition.literal == literal) {
        checks_.emplace_back(condition, std::move(check));
        return *this;
      }
    }
    throw ContractError("contract '" + contract_.name + "' declares no precondition '" + literal + "'");
  }

  /// How parameters are bound from an input (used to ground effects and rejection sentences).
  ContractChecker& bind(Binder binder) {
    binder_ = std::move(binder);
    return *this;
  }

  /// "" if every checked precondition holds, else "precondition 'lit' (description) is not met: why".
  std::string firstUnmet(const Input& input) const {
    for (const auto& entry : checks_) {
      std::string why = entry.second(input);
      if (!why.empty()) {
        return "precondition '" + ground(entry.first.literal, bindings(input)) + "' (" + entry.first.description +
               ") is not met: " + why;
      }
    }
    return "";
  }

  Bindings bindings(const Input& input) const { return binder_ ? binder_(input) : Bindings{}; }
  std::vector<std::string> groundEffects(const Input& input) const { return ground(contract_.effects, bindings(input)); }
  /// The same, with @p extra bindings beside the input's (what only the outcome knows); @p extra wins.
  std::vector<std::string> groundEffects(const Input& input, const Bindings& extra) const {
    Bindings all = bindings(input);
    for (const auto& [name, value] : extra) all[name] = value;
    return ground(contract_.effects, all);
  }
  const Contract& contract() const { return contract_; }

 private:
  Contract contract_;
  std::vector<std::pair<Condition, Check>> checks_;
  Binder binder_;
};

}  // namespace xpersif::core
