/**
 * @file parameters.h
 * @brief Every component parameter declared once: name, type, default, range and meaning (ROS-free).
 *
 * A component keeps one ParameterTable. Its ROS face reads values through it (component/parameters.h), so the
 * default, the range check and the sentence for a bad value come from the declaration; doc/parameters.md's parameter
 * reference is generated from the same tables (`xpersif_parameters`), and a component warns about parameters
 * set under its namespace that it does not declare (a typo in a launch file is otherwise silently ignored).
 */
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <variant>
#include <vector>

namespace xpersif::core {

struct ParameterSpec {
  enum class Type { Bool, Int, Double, String, StringList, DoubleList, Dictionary, Structure };
  /// The default, typed; std::monostate when it is derived at configure time (the scene, another parameter)
  /// or when there is none (the parameter is required, or absent means "not used").
  using Value = std::variant<std::monostate, bool, int, double, std::string, std::vector<std::string>, std::vector<double>>;

  std::string name;  ///< under the component's private namespace, without '~'
  Type type = Type::Double;
  Value default_value;
  /// Shown in the reference instead of the typed default when not empty (e.g. "A / 40, from the scene").
  std::string default_text;
  /// Numbers (and a number list's entries): the closed range. Strings and lists: at most `max` entries/characters.
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  std::vector<std::string> choices;  ///< a string's allowed values, when it is an enumeration
  std::string meaning;               ///< one or two sentences, with the unit
  bool set_by_component = false;     ///< an output the component writes (listed, never read)

  /// What the reference shows as the default.
  std::string describeDefault() const;
  /// "bool", "int", "double", "string", "string list", "number list", "dictionary", "structure" (YAML the
  /// component parses itself).
  std::string typeName() const;
  /// "0 .. 1", "one of a | b", "at most 64 entries", or "".
  std::string describeRange() const;
};

// Builders, so that a table reads as a list of declarations.
ParameterSpec flagParameter(std::string name, bool default_value, std::string meaning);
ParameterSpec intParameter(std::string name, int default_value, int min, int max, std::string meaning);
ParameterSpec numberParameter(std::string name, double default_value, double min, double max, std::string meaning);
/// A string; @p choices, when given, are the values it may take.
ParameterSpec textParameter(std::string name, std::string default_value, std::string meaning,
                            std::vector<std::string> choices = {});
ParameterSpec namesParameter(std::string name, std::vector<std::string> default_value, std::size_t max_entries,
                             std::string meaning);
ParameterSpec numbersParameter(std::string name, std::vector<double> default_value, double min, double max,
                               std::string meaning);
/// A parameter whose default is worked out at configure time; @p rule says how (shown in the reference).
ParameterSpec derivedParameter(ParameterSpec::Type type, std::string name, std::string rule, double min, double max,
                               std::string meaning);
/// A parameter the component writes for others to read.
ParameterSpec outputParameter(ParameterSpec::Type type, std::string name, std::string meaning);

/// One component's declared parameters, in the order the reference lists them.
class ParameterTable {
 public:
  ParameterTable() = default;
  /// @throws std::logic_error on a duplicate or empty name (a programming error).
  ParameterTable(std::string owner, std::vector<ParameterSpec> specs);

  /// Adds the parameters of a shared part (e.g. the experiment follower), their names prefixed with @p prefix
  /// (an aggregate's part: "feature_extraction/"); @throws std::logic_error on a clash.
  ParameterTable& include(const ParameterTable& part, const std::string& prefix = "");

  const std::string& owner() const { return owner_; }
  const std::vector<ParameterSpec>& specs() const { return specs_; }
  const ParameterSpec* find(const std::string& name) const;
  /// @throws std::logic_error for a name the table does not declare: reading one is a programming error.
  const ParameterSpec& at(const std::string& name) const;

  /// The names of @p set (first-level names under the namespace) that are not declared, a part's namespace
  /// counting as declared when the table declares a parameter under it, each with the closest declared name when one is near
  /// ("~tempreature (did you mean ~temperature?)"); empty when all are declared.
  std::vector<std::string> undeclared(const std::vector<std::string>& set) const;

  /// A Markdown table: parameter, type, default, range, meaning.
  std::string markdown() const;

 private:
  std::string owner_;
  std::vector<ParameterSpec> specs_;
};

/**
 * @brief The sentence for a value that breaks its declaration, or "" when it is fine.
 *        Numbers must be finite and in range; strings within their choices and length; lists within their count.
 */
std::string checkParameter(const ParameterSpec& spec, const ParameterSpec::Value& value);
/// The same, naming the value @p field (e.g. "~surprise/yaw_length").
std::string checkParameter(const ParameterSpec& spec, const ParameterSpec::Value& value, const std::string& field);

/// Edit distance (Levenshtein) between two names, for "did you mean".
std::size_t editDistance(const std::string& a, const std::string& b);

}  // namespace xpersif::core
