#include "xpersif/core/contract.h"

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
    std::size_t start = 0;
    while (true) {
      const auto comma = args.find(',', start);
      const std::string arg = trim(args.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
      if (arg.empty() || !std::all_of(arg.begin(), arg.end(), isNameChar)) {
        throw ContractError("literal '" + text + "' has an empty or invalid argument");
      }
      literal.arguments.push_back(arg);
      if (comma == std::string::npos) break;
      start = comma + 1;
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
