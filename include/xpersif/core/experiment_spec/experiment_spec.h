#pragma once

#include "xpersif/core/common/parameters.h"
/// @file experiment_spec.h
/// @brief An experiment file (experiments/*.yaml): the world, the robot, the phases in order, recording, the
/// run directory, the clock mode and component parameters to override. ROS-free; read with yaml-cpp.
///
/// Every mistake is reported before anything starts, as one sentence that names the experiment file, the key
/// and what is wrong, e.g. `experiments/x.yaml: phases[1].experiments is -3; it must be an integer in 1..100000`.
/// The schema is documented in doc/experiments.md and in experiments/default.yaml.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "xpersif/core/common/validation.h"

namespace xpersif {
namespace core {

/// A malformed experiment file; what() is the sentence.
class ExperimentFileError : public ValidationError {
 public:
  explicit ExperimentFileError(const std::string& what) : ValidationError(what) {}
};

/// One phase: a run of the loop (LOOPMODEL's RunLoop command) under its own name.
struct PhaseSpec {
  /// evaluation: random pushes every design's model is judged on afterwards (no goals);
  /// experimentation: experiments chosen by a design, then optionally goals with the model just learned;
  /// goal_directed: goals only, with the model learned so far.
  std::string kind;
  std::string name;         ///< the run's name in the knowledge base (unique within the experiment)
  std::string design;       ///< curiosity | random | grid (evaluation: random)
  std::uint32_t experiments = 0;
  std::uint32_t goals = 0;
  std::int64_t seed_offset = 0;  ///< the run's seed is the experiment's seed plus this
};

/// Recording of the whole experiment with rosbag (launch/record.launch).
struct RecordingSpec {
  std::string mode = "off";         ///< off | bags | bags_with_images
  std::string compression = "lz4";  ///< lz4 | bz2 | none
};

/// The parsed experiment file. Paths are absolute (relative ones are taken from the file's directory).
struct ExperimentSpec {
  std::string file;      ///< the experiment file as given
  std::string name;      ///< defaults to the file's stem
  std::string world;     ///< the world file
  std::string robot;     ///< a URDF that replaces the world's robot; empty: the world's own
  std::int64_t seed = 1;  ///< the components' seed (DESIGNOFEXPERIMENTS, GOALDESIGN) and the phases' base seed
  std::string clock = "lockstep";  ///< lockstep | realtime | fast
  std::string run_dir;   ///< where everything goes; "{time}" becomes the start time (YYYYmmdd-HHMMSS)
  RecordingSpec recording;
  std::vector<PhaseSpec> phases;
  /// Component parameters to override: component name -> its parameters as a YAML mapping (text).
  std::map<std::string, std::string> parameters;

  /// The run's seed of phase i.
  std::uint64_t phaseSeed(std::size_t i) const {
    return static_cast<std::uint64_t>(seed + phases.at(i).seed_offset);
  }
  /// The phases' names of one kind, in order.
  std::vector<std::string> phaseNames(const std::string& kind) const;
};

/// One "KEY=VALUE" override from the command line, applied to the file before it is checked. KEY is a dotted
/// path into the file (`seed`, `recording.mode`, `phases.1.experiments`, `parameters.xpersim.tick_period`);
/// VALUE is read as YAML (`3`, `bags`, `[1, 2]`).
struct Override {
  std::string key;
  std::string value;
};

/// Parses "KEY=VALUE"; throws ExperimentFileError naming the text when there is no '=' or no key.
Override parseOverride(const std::string& text);

/// Reads and checks an experiment file, with overrides applied first. Checks: the file is YAML and a mapping;
/// every key is known (at the top, in recording and in each phase); every value has its type and lies in its
/// range; phase names are unique identifiers; the world file (and robot URDF) exist. Does not load the world:
/// loadWorldFile does that. Throws ExperimentFileError.
/// @param known_components component names `parameters` may override (empty: any identifier)
/// @param declared each component's declared parameters (by component name): a parameter it does not declare
///        ("did you mean ..."), a value of the wrong type or out of its range is an ExperimentFileError; a
///        component without an entry is not checked further
ExperimentSpec loadExperimentFile(const std::string& path, const std::vector<Override>& overrides = {},
                                  const std::vector<std::string>& known_components = {},
                                  const std::map<std::string, const ParameterTable*>& declared = {});

/// The components of a supervisor's list (config/loop.yaml): name -> nodelet type.
std::map<std::string, std::string> componentTypes(const std::string& config_file);

/// The experiment as run: YAML that loadExperimentFile reads back to the same ExperimentSpec, with absolute
/// paths, every default written out, and the run directory given (no "{time}").
std::string experimentToYaml(const ExperimentSpec& spec, const std::string& run_dir);

/// The same as a JSON object, for the knowledge base's run record.
std::string experimentToJson(const ExperimentSpec& spec, const std::string& run_dir);

/// A JSON string literal (quoted, escaped).
std::string jsonString(const std::string& text);

/// The URDF a world file's robot.urdf names, absolute (relative names are the world file's directory's).
/// Throws ExperimentFileError when the world file is not YAML or names no URDF.
std::string worldRobotUrdf(const std::string& world_file);

/// The world file's text with robot.urdf set to `urdf`: how an experiment's world is stored in its run
/// directory beside a copy of the URDF, so that the directory is self-contained.
std::string worldWithRobot(const std::string& world_file, const std::string& urdf);

/// The component names a supervisor's config file lists under `components` (config/loop.yaml, ...).
std::vector<std::string> componentNames(const std::string& config_file);

}  // namespace core
}  // namespace xpersif
