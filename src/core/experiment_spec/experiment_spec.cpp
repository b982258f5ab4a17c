#include "xpersif/core/experiment_spec/experiment_spec.h"
#include "xpersif/core/planning/experiment_design.h"
#include "xpersif/core/common/package_path.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <optional>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>

namespace xpersif {
namespace core {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string> kTopKeys = {"name",  "world",     "robot",  "seed",      "clock",
                                           "run_dir", "recording", "phases", "parameters"};
const std::vector<std::string> kRecordingKeys = {"mode", "compression"};
const std::vector<std::string> kKinds = {"evaluation", "experimentation", "goal_directed"};
const std::map<std::string, std::vector<std::string>> kPhaseKeys = {
    {"evaluation", {"kind", "name", "experiments", "seed_offset"}},
    {"experimentation", {"kind", "name", "design", "experiments", "goals", "seed_offset"}},
    {"goal_directed", {"kind", "name", "goals", "seed_offset"}},
};
const std::vector<std::string> kDesigns = designNames();  // experiment_design.h: this package's designs
const std::vector<std::string> kClocks = {"lockstep", "realtime", "fast"};
const std::vector<std::string> kRecordingModes = {"off", "bags", "bags_with_images"};
const std::vector<std::string> kCompressions = {"lz4", "bz2", "none"};
// The same bounds as LOOPMODEL's RunLoop checks, so a file that passes here is not refused later.
constexpr std::int64_t kMaxExperiments = 100000;
constexpr std::int64_t kMaxGoals = 10000;
constexpr std::int64_t kMaxSeed = std::numeric_limits<std::int32_t>::max();

std::string joined(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : ", ") + w;
  return out;
}

std::string at(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  if (mark.line < 0) return "";
  return " (line " + std::to_string(mark.line + 1) + ")";
}

/// Reads one file: every sentence starts with the file's name.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what, const YAML::Node& node) const {
    throw ExperimentFileError(file_ + ": " + key + " " + what + at(node));
  }

  void requireMap(const YAML::Node& node, const std::string& key) const {
    if (!node.IsMap()) fail(key, "must be a mapping of keys to values", node);
  }

  void requireKnownKeys(const YAML::Node& map, const std::string& prefix,
                        const std::vector<std::string>& known) const {
    for (const auto& entry : map) {
      const std::string key = entry.first.Scalar();
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        throw ExperimentFileError(file_ + ": unknown key '" + prefix + key + "'" + at(entry.first) +
                                  "; the keys there are " + joined(known));
      }
    }
  }

  std::string text(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar() || node.Scalar().empty()) fail(key, "must be a non-empty text", node);
    return node.Scalar();
  }

  std::string oneOf(const YAML::Node& node, const std::string& key, const std::vector<std::string>& allowed) const {
    const std::string value = text(node, key);
    if (std::find(allowed.begin(), allowed.end(), value) == allowed.end()) {
      fail(key, "is '" + value + "'; it must be one of " + joined(allowed), node);
    }
    return value;
  }

  std::int64_t integer(const YAML::Node& node, const std::string& key, std::int64_t lo, std::int64_t hi) const {
    const std::string range = "it must be an integer in " + std::to_string(lo) + ".." + std::to_string(hi);
    if (!node.IsScalar()) fail(key, "is not a single value; " + range, node);
    std::int64_t value = 0;
    try {
      std::size_t used = 0;
      value = std::stoll(node.Scalar(), &used);
      if (used != node.Scalar().size()) throw std::invalid_argument(node.Scalar());
    } catch (const std::exception&) {
      fail(key, "is '" + node.Scalar() + "'; " + range, node);
    }
    if (value < lo || value > hi) fail(key, "is " + std::to_string(value) + "; " + range, node);
    return value;
  }

  std::string identifier(const YAML::Node& node, const std::string& key) const {
    const std::string value = text(node, key);
    const bool ok = std::all_of(value.begin(), value.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
    });
    if (!ok || value.size() > 64) {
      fail(key, "is '" + value + "'; it must be 1 to 64 letters, digits, '_' or '-'", node);
    }
    return value;
  }

  /// A path relative to the experiment file's directory, made absolute.
  std::string path(const YAML::Node& node, const std::string& key) const {
    const fs::path given(text(node, key));
    if (given.is_absolute()) return given.lexically_normal().string();
    const fs::path base = fs::absolute(fs::path(file_)).parent_path();
    return (base / given).lexically_normal().string();
  }

  std::string existingFile(const YAML::Node& node, const std::string& key) const {
    const std::string resolved = path(node, key);
    std::error_code error;
    if (!fs::is_regular_file(resolved, error)) {
      const bool relative = !fs::path(text(node, key)).is_absolute();
      fail(key,
           "names " + resolved + ", which does not exist or is not a file" +
               (relative ? std::string(" (a relative path is taken from the experiment file's directory)") : ""),
           node);
    }
    return resolved;
  }

 private:
  std::string file_;
};

void applyOverride(YAML::Node root, const Override& o, const std::string& file) {
  std::vector<std::string> parts;
  std::stringstream in(o.key);
  for (std::string part; std::getline(in, part, '.');) parts.push_back(part);
  const std::string where = file + ": override " + o.key + "=" + o.value + ": ";
  YAML::Node node(root);
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    const std::string& part = parts[i];
    if (node.IsSequence()) {
      std::size_t index = 0;
      try {
        std::size_t used = 0;
        index = std::stoul(part, &used);
        if (used != part.size()) throw std::invalid_argument(part);
      } catch (const std::exception&) {
        throw ExperimentFileError(where + "'" + part + "' must be an index into a list");
      }
      if (index >= node.size()) {
        throw ExperimentFileError(where + "the list has " + std::to_string(node.size()) + " entries (from 0)");
      }
      node.reset(node[index]);
    } else {
      if (node[part].IsNull() || !node[part].IsDefined()) node[part] = YAML::Node(YAML::NodeType::Map);
      YAML::Node next = node[part];
      node.reset(next);
    }
  }
  YAML::Node value;
  try {
    value = YAML::Load(o.value);
  } catch (const YAML::Exception& e) {
    throw ExperimentFileError(where + "the value is not YAML: " + e.msg);
  }
  if (node.IsSequence()) {
    throw ExperimentFileError(where + "replace a list's entry through its key, e.g. phases.0.experiments");
  }
  node[parts.back()] = value;
}

YAML::Node phaseNode(const PhaseSpec& p) {
  YAML::Node n;
  n["kind"] = p.kind;
  n["name"] = p.name;
  if (p.kind == "experimentation") n["design"] = p.design;
  if (p.kind != "goal_directed") n["experiments"] = p.experiments;
  if (p.kind != "evaluation") n["goals"] = p.goals;
  n["seed_offset"] = p.seed_offset;
  return n;
}

/// A YAML node as JSON: scalars that read as numbers or booleans stay so, everything else is a string.
void toJson(const YAML::Node& node, std::ostream& out) {
  if (node.IsMap()) {
    out << "{";
    bool first = true;
    for (const auto& entry : node) {
      out << (first ? "" : ",") << jsonString(entry.first.Scalar()) << ":";
      toJson(entry.second, out);
      first = false;
    }
    out << "}";
  } else if (node.IsSequence()) {
    out << "[";
    for (std::size_t i = 0; i < node.size(); ++i) {
      out << (i ? "," : "");
      toJson(node[i], out);
    }
    out << "]";
  } else if (node.IsScalar()) {
    const std::string& s = node.Scalar();
    if (s == "true" || s == "false") {
      out << s;
      return;
    }
    char* end = nullptr;
    const double number = std::strtod(s.c_str(), &end);
    const bool numeric = !s.empty() && end == s.c_str() + s.size() && std::isfinite(number) &&
                         s.find_first_of("xXnN") == std::string::npos;
    if (numeric && node.Tag() != "!") {
      out << s;
    } else {
      out << jsonString(s);
    }
  } else {
    out << "null";
  }
}

YAML::Node asRun(const ExperimentSpec& spec, const std::string& run_dir) {
  YAML::Node root;
  root["name"] = spec.name;
  root["world"] = spec.world;
  if (!spec.robot.empty()) root["robot"] = spec.robot;
  root["seed"] = spec.seed;
  root["clock"] = spec.clock;
  root["run_dir"] = run_dir;
  root["recording"]["mode"] = spec.recording.mode;
  root["recording"]["compression"] = spec.recording.compression;
  for (const auto& p : spec.phases) root["phases"].push_back(phaseNode(p));
  root["parameters"] = YAML::Node(YAML::NodeType::Map);
  for (const auto& [component, values] : spec.parameters) root["parameters"][component] = YAML::Load(values);
  return root;
}

}  // namespace

std::vector<std::string> ExperimentSpec::phaseNames(const std::string& kind) const {
  std::vector<std::string> names;
  for (const auto& p : phases) {
    if (p.kind == kind) names.push_back(p.name);
  }
  return names;
}

Override parseOverride(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw ExperimentFileError("the override '" + text + "' must read KEY=VALUE, e.g. seed=3 or phases.1.experiments=8");
  }
  return {text.substr(0, eq), text.substr(eq + 1)};
}

namespace {
/// The YAML value as the declaration's type, or nullopt when it is not of that type.
std::optional<ParameterSpec::Value> valueAs(const ParameterSpec& spec, const YAML::Node& node) {
  try {
    switch (spec.type) {
      case ParameterSpec::Type::Bool: return ParameterSpec::Value(node.as<bool>());
      case ParameterSpec::Type::Int: return ParameterSpec::Value(node.as<int>());
      case ParameterSpec::Type::Double: return ParameterSpec::Value(node.as<double>());
      case ParameterSpec::Type::String:
        if (!node.IsScalar()) return std::nullopt;
        return ParameterSpec::Value(node.as<std::string>());
      case ParameterSpec::Type::StringList: return ParameterSpec::Value(node.as<std::vector<std::string>>());
      case ParameterSpec::Type::DoubleList: return ParameterSpec::Value(node.as<std::vector<double>>());
      case ParameterSpec::Type::Dictionary:
        if (!node.IsMap()) return std::nullopt;
        return ParameterSpec::Value();
      case ParameterSpec::Type::Structure: return ParameterSpec::Value();
    }
  } catch (const YAML::Exception&) {
  }
  return std::nullopt;
}
}  // namespace

namespace {

/// The file as YAML, a mapping, with the overrides applied.
YAML::Node readRoot(const std::string& path, const std::vector<Override>& overrides) {
  std::error_code error;
  if (!fs::is_regular_file(path, error)) {
    throw ExperimentFileError(path + ": no such experiment file");
  }
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw ExperimentFileError(path + ": not valid YAML: " + e.msg +
                              (e.mark.is_null() ? "" : " (line " + std::to_string(e.mark.line + 1) + ")"));
  }
  if (!root.IsMap()) throw ExperimentFileError(path + ": must be a mapping of keys (world, phases, ...) to values");
  for (const auto& o : overrides) {
    try {
      applyOverride(root, o, path);
    } catch (const YAML::Exception& e) {
      throw ExperimentFileError(path + ": override " + o.key + "=" + o.value + ": " + e.msg);
    }
  }
  return root;
}

/// name, world, robot, seed, clock, run_dir and recording.
void readSettings(const Reader& r, const YAML::Node& root, const std::string& path, ExperimentSpec& spec) {
  spec.name = root["name"] ? r.identifier(root["name"], "name") : fs::path(path).stem().string();
  if (!root["world"]) throw ExperimentFileError(path + ": world is missing; name the world file (see worlds/)");
  spec.world = r.existingFile(root["world"], "world");
  if (root["robot"]) spec.robot = r.existingFile(root["robot"], "robot");
  if (root["seed"]) spec.seed = r.integer(root["seed"], "seed", 0, kMaxSeed);
  if (root["clock"]) spec.clock = r.oneOf(root["clock"], "clock", kClocks);
  spec.run_dir = root["run_dir"] ? r.path(root["run_dir"], "run_dir")
                                 : (fs::absolute(fs::path(path)).parent_path() / "../runs/{time}").lexically_normal().string();
  if (const YAML::Node recording = root["recording"]) {
    r.requireMap(recording, "recording");
    r.requireKnownKeys(recording, "recording.", kRecordingKeys);
    if (recording["mode"]) spec.recording.mode = r.oneOf(recording["mode"], "recording.mode", kRecordingModes);
    if (recording["compression"]) {
      spec.recording.compression = r.oneOf(recording["compression"], "recording.compression", kCompressions);
    }
  }
}

/// Entry @p key of phases; @p names holds the names of the phases before it, and gets this one's.
PhaseSpec readPhase(const Reader& r, const YAML::Node& p, const std::string& key, std::int64_t seed,
                    std::set<std::string>& names) {
  r.requireMap(p, key);
  if (!p["kind"]) r.fail(key + ".kind", "is missing; it must be one of " + joined(kKinds), p);
  PhaseSpec phase;
  phase.kind = r.oneOf(p["kind"], key + ".kind", kKinds);
  r.requireKnownKeys(p, key + ".", kPhaseKeys.at(phase.kind));
  if (!p["name"]) r.fail(key + ".name", "is missing; every phase is a run with a name", p);
  phase.name = r.identifier(p["name"], key + ".name");
  if (!names.insert(phase.name).second) r.fail(key + ".name", "'" + phase.name + "' is used twice", p["name"]);
  // The evaluation set gives the objects turns (a uniform random push each), so that every object the report
  // weighs equally is judged on as many pushes, as a study's evaluation set does (scripts/study.py).
  phase.design = phase.kind == "evaluation" ? "round_robin" : "random";
  if (phase.kind == "experimentation") {
    if (!p["design"]) r.fail(key + ".design", "is missing; it must be one of " + joined(kDesigns), p);
    phase.design = r.oneOf(p["design"], key + ".design", kDesigns);
  } else if (phase.kind == "goal_directed") {
    phase.design = "curiosity";  // stored with the run; goals are designed by GOALDESIGN whatever it says
  }
  if (phase.kind != "goal_directed") {
    if (!p["experiments"]) r.fail(key + ".experiments", "is missing", p);
    phase.experiments = static_cast<std::uint32_t>(r.integer(p["experiments"], key + ".experiments", 1, kMaxExperiments));
  }
  if (phase.kind == "goal_directed") {
    if (!p["goals"]) r.fail(key + ".goals", "is missing", p);
    phase.goals = static_cast<std::uint32_t>(r.integer(p["goals"], key + ".goals", 1, kMaxGoals));
  } else if (p["goals"]) {
    phase.goals = static_cast<std::uint32_t>(r.integer(p["goals"], key + ".goals", 0, kMaxGoals));
  }
  if (p["seed_offset"]) phase.seed_offset = r.integer(p["seed_offset"], key + ".seed_offset", 0, kMaxSeed);
  if (seed + phase.seed_offset > kMaxSeed) {
    r.fail(key + ".seed_offset", "makes the run's seed " + std::to_string(seed + phase.seed_offset) +
                                     ", above " + std::to_string(kMaxSeed), p);
  }
  return phase;
}

void readPhases(const Reader& r, const YAML::Node& root, const std::string& path, ExperimentSpec& spec) {
  const YAML::Node phases = root["phases"];
  if (!phases) throw ExperimentFileError(path + ": phases is missing; list at least one phase");
  if (!phases.IsSequence() || phases.size() == 0) r.fail("phases", "must be a non-empty list of phases", phases);
  std::set<std::string> names;
  for (std::size_t i = 0; i < phases.size(); ++i) {
    spec.phases.push_back(readPhase(r, phases[i], "phases[" + std::to_string(i) + "]", spec.seed, names));
  }
}

/// The value @p value of parameters.COMPONENT.NAME (at @p where), checked against @p parameters, the
/// component's declaration, when it has one.
void checkParameterValue(const Reader& r, const std::string& path, const std::string& component,
                         const std::string& where, const std::pair<YAML::Node, YAML::Node>& value,
                         const ParameterTable* parameters) {
  const std::string name = value.first.Scalar();
  r.identifier(value.first, where);
  if (value.second.IsNull()) r.fail(where, "has no value", value.second);
  if (!parameters) return;
  const ParameterSpec* spec = parameters->find(name);
  if (!spec) {
    r.fail(where, "is not a parameter of " + component + ": " + parameters->undeclared({name}).front() +
                      " is not declared (doc/parameters.md)", value.first);
  }
  if (spec->set_by_component) r.fail(where, "is set by " + component + " itself, not read", value.first);
  const auto typed = valueAs(*spec, value.second);
  if (!typed) r.fail(where, "must be of type " + spec->typeName() + " (" + spec->meaning + ")", value.second);
  const std::string why = checkParameter(*spec, *typed, where);
  if (!why.empty()) throw ExperimentFileError(path + ": " + why + at(value.second));
}

/// parameters: per component, its values (checked) as one line of flow YAML.
void readParameters(const Reader& r, const YAML::Node& root, const std::string& path,
                    const std::vector<std::string>& known_components,
                    const std::map<std::string, const ParameterTable*>& declared, ExperimentSpec& spec) {
  const YAML::Node parameters = root["parameters"];
  if (!parameters || parameters.IsNull()) return;
  r.requireMap(parameters, "parameters");
  for (const auto& entry : parameters) {
    const std::string component = entry.first.Scalar();
    const std::string key = "parameters." + component;
    if (!known_components.empty() &&
        std::find(known_components.begin(), known_components.end(), component) == known_components.end()) {
      throw ExperimentFileError(path + ": unknown component '" + component + "' under parameters" + at(entry.first) +
                                "; the components are " + joined(known_components));
    }
    r.identifier(entry.first, key);
    r.requireMap(entry.second, key);
    const auto table = declared.find(component);
    const ParameterTable* declaration = table == declared.end() ? nullptr : table->second;
    for (const auto& value : entry.second) {
      checkParameterValue(r, path, component, key + "." + value.first.Scalar(), value, declaration);
    }
    YAML::Emitter out;
    out << YAML::Flow << entry.second;
    spec.parameters[component] = out.c_str();
  }
}

}  // namespace

ExperimentSpec loadExperimentFile(const std::string& path, const std::vector<Override>& overrides,
                                  const std::vector<std::string>& known_components,
                                  const std::map<std::string, const ParameterTable*>& declared) {
  const YAML::Node root = readRoot(path, overrides);
  const Reader r(path);
  r.requireKnownKeys(root, "", kTopKeys);
  ExperimentSpec spec;
  spec.file = path;
  readSettings(r, root, path, spec);
  readPhases(r, root, path, spec);
  readParameters(r, root, path, known_components, declared, spec);
  return spec;
}

std::string experimentToYaml(const ExperimentSpec& spec, const std::string& run_dir) {
  YAML::Emitter out;
  out << asRun(spec, run_dir);
  return std::string("# The experiment as run (xpersif_experiment): absolute paths, every default written out.\n") +
         out.c_str() + "\n";
}

std::string experimentToJson(const ExperimentSpec& spec, const std::string& run_dir) {
  std::ostringstream out;
  toJson(asRun(spec, run_dir), out);
  return out.str();
}

std::string jsonString(const std::string& text) {
  std::ostringstream out;
  out << '"';
  for (const char c : text) {
    switch (c) {
      case '"': out << "\\\""; break;
      case '\\': out << "\\\\"; break;
      case '\n': out << "\\n"; break;
      case '\t': out << "\\t"; break;
      case '\r': out << "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          out << "\\u" << std::hex << std::setw(4) << std::setfill('0') << static_cast<int>(c) << std::dec;
        } else {
          out << c;
        }
    }
  }
  out << '"';
  return out.str();
}

namespace {
YAML::Node loadYaml(const std::string& file, const std::string& what) {
  try {
    return YAML::LoadFile(file);
  } catch (const YAML::Exception& e) {
    throw ExperimentFileError(file + ": cannot read the " + what + ": " + e.msg);
  }
}
}  // namespace

std::string worldRobotUrdf(const std::string& world_file) {
  const YAML::Node world = loadYaml(world_file, "world file");
  if (!world.IsMap() || !world["robot"] || !world["robot"].IsMap() || !world["robot"]["urdf"] ||
      !world["robot"]["urdf"].IsScalar()) {
    throw ExperimentFileError(world_file + ": robot.urdf is missing; a world names its robot's URDF");
  }
  try {
    return fs::path(resolveNamedFile(world["robot"]["urdf"].Scalar(),
                                     fs::absolute(fs::path(world_file)).parent_path().string()))
        .lexically_normal()
        .string();
  } catch (const std::invalid_argument& e) {
    throw ExperimentFileError(world_file + ": robot.urdf " + e.what());
  }
}

std::string worldWithRobot(const std::string& world_file, const std::string& urdf) {
  YAML::Node world = loadYaml(world_file, "world file");
  if (!world.IsMap() || !world["robot"] || !world["robot"].IsMap()) {
    throw ExperimentFileError(world_file + ": robot is missing; a world names its robot");
  }
  world["robot"]["urdf"] = urdf;
  YAML::Emitter out;
  out << world;
  return "# " + world_file + " as run, its robot's URDF beside it (xpersif_experiment).\n" + out.c_str() + "\n";
}

std::map<std::string, std::string> componentTypes(const std::string& config_file) {
  const YAML::Node config = loadYaml(config_file, "component list");
  std::map<std::string, std::string> types;
  if (!config.IsMap() || !config["components"] || !config["components"].IsSequence()) return types;
  for (const auto& c : config["components"]) {
    if (c.IsMap() && c["name"] && c["name"].IsScalar() && c["type"] && c["type"].IsScalar()) {
      types[c["name"].Scalar()] = c["type"].Scalar();
    }
  }
  return types;
}

std::vector<std::string> componentNames(const std::string& config_file) {
  const YAML::Node config = loadYaml(config_file, "component list");
  std::vector<std::string> names;
  if (!config.IsMap() || !config["components"] || !config["components"].IsSequence()) return names;
  for (const auto& c : config["components"]) {
    if (c.IsMap() && c["name"] && c["name"].IsScalar()) names.push_back(c["name"].Scalar());
  }
  return names;
}

}  // namespace core
}  // namespace xpersif
