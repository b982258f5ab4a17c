#include "xpersif/core/common/parameters.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

std::string joined(const std::vector<std::string>& items, const std::string& separator) {
  std::string text;
  for (const auto& item : items) text += (text.empty() ? "" : separator) + item;
  return text;
}

std::string numberText(double value) {
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  // Whole numbers in full (2147483647, not 2.14748e+09).
  if (std::fabs(value) < 1e15 && value == std::floor(value)) return std::to_string(static_cast<long long>(value));
  return describeNumber(value);
}

/// A Markdown table cell: pipes escaped, no line breaks.
std::string cell(std::string text) {
  std::string out;
  for (char c : text) {
    if (c == '|') out += "\\|";
    else if (c == '\n') out += ' ';
    else out += c;
  }
  return out;
}

bool isNumber(ParameterSpec::Type type) {
  return type == ParameterSpec::Type::Int || type == ParameterSpec::Type::Double;
}

}  // namespace

std::string ParameterSpec::typeName() const {
  switch (type) {
    case Type::Bool: return "bool";
    case Type::Int: return "int";
    case Type::Double: return "double";
    case Type::String: return "string";
    case Type::StringList: return "string list";
    case Type::DoubleList: return "number list";
    case Type::Dictionary: return "dictionary";
    case Type::Structure: return "structure";
  }
  return "?";
}

std::string ParameterSpec::describeDefault() const {
  if (!default_text.empty()) return default_text;
  struct Visitor {
    std::string operator()(std::monostate) const { return "(none)"; }
    std::string operator()(bool b) const { return b ? "true" : "false"; }
    std::string operator()(int i) const { return std::to_string(i); }
    std::string operator()(double d) const { return numberText(d); }
    std::string operator()(const std::string& s) const { return s.empty() ? "\"\"" : s; }
    std::string operator()(const std::vector<std::string>& v) const { return "[" + joined(v, ", ") + "]"; }
    std::string operator()(const std::vector<double>& v) const {
      std::vector<std::string> texts;
      for (double d : v) texts.push_back(numberText(d));
      return "[" + joined(texts, ", ") + "]";
    }
  };
  return std::visit(Visitor{}, default_value);
}

std::string ParameterSpec::describeRange() const {
  if (set_by_component) return "set by the component";
  if (!choices.empty()) return "one of " + joined(choices, ", ");
  const bool has_min = std::isfinite(min), has_max = std::isfinite(max);
  if (isNumber(type) || type == Type::DoubleList) {
    if (has_min && has_max) return numberText(min) + " .. " + numberText(max);
    if (has_min) return "≥ " + numberText(min);
    if (has_max) return "≤ " + numberText(max);
    return "";
  }
  if (has_max && (type == Type::StringList || type == Type::Dictionary)) return "at most " + numberText(max) + " entries";
  if (has_max && type == Type::String) return "at most " + numberText(max) + " characters";
  return "";
}

namespace {
/// The fields every builder sets.
ParameterSpec declared(std::string name, ParameterSpec::Type type, ParameterSpec::Value default_value,
                       std::string meaning) {
  ParameterSpec spec;
  spec.name = std::move(name);
  spec.type = type;
  spec.default_value = std::move(default_value);
  spec.meaning = std::move(meaning);
  return spec;
}
}  // namespace

ParameterSpec flagParameter(std::string name, bool default_value, std::string meaning) {
  return declared(std::move(name), ParameterSpec::Type::Bool, default_value, std::move(meaning));
}

ParameterSpec intParameter(std::string name, int default_value, int min, int max, std::string meaning) {
  ParameterSpec spec = declared(std::move(name), ParameterSpec::Type::Int, default_value, std::move(meaning));
  spec.min = min;
  spec.max = max;
  return spec;
}

ParameterSpec numberParameter(std::string name, double default_value, double min, double max, std::string meaning) {
  ParameterSpec spec = declared(std::move(name), ParameterSpec::Type::Double, default_value, std::move(meaning));
  spec.min = min;
  spec.max = max;
  return spec;
}

ParameterSpec textParameter(std::string name, std::string default_value, std::string meaning,
                            std::vector<std::string> choices) {
  ParameterSpec spec =
      declared(std::move(name), ParameterSpec::Type::String, std::move(default_value), std::move(meaning));
  spec.choices = std::move(choices);
  return spec;
}

ParameterSpec namesParameter(std::string name, std::vector<std::string> default_value, std::size_t max_entries,
                             std::string meaning) {
  ParameterSpec spec =
      declared(std::move(name), ParameterSpec::Type::StringList, std::move(default_value), std::move(meaning));
  spec.max = static_cast<double>(max_entries);
  return spec;
}

ParameterSpec numbersParameter(std::string name, std::vector<double> default_value, double min, double max,
                               std::string meaning) {
  ParameterSpec spec =
      declared(std::move(name), ParameterSpec::Type::DoubleList, std::move(default_value), std::move(meaning));
  spec.min = min;
  spec.max = max;
  return spec;
}

ParameterSpec derivedParameter(ParameterSpec::Type type, std::string name, std::string rule, double min, double max,
                               std::string meaning) {
  ParameterSpec spec = declared(std::move(name), type, {}, std::move(meaning));
  spec.default_text = std::move(rule);
  spec.min = min;
  spec.max = max;
  return spec;
}

ParameterSpec outputParameter(ParameterSpec::Type type, std::string name, std::string meaning) {
  ParameterSpec spec = declared(std::move(name), type, {}, std::move(meaning));
  spec.default_text = "—";
  spec.set_by_component = true;
  return spec;
}

ParameterTable::ParameterTable(std::string owner, std::vector<ParameterSpec> specs) : owner_(std::move(owner)) {
  for (auto& spec : specs) {
    ParameterTable part;
    part.owner_ = owner_;
    part.specs_ = {std::move(spec)};
    include(part);
  }
}

ParameterTable& ParameterTable::include(const ParameterTable& part, const std::string& prefix) {
  for (ParameterSpec spec : part.specs_) {
    if (spec.name.empty()) throw std::logic_error(owner_ + " declares a parameter without a name");
    spec.name = prefix + spec.name;
    if (find(spec.name)) throw std::logic_error(owner_ + " declares ~" + spec.name + " twice");
    specs_.push_back(std::move(spec));
  }
  return *this;
}

const ParameterSpec* ParameterTable::find(const std::string& name) const {
  for (const auto& spec : specs_) {
    if (spec.name == name) return &spec;
  }
  return nullptr;
}

const ParameterSpec& ParameterTable::at(const std::string& name) const {
  const ParameterSpec* spec = find(name);
  if (!spec) throw std::logic_error(owner_ + " reads ~" + name + ", which it does not declare");
  return *spec;
}

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::vector<std::string> ParameterTable::undeclared(const std::vector<std::string>& set) const {
  std::vector<std::string> out;
  for (const auto& name : set) {
    if (find(name)) continue;
    const bool part = std::any_of(specs_.begin(), specs_.end(),
                                  [&](const ParameterSpec& s) { return s.name.compare(0, name.size() + 1, name + "/") == 0; });
    if (part) continue;
    std::string text = "~" + name;
    const ParameterSpec* closest = nullptr;
    std::size_t best = 0;
    for (const auto& spec : specs_) {
      const std::size_t d = editDistance(name, spec.name);
      if (!closest || d < best) closest = &spec, best = d;
    }
    // A near name is a likely typo: at most a third of the name's letters differ.
    if (closest && best * 3 <= std::max<std::size_t>(name.size(), 3)) text += " (did you mean ~" + closest->name + "?)";
    out.push_back(text);
  }
  return out;
}

std::string ParameterTable::markdown() const {
  std::string text = "| parameter | type | default | range | meaning |\n| --- | --- | --- | --- | --- |\n";
  for (const auto& spec : specs_) {
    text += "| `~" + spec.name + "` | " + spec.typeName() + " | " + cell(spec.describeDefault()) + " | " +
            cell(spec.describeRange()) + " | " + cell(spec.meaning) + " |\n";
  }
  return text;
}

std::string checkParameter(const ParameterSpec& spec, const ParameterSpec::Value& value) {
  return checkParameter(spec, value, "~" + spec.name);
}

std::string checkParameter(const ParameterSpec& spec, const ParameterSpec::Value& value, const std::string& field) {
  if (const auto* i = std::get_if<int>(&value)) return checkInRange(field, *i, spec.min, spec.max);
  if (const auto* d = std::get_if<double>(&value)) return checkInRange(field, *d, spec.min, spec.max);
  if (const auto* s = std::get_if<std::string>(&value)) {
    if (!spec.choices.empty()) return checkOneOf(field, *s, spec.choices);
    if (std::isfinite(spec.max)) return checkMaxLength(field, *s, static_cast<std::size_t>(spec.max));
    return "";
  }
  if (const auto* names = std::get_if<std::vector<std::string>>(&value)) {
    if (std::isfinite(spec.max)) return checkMaxSize(field, names->size(), static_cast<std::size_t>(spec.max));
    return "";
  }
  if (const auto* numbers = std::get_if<std::vector<double>>(&value)) {
    for (std::size_t i = 0; i < numbers->size(); ++i) {
      const std::string why = checkInRange(field + "[" + std::to_string(i) + "]", (*numbers)[i], spec.min, spec.max);
      if (!why.empty()) return why;
    }
  }
  return "";
}

}  // namespace xpersif::core
