// The experiment file parser: every shipped file loads; each kind of mistake is refused with a sentence that
// names the file, the key and what is wrong; overrides; the file as run reads back to the same experiment.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "xpersif/core/experiment_spec/experiment_spec.h"

namespace fs = std::filesystem;
using xpersif::core::ExperimentFileError;
using xpersif::core::ExperimentSpec;
using xpersif::core::loadExperimentFile;
using xpersif::core::parseOverride;

namespace {

const std::string kSource = XPERSIF_SOURCE_DIR;

/// A valid experiment in a temporary directory, its world given by absolute path.
class ExperimentFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("xpersif_experiment_spec_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& body) {
    const std::string file = (dir_ / "experiment.yaml").string();
    std::ofstream(file) << body;
    return file;
  }
  std::string valid(const std::string& extra = "") {
    return "world: " + kSource + "/worlds/default.yaml\n" + extra +
           "phases:\n"
           "  - {kind: evaluation, name: evaluation, experiments: 4, seed_offset: 1000}\n"
           "  - {kind: experimentation, name: curiosity, design: curiosity, experiments: 8, goals: 2}\n";
  }
  /// The sentence loadExperimentFile throws for this body; fails the test if it loads.
  std::string errorOf(const std::string& body, const std::vector<xpersif::core::Override>& overrides = {}) {
    const std::string file = write(body);
    try {
      loadExperimentFile(file, overrides, {"xpersim", "machine_learning"});
    } catch (const ExperimentFileError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(file + ": ", 0), 0u) << "the sentence must start with the file: " << what;
      return what;
    }
    ADD_FAILURE() << "accepted:\n" << body;
    return "";
  }

  fs::path dir_;
};

TEST_F(ExperimentFileTest, ValidFileWithDefaults) {
  const std::string file = write(valid());
  const ExperimentSpec spec = loadExperimentFile(file);
  EXPECT_EQ(spec.name, "experiment");
  EXPECT_EQ(spec.world, kSource + "/worlds/default.yaml");
  EXPECT_EQ(spec.seed, 1);
  EXPECT_EQ(spec.clock, "lockstep");
  EXPECT_EQ(spec.recording.mode, "off");
  EXPECT_EQ(spec.recording.compression, "lz4");
  ASSERT_EQ(spec.phases.size(), 2u);
  EXPECT_EQ(spec.phases[0].kind, "evaluation");
  EXPECT_EQ(spec.phases[0].design, "round_robin");  // every object the same number of evaluation pushes
  EXPECT_EQ(spec.phases[0].experiments, 4u);
  EXPECT_EQ(spec.phaseSeed(0), 1001u);
  EXPECT_EQ(spec.phases[1].goals, 2u);
  EXPECT_EQ(spec.phaseSeed(1), 1u);
  EXPECT_EQ(spec.phaseNames("experimentation"), std::vector<std::string>{"curiosity"});
  // Relative paths are the file's directory's.
  EXPECT_EQ(spec.run_dir, (dir_.parent_path() / "runs/{time}").string());
}

TEST_F(ExperimentFileTest, RelativePathsAreTheFilesDirectorys) {
  fs::create_directories(dir_ / "worlds");
  fs::copy_file(kSource + "/worlds/default.yaml", dir_ / "worlds/w.yaml");
  const std::string file = write(
      "world: worlds/w.yaml\nrun_dir: out\nphases: [{kind: goal_directed, name: goals, goals: 3}]\n");
  const ExperimentSpec spec = loadExperimentFile(file);
  EXPECT_EQ(spec.world, (dir_ / "worlds/w.yaml").string());
  EXPECT_EQ(spec.run_dir, (dir_ / "out").string());
  EXPECT_EQ(spec.phases[0].goals, 3u);
  EXPECT_EQ(spec.phases[0].experiments, 0u);
}

TEST_F(ExperimentFileTest, EveryShippedExperimentLoads) {
  int files = 0;
  for (const auto& entry : fs::directory_iterator(kSource + "/experiments")) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    const ExperimentSpec spec = loadExperimentFile(entry.path().string());
    EXPECT_FALSE(spec.phases.empty());
    ++files;
  }
  EXPECT_GE(files, 3);
}

TEST_F(ExperimentFileTest, EveryShippedWorldHasAnExperiment) {
  for (const auto& world : fs::directory_iterator(kSource + "/worlds")) {
    if (world.path().extension() != ".yaml") continue;
    const fs::path experiment = fs::path(kSource) / "experiments" / ("world_" + world.path().filename().string());
    ASSERT_TRUE(fs::exists(experiment)) << experiment << " is missing for " << world.path();
    EXPECT_EQ(loadExperimentFile(experiment.string()).world, world.path().lexically_normal().string());
  }
}

TEST_F(ExperimentFileTest, UnknownKeysAreNamed) {
  std::string what = errorOf(valid("sede: 3\n"));
  EXPECT_NE(what.find("unknown key 'sede' (line 2)"), std::string::npos) << what;
  EXPECT_NE(what.find("seed"), std::string::npos) << "the known keys are listed: " << what;
  what = errorOf(valid("recording: {mode: bags, compresion: bz2}\n"));
  EXPECT_NE(what.find("unknown key 'recording.compresion'"), std::string::npos) << what;
  what = errorOf("world: " + kSource + "/worlds/default.yaml\nphases: [{kind: evaluation, name: e, experiments: 2, goals: 1}]\n");
  EXPECT_NE(what.find("unknown key 'phases[0].goals'"), std::string::npos) << what;
  what = errorOf(valid("parameters: {xpersimm: {tick_period: 0.01}}\n"));
  EXPECT_NE(what.find("unknown component 'xpersimm'"), std::string::npos) << what;
}

TEST_F(ExperimentFileTest, WrongTypesAreNamed) {
  std::string what = errorOf(valid("seed: three\n"));
  EXPECT_NE(what.find("seed is 'three'; it must be an integer"), std::string::npos) << what;
  what = errorOf(valid("recording: bags\n"));
  EXPECT_NE(what.find("recording must be a mapping"), std::string::npos) << what;
  what = errorOf("world: " + kSource + "/worlds/default.yaml\nphases: {kind: evaluation}\n");
  EXPECT_NE(what.find("phases must be a non-empty list"), std::string::npos) << what;
  what = errorOf(valid("parameters: {xpersim: 3}\n"));
  EXPECT_NE(what.find("parameters.xpersim must be a mapping"), std::string::npos) << what;
  what = errorOf("[1, 2]\n");
  EXPECT_NE(what.find("must be a mapping"), std::string::npos) << what;
  what = errorOf("world: [unclosed\n");
  EXPECT_NE(what.find("not valid YAML"), std::string::npos) << what;
}

TEST_F(ExperimentFileTest, OutOfRangeValuesAreNamed) {
  std::string what = errorOf("world: " + kSource + "/worlds/default.yaml\n"
                             "phases: [{kind: experimentation, name: r, design: random, experiments: -3}]\n");
  EXPECT_NE(what.find("phases[0].experiments is -3; it must be an integer in 1..100000"), std::string::npos) << what;
  what = errorOf(valid("clock: slow\n"));
  EXPECT_NE(what.find("clock is 'slow'; it must be one of lockstep, realtime, fast"), std::string::npos) << what;
  what = errorOf(valid("recording: {mode: video}\n"));
  EXPECT_NE(what.find("recording.mode is 'video'"), std::string::npos) << what;
  what = errorOf("world: " + kSource + "/worlds/default.yaml\n"
                 "phases: [{kind: experimentation, name: r, design: bogus, experiments: 3}]\n");
  EXPECT_NE(what.find("phases[0].design is 'bogus'"), std::string::npos) << what;
  what = errorOf("world: " + kSource + "/worlds/default.yaml\n"
                 "phases: [{kind: evaluation, name: a, experiments: 3}, {kind: evaluation, name: a, experiments: 3}]\n");
  EXPECT_NE(what.find("phases[1].name 'a' is used twice"), std::string::npos) << what;
  what = errorOf("world: " + kSource + "/worlds/default.yaml\nphases: [{kind: evaluation, name: a b, experiments: 3}]\n");
  EXPECT_NE(what.find("phases[0].name is 'a b'"), std::string::npos) << what;
}

TEST_F(ExperimentFileTest, MissingFilesAreNamed) {
  std::string what = errorOf("world: no/such/world.yaml\nphases: [{kind: evaluation, name: e, experiments: 2}]\n");
  EXPECT_NE(what.find("world names " + (dir_ / "no/such/world.yaml").string() + ", which does not exist"),
            std::string::npos)
      << what;
  // A relative path is resolved against the experiment file, not the shell's directory: the sentence says so.
  EXPECT_NE(what.find("a relative path is taken from the experiment file's directory"), std::string::npos) << what;
  what = errorOf("world: /no/such/world.yaml\nphases: [{kind: evaluation, name: e, experiments: 2}]\n");
  EXPECT_EQ(what.find("relative path"), std::string::npos) << what;
  what = errorOf(valid("robot: missing.urdf\n"));
  EXPECT_NE(what.find("robot names"), std::string::npos) << what;
  what = errorOf("phases: [{kind: evaluation, name: e, experiments: 2}]\n");
  EXPECT_NE(what.find("world is missing"), std::string::npos) << what;
  EXPECT_THROW(loadExperimentFile((dir_ / "absent.yaml").string()), ExperimentFileError);
}

TEST_F(ExperimentFileTest, OverridesApplyBeforeTheChecks) {
  const std::string file = write(valid());
  const ExperimentSpec spec = loadExperimentFile(
      file, {parseOverride("seed=7"), parseOverride("phases.1.experiments=3"), parseOverride("recording.mode=bags"),
             parseOverride("parameters.xpersim.tick_period=0.01")});
  EXPECT_EQ(spec.seed, 7);
  EXPECT_EQ(spec.phaseSeed(0), 1007u);
  EXPECT_EQ(spec.phases[1].experiments, 3u);
  EXPECT_EQ(spec.recording.mode, "bags");
  EXPECT_EQ(spec.parameters.at("xpersim"), "{tick_period: 0.01}");
  // An override is checked like the file.
  std::string what = errorOf(valid(), {parseOverride("phases.1.experiments=0")});
  EXPECT_NE(what.find("phases[1].experiments is 0"), std::string::npos) << what;
  what = errorOf(valid(), {parseOverride("phases.5.experiments=3")});
  EXPECT_NE(what.find("override phases.5.experiments=3: the list has 2 entries"), std::string::npos) << what;
  EXPECT_THROW(parseOverride("seed"), ExperimentFileError);
  EXPECT_THROW(parseOverride("=3"), ExperimentFileError);
}

TEST_F(ExperimentFileTest, TheFileAsRunReadsBackTheSame) {
  const std::string file = write(valid("name: study\nseed: 4\nclock: fast\nrecording: {mode: bags_with_images, "
                                       "compression: bz2}\nparameters: {machine_learning: {k: 5, names: [a, b]}}\n"));
  const ExperimentSpec spec = loadExperimentFile(file);
  const std::string stored = (dir_ / "as_run.yaml").string();
  std::ofstream(stored) << xpersif::core::experimentToYaml(spec, "/tmp/somewhere");
  const ExperimentSpec again = loadExperimentFile(stored);
  EXPECT_EQ(again.name, "study");
  EXPECT_EQ(again.world, spec.world);
  EXPECT_EQ(again.seed, 4);
  EXPECT_EQ(again.clock, "fast");
  EXPECT_EQ(again.run_dir, "/tmp/somewhere");
  EXPECT_EQ(again.recording.mode, "bags_with_images");
  EXPECT_EQ(again.recording.compression, "bz2");
  ASSERT_EQ(again.phases.size(), spec.phases.size());
  for (std::size_t i = 0; i < spec.phases.size(); ++i) {
    EXPECT_EQ(again.phases[i].name, spec.phases[i].name);
    EXPECT_EQ(again.phases[i].experiments, spec.phases[i].experiments);
    EXPECT_EQ(again.phases[i].goals, spec.phases[i].goals);
    EXPECT_EQ(again.phaseSeed(i), spec.phaseSeed(i));
  }
  EXPECT_EQ(again.parameters, spec.parameters);
  const std::string json = xpersif::core::experimentToJson(spec, "/tmp/somewhere");
  EXPECT_NE(json.find("\"seed\":4"), std::string::npos) << json;
  EXPECT_NE(json.find("\"machine_learning\":{\"k\":5,\"names\":[\"a\",\"b\"]}"), std::string::npos) << json;
  EXPECT_EQ(xpersif::core::jsonString("a\"b\\\n"), "\"a\\\"b\\\\\\n\"");
}

}  // namespace

TEST_F(ExperimentFileTest, ComponentParametersAreCheckedAgainstTheirDeclarations) {
  using namespace xpersif::core;
  const ParameterTable xpersim("xpersim", {numberParameter("tick_period", 0.02, 1e-4, 1.0, "s per tick"),
                                           textParameter("clock_mode", "realtime", "how", {"realtime", "lockstep"}),
                                           outputParameter(ParameterSpec::Type::StringList, "available", "")});
  const std::map<std::string, const ParameterTable*> declared{{"xpersim", &xpersim}};
  auto errorWith = [&](const std::string& parameters) {
    const std::string file = write(valid("parameters:\n  xpersim: " + parameters + "\n"));
    try {
      loadExperimentFile(file, {}, {"xpersim", "machine_learning"}, declared);
    } catch (const ExperimentFileError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(errorWith("{tick_period: 0.04, clock_mode: lockstep}"), "accepted");
  std::string why = errorWith("{tick_perod: 0.04}");
  EXPECT_NE(why.find("parameters.xpersim.tick_perod is not a parameter of xpersim: ~tick_perod (did you mean "
                     "~tick_period?) is not declared"),
            std::string::npos)
      << why;
  why = errorWith("{tick_period: fast}");
  EXPECT_NE(why.find("parameters.xpersim.tick_period must be of type double"), std::string::npos) << why;
  why = errorWith("{tick_period: 5}");
  EXPECT_NE(why.find("parameters.xpersim.tick_period is 5; it must lie in [0.0001, 1]"), std::string::npos) << why;
  why = errorWith("{clock_mode: slow}");
  EXPECT_NE(why.find("parameters.xpersim.clock_mode is 'slow'; it must be one of"), std::string::npos) << why;
  why = errorWith("{available: [a]}");
  EXPECT_NE(why.find("is set by xpersim itself"), std::string::npos) << why;
  // A component without declarations (here machine_learning) is not checked further.
  const std::string file = write(valid("parameters:\n  machine_learning: {anything: 1}\n"));
  EXPECT_NO_THROW(loadExperimentFile(file, {}, {"xpersim", "machine_learning"}, declared));
}
