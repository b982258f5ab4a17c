#include "xpersif/core/common/contract.h"

#include <algorithm>
#include <cctype>

namespace xpersif::core {

namespace {

std::string trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t");
  return s.substr(begin, end - begin + 1);
}

// '+' so that signed values and push sides ("+x") can be arguments.
bool isNameChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '?' || c == '-' || c == '+' || c == '.' ||
         c == '/';
}

/// A name, or a tuple "(a, b, ...)" of names (normalized to single spaces after its commas).
std::string parseArgument(const std::string& text, const std::string& arg) {
  const auto invalid = [&] { return ContractError("literal '" + text + "' has an empty or invalid argument"); };
  if (arg.empty()) throw invalid();
  if (arg.front() != '(') {
    if (!std::all_of(arg.begin(), arg.end(), isNameChar)) throw invalid();
    return arg;
  }
  if (arg.back() != ')') throw invalid();
  std::string tuple = "(";
  const std::string items = arg.substr(1, arg.size() - 2);
  std::size_t start = 0;
  while (true) {
    const auto comma = items.find(',', start);
    const std::string item = trim(items.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (item.empty() || !std::all_of(item.begin(), item.end(), isNameChar)) throw invalid();
    tuple += (start ? ", " : "") + item;
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return tuple + ")";
}

}  // namespace

std::string Literal::toString() const {
  std::string out = negated ? "not " : "";
  out += predicate + "(";
  for (std::size_t i = 0; i < arguments.size(); ++i) out += (i ? ", " : "") + arguments[i];
  return out + ")";
}

Literal parseLiteral(const std::string& text) {
  Literal literal;
  std::string body = trim(text);
  if (body.rfind("not ", 0) == 0) {
    literal.negated = true;
    body = trim(body.substr(4));
  }
  const auto open = body.find('(');
  if (open == std::string::npos || body.back() != ')') {
    throw ContractError("literal '" + text + "' is malformed; write predicate(arg, ...)");
  }
  literal.predicate = trim(body.substr(0, open));
  if (literal.predicate.empty() || !std::all_of(literal.predicate.begin(), literal.predicate.end(), isNameChar)) {
    throw ContractError("literal '" + text + "' has no valid predicate name");
  }
  const std::string args = body.substr(open + 1, body.size() - open - 2);
  if (!trim(args).empty()) {
    // Split at the commas outside parentheses: an argument may be a tuple such as a pose "(0.1, 0.2, 0)".
    std::vector<std::string> parts(1);
    int depth = 0;
    for (char c : args) {
      if (c == '(' && ++depth > 1) throw ContractError("literal '" + text + "' nests a tuple in a tuple");
      if (c == ')' && --depth < 0) throw ContractError("literal '" + text + "' has an unbalanced ')'");
      if (c == ',' && depth == 0) {
        parts.emplace_back();
      } else {
        parts.back() += c;
      }
    }
    if (depth != 0) throw ContractError("literal '" + text + "' has an unclosed '('");
    for (const auto& part : parts) {
      literal.arguments.push_back(parseArgument(text, trim(part)));
    }
  }
  return literal;
}

std::string ground(const std::string& literal, const Bindings& bindings) {
  Literal parsed = parseLiteral(literal);
  for (auto& arg : parsed.arguments) {
    const auto it = bindings.find(arg);
    if (it != bindings.end()) arg = it->second;
  }
  return parsed.toString();
}

std::vector<std::string> ground(const std::vector<std::string>& literals, const Bindings& bindings) {
  std::vector<std::string> out;
  out.reserve(literals.size());
  for (const auto& l : literals) out.push_back(ground(l, bindings));
  return out;
}

const char* toString(Contract::Kind kind) { return kind == Contract::Kind::Command ? "command" : "operation"; }

void Contract::validate() const {
  if (name.empty()) throw ContractError("a contract needs a name");
  for (const auto& p : parameters) {
    if (p.size() < 2 || p[0] != '?') {
      throw ContractError("contract '" + name + "': parameter '" + p + "' must start with '?'");
    }
  }
  auto checkLiteral = [&](const std::string& text) {
    const Literal literal = parseLiteral(text);
    for (const auto& arg : literal.arguments) {
      if (arg[0] == '?' && std::find(parameters.begin(), parameters.end(), arg) == parameters.end()) {
        throw ContractError("contract '" + name + "': literal '" + text + "' uses undeclared parameter '" + arg + "'");
      }
    }
  };
  for (const auto& c : preconditions) {
    if (c.description.empty()) {
      throw ContractError("contract '" + name + "': precondition '" + c.literal + "' needs a description");
    }
    checkLiteral(c.literal);
  }
  for (const auto& e : effects) checkLiteral(e);
}

}  // namespace xpersif::core
