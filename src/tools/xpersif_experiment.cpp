// xpersif_experiment: runs an experiment file (experiments/*.yaml) from start to end; launch/experiment.launch
// starts it as its one required node, so roslaunch ends when it does.
//
//   xpersif_experiment check FILE [--components CONFIG,...] [KEY=VALUE...]
//       ROS-free: check the file (and its world) and print it as run; exit 2 with one sentence when it is wrong.
//       experiment.launch runs this while roslaunch reads the launch file, so a bad file starts nothing.
//   xpersif_experiment (a ROS node; private parameters ~experiment, ~overrides, ~run_dir, ~status_file,
//       ~components, ~startup_timeout)
//       1. the run directory: the experiment as run (experiment.yaml), its world and URDF, the component
//          parameters (parameters.yaml) and provenance.yaml (code version, source files);
//       2. launch/xpersif.launch on the same master, its output in launch.log, and wait until LOOPMODEL is up;
//       3. each phase as one RunLoop goal (the provenance goes into the run's record in the knowledge base);
//          progress on the console and on ~progress;
//       4. xpersif_report into the run directory; then the system is stopped.
//   Exit status 0 when every phase succeeded and the report was written, 1 otherwise, 2 for a bad file; the
//   same code and a sentence go to RUN_DIR/status and to ~status_file (Debian's roslaunch exits 0 whatever
//   its required node returned: scripts/run.sh exits with this file's code).
#include <ros/master.h>
#include <ros/ros.h>
#include <yaml-cpp/yaml.h>

#include <actionlib/client/simple_action_client.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "xpersif/core/experiment_spec/experiment_spec.h"
#include "parameter_catalogue.h"
#include "xpersif/core/perception/perception_check.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/sim/world_spec.h"
#include "xpersif/ExperimentProgress.h"
#include "xpersif/RunLoopAction.h"
#include "run_driver.h"
#include "tool_command_line.h"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using xpersif::core::ExperimentSpec;

std::vector<std::string> split(const std::string& text, char by) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, by);) {
    if (!part.empty()) out.push_back(part);
  }
  return out;
}

std::vector<std::string> knownComponents(const std::vector<std::string>& configs) {
  // LOOPMODEL itself takes parameters too; the rest are the supervisors' components.
  std::vector<std::string> names{"loop_model"};
  for (const auto& c : configs) {
    for (const auto& n : xpersif::core::componentNames(c)) names.push_back(n);
  }
  return names;
}

/// The world the experiment will run on, built as XPERSim will build it (with the experiment's robot).
void checkWorld(const ExperimentSpec& spec) {
  const std::string urdf = spec.robot.empty() ? xpersif::core::worldRobotUrdf(spec.world) : spec.robot;
  try {
    const auto world = xpersif::core::parseWorld(xpersif::core::worldWithRobot(spec.world, urdf),
                                                 fs::path(spec.world).parent_path().string(), spec.world);
    xpersif::core::PhysicsWorld physics(world);
    // Seen through its cameras at the start, with the loop's own FEATUREEXTRACTION: a world the loop could not
    // perceive is refused now, with the reason, not after every experiment has failed.
    const std::string problem =
        xpersif::core::checkPerception(physics.scene(), physics.dynamicTransforms()).problem();
    if (!problem.empty()) throw std::runtime_error(problem + " (`xpersif check-world " + spec.world + "` shows all)");
  } catch (const std::exception& e) {
    throw xpersif::core::ExperimentFileError(spec.file + ": world " + spec.world + " cannot be used: " + e.what());
  }
}

/// Each component's declared parameters (doc/parameters.md), by its name in the component lists.
std::map<std::string, const xpersif::core::ParameterTable*> declaredParameters(const std::vector<std::string>& configs) {
  std::map<std::string, const xpersif::core::ParameterTable*> declared{
      {"loop_model", xpersif::declaredParametersOf("xpersif/LoopModelNodelet")}};
  for (const auto& c : configs) {
    for (const auto& [name, type] : xpersif::core::componentTypes(c)) declared[name] = xpersif::declaredParametersOf(type);
  }
  return declared;
}

ExperimentSpec load(const std::string& file, const std::vector<std::string>& overrides,
                    const std::vector<std::string>& configs) {
  std::vector<xpersif::core::Override> parsed;
  for (const auto& o : overrides) parsed.push_back(xpersif::core::parseOverride(o));
  ExperimentSpec spec =
      xpersif::core::loadExperimentFile(file, parsed, knownComponents(configs), declaredParameters(configs));
  checkWorld(spec);
  return spec;
}

/// `check`: the file (and its world) checked and printed as it will run; exit 2 with one sentence when it is wrong.
int check(const std::string& file, const std::vector<std::string>& overrides, const std::vector<std::string>& configs) {
  try {
    const ExperimentSpec spec = load(file, overrides, configs);
    std::cout << xpersif::core::experimentToYaml(spec, spec.run_dir);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "xpersif_experiment: " << e.what() << std::endl;
    return 2;
  }
}

std::string nowStamp() {
  const std::time_t t = std::time(nullptr);
  std::tm local{};
  localtime_r(&t, &local);
  std::ostringstream out;
  out << std::put_time(&local, "%Y%m%d-%H%M%S");
  return out.str();
}

void writeFile(const fs::path& file, const std::string& text) {
  std::ofstream out(file);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + file.string());
}

std::string readCommand(const std::string& command) {
  std::string out;
  if (FILE* pipe = ::popen(command.c_str(), "r")) {
    char buffer[256];
    while (std::fgets(buffer, sizeof buffer, pipe)) out += buffer;
    if (::pclose(pipe) != 0) out.clear();
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out;
}

/// git describe of the package's checkout, else package.xml's version.
std::string codeVersion(const std::string& package_dir) {
  std::string version = readCommand("git -C '" + package_dir + "' describe --always --dirty --tags 2>/dev/null");
  if (!version.empty()) return version;
  std::ifstream in(package_dir + "/package.xml");
  const std::string xml((std::istreambuf_iterator<char>(in)), {});
  const auto begin = xml.find("<version>"), end = xml.find("</version>");
  if (begin != std::string::npos && end != std::string::npos && end > begin) {
    return "package " + xml.substr(begin + 9, end - begin - 9);
  }
  return "unknown";
}

/// An executable of this package: beside this one (devel or install space), else on the PATH.
std::string sibling(const std::string& name) {
  std::error_code error;
  const fs::path here = fs::read_symlink("/proc/self/exe", error).parent_path() / name;
  return !error && fs::exists(here) ? here.string() : name;
}

/// A child process: argv, output appended to a file (or inherited when empty), optional extra environment.
pid_t spawn(const std::vector<std::string>& argv, const std::string& output, const std::vector<std::string>& env = {}) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (!output.empty()) {
    posix_spawn_file_actions_addopen(&actions, 1, output.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
  }
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  std::vector<std::string> environment(env);
  for (char** e = environ; *e; ++e) environment.emplace_back(*e);  // the first of a name wins
  std::vector<char*> envp;
  for (auto& e : environment) envp.push_back(const_cast<char*>(e.c_str()));
  envp.push_back(nullptr);
  pid_t pid = -1;
  const int error = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  return error == 0 ? pid : -1;
}

/// Waits for a child; its exit status, or 128 + signal.
int waitFor(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return 127;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

/// Stops a child roslaunch as a person would: SIGINT, then harder if it does not go (it ignores SIGINT while
/// it is still starting).
void stopChild(pid_t pid) {
  for (const int signal : {SIGINT, SIGINT, SIGTERM, SIGKILL}) {
    if (::kill(pid, signal) != 0) break;
    for (int i = 0; i < 100; ++i) {
      int status = 0;
      if (::waitpid(pid, &status, WNOHANG) == pid) return;
      ::usleep(100000);
    }
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
}

class Runner {
 public:
  Runner(ros::NodeHandle& pnh) : pnh_(pnh) { progress_pub_ = pnh_.advertise<xpersif::ExperimentProgress>("progress", 10, true); }

  int run() {
    started_ = std::chrono::steady_clock::now();
    std::string file, overrides, run_dir;
    pnh_.param("experiment", file, file);
    pnh_.param("overrides", overrides, overrides);
    pnh_.param("run_dir", run_dir, run_dir);
    pnh_.param("status_file", status_file_, status_file_);
    pnh_.param("components", components_, components_);
    pnh_.param("package_dir", package_dir_, package_dir_);
    pnh_.param("startup_timeout", startup_timeout_, startup_timeout_);
    std::string hosts;
    pnh_.param("hosts", hosts, hosts);
    pnh_.param("web", web_, web_);
    pnh_.param("web_port", web_port_, web_port_);
    // roslaunch starts nodes in ROS_HOME: relative paths are the launching shell's (~cwd).
    std::string cwd;
    pnh_.param("cwd", cwd, cwd);
    const auto fromShell = [&](const std::string& path) {
      return path.empty() || fs::path(path).is_absolute() || cwd.empty() ? path : (fs::path(cwd) / path).string();
    };
    file = fromShell(file);
    run_dir = fromShell(run_dir);
    try {
      spec_ = load(file, split(overrides, ' '), split(components_, ','));
    } catch (const std::exception& e) {
      return finish(2, e.what());
    }
    // Where the system's parts run (doc/hosts.md): only xpersif.launch's host arguments, so that
    // nothing here can change what the experiment file says.
    static const std::set<std::string> kHostArguments = {
        "sim_host", "loop_host", "view_host", "view_rviz", "view_telesim", "view_telesim_display",
        "view_telesim_output_dir", "ssh_user", "ssh_port", "env_loader", "machine_timeout"};
    for (const auto& argument : split(hosts, ' ')) {
      if (argument.empty()) continue;
      // NAME=VALUE (roslaunch drops a command-line argument with two ':='), passed on as NAME:=VALUE.
      const auto assign = argument.find('=');
      const std::string name = assign == std::string::npos ? "" : argument.substr(0, assign);
      if (!kHostArguments.count(name)) {
        std::string known;
        for (const auto& k : kHostArguments) known += (known.empty() ? "" : ", ") + k;
        return finish(2, "hosts: '" + argument + "' is not NAME=VALUE with NAME one of xpersif.launch's host "
                         "arguments (" + known + ")");
      }
      host_arguments_.push_back(name + ":=" + argument.substr(assign + 1));
    }
    progress_.experiment = spec_.name;
    progress_.phases = static_cast<std::uint32_t>(spec_.phases.size());
    for (const auto& p : spec_.phases) units_total_ += p.experiments + p.goals;

    run_dir_ = run_dir.empty() ? spec_.run_dir : run_dir;
    const auto stamp = run_dir_.find("{time}");
    if (stamp != std::string::npos) run_dir_.replace(stamp, 6, nowStamp());
    run_dir_ = fs::absolute(run_dir_).lexically_normal().string();
    if (fs::exists(fs::path(run_dir_) / "knowledge.db")) {
      return finish(2, spec_.file + ": run_dir " + run_dir_ +
                           " already holds a knowledge base; an experiment needs a run directory of its own");
    }
    owns_run_dir_ = true;
    try {
      prepareRunDirectory();
    } catch (const std::exception& e) {
      return finish(1, "cannot prepare the run directory " + run_dir_ + ": " + e.what());
    }
    say("starting", spec_.name + ": " + std::to_string(spec_.phases.size()) + " phases, results in " + run_dir_);

    launch_ = startSystem();
    if (launch_ < 0) return finish(1, "cannot start roslaunch for launch/xpersif.launch");
    const int outcome = runPhases();
    stopChild(launch_);
    launch_ = -1;
    return outcome;
  }

  /// Ctrl-C or the outer roslaunch stopping: the child system is stopped too.
  ~Runner() {
    if (launch_ > 0) stopChild(launch_);
  }

 private:
  void prepareRunDirectory() {
    fs::create_directories(run_dir_);
    const std::string urdf = spec_.robot.empty() ? xpersif::core::worldRobotUrdf(spec_.world) : spec_.robot;
    const std::string urdf_copy = fs::path(urdf).filename().string();
    fs::copy_file(urdf, fs::path(run_dir_) / urdf_copy, fs::copy_options::overwrite_existing);
    world_copy_ = (fs::path(run_dir_) / "world.yaml").string();
    writeFile(world_copy_, xpersif::core::worldWithRobot(spec_.world, urdf_copy));
    // The experiment as run names the copies, so that it repeats from the run directory alone.
    ExperimentSpec as_run = spec_;
    as_run.world = world_copy_;
    as_run.robot.clear();
    as_run_json_ = xpersif::core::experimentToJson(as_run, run_dir_);
    writeFile(fs::path(run_dir_) / "experiment.yaml", xpersif::core::experimentToYaml(as_run, run_dir_));
    // Component parameters, loaded into /xpersif after the launch's own.
    std::ostringstream parameters;
    parameters << "# Component parameters the experiment overrides (loaded into /xpersif by xpersif.launch).\n";
    // Emitted as one YAML document: a component's values may be a nested mapping or hold lists, which a flow
    // text after "component: " would not always keep valid.
    YAML::Node all(YAML::NodeType::Map);
    for (const auto& [component, values] : spec_.parameters) all[component] = YAML::Load(values);
    YAML::Emitter emitted;
    emitted << all;
    parameters << (spec_.parameters.empty() ? std::string("{}") : std::string(emitted.c_str())) << "\n";
    parameters_file_ = (fs::path(run_dir_) / "parameters.yaml").string();
    writeFile(parameters_file_, parameters.str());
    code_version_ = codeVersion(package_dir_);
    std::ostringstream provenance;
    provenance << "# Where this run came from (xpersif_experiment). Repeat it: xpersif rerun " << run_dir_ << "\n"
               << "experiment_file: " << xpersif::core::jsonString(fs::absolute(spec_.file).string()) << "\n"
               << "world_file: " << xpersif::core::jsonString(spec_.world) << "\n"
               << "urdf_file: " << xpersif::core::jsonString(urdf) << "\n"
               << "code_version: " << xpersif::core::jsonString(code_version_) << "\n"
               << "started: " << xpersif::core::jsonString(nowStamp()) << "\n"
               << "stored: [experiment.yaml, world.yaml, " << urdf_copy << ", parameters.yaml]\n";
    writeFile(fs::path(run_dir_) / "provenance.yaml", provenance.str());
  }

  pid_t startSystem() {
    const std::string record = spec_.recording.mode == "off" ? "false" : "true";
    const std::string images = spec_.recording.mode == "bags_with_images" ? "true" : "false";
    std::vector<std::string> argv = {
        "roslaunch", "xpersif", "xpersif.launch", "world:=" + world_copy_,
        "database:=" + run_dir_ + "/knowledge.db", "seed:=" + std::to_string(spec_.seed), "run_dir:=" + run_dir_,
        "clock_mode:=" + spec_.clock, "record:=" + record, "record_images:=" + images,
        "record_compression:=" + spec_.recording.compression, "parameters:=" + parameters_file_};
    std::vector<std::string> args = argv;
    args.insert(args.end(), host_arguments_.begin(), host_arguments_.end());
    if (web_) {  // watch it in a browser (WEBBRIDGE)
      args.push_back("web:=true");
      args.push_back("web_port:=" + std::to_string(web_port_));
    }
    return spawn(args, run_dir_ + "/launch.log", {"ROS_LOG_DIR=" + run_dir_ + "/ros_log"});
  }

  int runPhases() {
    // The console client's own wait: LOOPMODEL and every part ACTIVE.
    const pid_t wait = spawn({sibling("xpersif"), "wait", "--timeout", std::to_string(startup_timeout_), "/xpersif/loop_model"},
                             run_dir_ + "/status.txt");
    if (wait < 0 || waitFor(wait) != 0) {
      return finish(1, "the system did not come up within " + std::to_string(startup_timeout_) + " s; see " +
                           run_dir_ + "/launch.log and status.txt");
    }
    if (!ros::ok()) return finish(1, "interrupted while the system came up");
    actionlib::SimpleActionClient<xpersif::RunLoopAction> client("/xpersif/loop_model/run", true);
    if (!client.waitForServer(ros::Duration(30.0))) return finish(1, "LOOPMODEL's run command is not offered");
    phases_started_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    for (std::size_t i = 0; i < spec_.phases.size(); ++i) {
      const auto& phase = spec_.phases[i];
      progress_.phase = phase.name;
      progress_.kind = phase.kind;
      progress_.phase_number = static_cast<std::uint32_t>(i + 1);
      progress_.experiments = phase.experiments;
      progress_.goals = phase.goals;
      progress_.experiments_done = 0;
      say("running", "phase " + std::to_string(i + 1) + "/" + std::to_string(spec_.phases.size()) + " " + phase.name +
                         " (" + phase.kind + "): " + std::to_string(phase.experiments) + " experiments by " +
                         phase.design + " design, " + std::to_string(phase.goals) + " goals, seed " +
                         std::to_string(spec_.phaseSeed(i)));
      xpersif::RunLoopGoal goal;
      goal.name = phase.name;
      goal.design = phase.design;
      goal.experiments = phase.experiments;
      goal.goals = phase.goals;
      goal.seed = spec_.phaseSeed(i);
      goal.provenance = "{\"experiment\":" + as_run_json_ + ",\"experiment_file\":" +
                        xpersif::core::jsonString(run_dir_ + "/experiment.yaml") +
                        ",\"code_version\":" + xpersif::core::jsonString(code_version_) +
                        ",\"phase\":" + std::to_string(i + 1) + "}";
      const std::uint32_t units_before = units_done_;
      // A phase whose LOOPMODEL died and came back goes on, resumed from the knowledge base (RunDriver).
      xpersif::RunDriver driver(client, "/xpersif/loop_model/run", [&](const std::string& s) { say("running", s); });
      const xpersif::RunDriver::Outcome outcome = driver.run(
          goal,
          [&](const xpersif::RunLoopFeedbackConstPtr& p) {
            if (p->experiment != progress_.experiments_done && p->experiment <= phase.experiments) {
              progress_.experiments_done = p->experiment;
              units_done_ = units_before + p->experiment;
              say("running", phase.name + ": experiment " + std::to_string(p->experiment) + " of " +
                                 std::to_string(phase.experiments) + ": " + p->last);
            } else if (p->state == "goal_directed" && p->last != last_goal_text_) {
              last_goal_text_ = p->last;
              say("running", phase.name + ": goals: " + p->last);
            }
          },
          {}, [] { return !ros::ok(); });
      if (!outcome.ended) {
        if (!ros::ok()) return finish(1, "interrupted in phase " + phase.name + "; nothing after it ran");
        return finish(1, "phase " + phase.name + ": " + outcome.problem);
      }
      const auto& state = outcome.state;
      const auto& result = outcome.result;
      units_done_ = units_before + phase.experiments + phase.goals;
      if (state != actionlib::SimpleClientGoalState::SUCCEEDED) {
        // A cause that fails every experiment (the loop cannot perceive) has its own code: running again won't help.
        const bool repeating = result && result->code == xpersif::RunLoopResult::REPEATING_CAUSE;
        return finish(repeating ? xpersif::core::kExitRepeatingCause : xpersif::core::kExitFailed,
                      "phase " + phase.name + " ended " + state.toString() + ": " + state.getText());
      }
      std::ostringstream summary;
      summary << "phase " << phase.name << " done: run " << (result ? result->run_id : 0) << ", "
              << (result ? result->experiments_done : 0) << " experiments ("
              << (result ? result->experiments_failed : 0) << " failed), goals reached "
              << (result ? result->goals_reached : 0) << " of " << (result ? result->goals_tried : 0);
      say("running", summary.str());
    }
    return report();
  }

  int report() {
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    const std::string done = spec_.name + " done in " + std::to_string(static_cast<long>(took)) + " s";
    const auto evaluation = spec_.phaseNames("evaluation");
    // The report judges every model on the evaluation set: without one there is nothing to judge on.
    if (evaluation.empty()) return finish(0, done + "; no evaluation phase, so no report; results in " + run_dir_);
    // An evaluation set alone (a study's, scripts/study.py) has no design to judge on it.
    if (spec_.phaseNames("experimentation").empty()) {
      return finish(0, done + "; no experimentation phase to judge on the evaluation set, so no report; results in " +
                           run_dir_);
    }
    say("report", "writing the report into " + run_dir_);
    std::vector<std::string> argv = {sibling("xpersif_report"), "--database", run_dir_ + "/knowledge.db", "--out", run_dir_,
                                     "--evaluation", evaluation.front(), "--world", world_copy_};
    std::string designs;
    for (const auto& name : spec_.phaseNames("experimentation")) designs += (designs.empty() ? "" : ",") + name;
    if (!designs.empty()) argv.insert(argv.end(), {"--designs", designs});
    for (const auto& p : spec_.phases) {
      if (p.goals > 0) {
        argv.insert(argv.end(), {"--goals", p.name});
        break;  // the report follows one phase's goals
      }
    }
    const pid_t pid = spawn(argv, run_dir_ + "/report.log");
    if (pid < 0 || waitFor(pid) != 0 || !fs::exists(fs::path(run_dir_) / "report.md")) {
      return finish(1, "xpersif_report failed; see " + run_dir_ + "/report.log");
    }
    std::ifstream report(fs::path(run_dir_) / "report.md");
    std::cout << report.rdbuf() << std::endl;
    return finish(0, done + ": report in " + run_dir_ + "/report.md");
  }

  /// A console line and a ~progress message; the action client's feedback thread calls it too.
  void say(const std::string& state, const std::string& text) {
    std::lock_guard<std::mutex> lock(say_mutex_);
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    progress_.state = state;
    progress_.text = text;
    progress_.elapsed = elapsed;
    // The pace since the first phase began, times what is left; unknown until something is done.
    progress_.seconds_left = -1;
    if (units_done_ > 0 && units_total_ >= units_done_) {
      progress_.seconds_left = (elapsed - phases_started_) / units_done_ * (units_total_ - units_done_);
    }
    progress_pub_.publish(progress_);
    std::ostringstream line;
    line << "experiment [" << std::fixed << std::setprecision(0) << elapsed << " s";
    if (progress_.seconds_left >= 0) line << ", about " << progress_.seconds_left << " s left";
    line << "] " << text;
    std::cout << line.str() << std::endl;
  }

  int finish(int code, const std::string& sentence) {
    progress_.state = code == 0 ? "succeeded" : "failed";
    say(progress_.state, sentence);
    if (code != 0) std::cerr << "xpersif_experiment: " << sentence << std::endl;
    const std::string line = std::to_string(code) + " " + sentence + "\n";
    if (owns_run_dir_ && fs::is_directory(run_dir_)) {  // never another run's
      try {
        writeFile(fs::path(run_dir_) / "status", line);
      } catch (const std::exception&) {
      }
    }
    if (!status_file_.empty()) {
      try {
        writeFile(status_file_, line);
      } catch (const std::exception& e) {
        std::cerr << "xpersif_experiment: " << e.what() << std::endl;
      }
    }
    return code;
  }

  ros::NodeHandle& pnh_;
  std::mutex say_mutex_;
  ros::Publisher progress_pub_;
  xpersif::ExperimentProgress progress_;
  ExperimentSpec spec_;
  std::string status_file_, components_, package_dir_, run_dir_, world_copy_, parameters_file_, as_run_json_,
      code_version_, last_goal_text_;
  std::vector<std::string> host_arguments_;  // xpersif.launch sim_host:=... (~hosts)
  double startup_timeout_ = 180.0;
  bool web_ = false;      // ~web: the system with WEBBRIDGE (web:=true), on ~web_port
  int web_port_ = 8765;
  pid_t launch_ = -1;
  bool owns_run_dir_ = false;
  std::chrono::steady_clock::time_point started_;
  std::uint32_t units_total_ = 0;
  std::atomic<std::uint32_t> units_done_{0};  // also counted in the feedback thread
  double phases_started_ = 0;  // wall seconds from the start to the first phase (bring-up)
};

/// Ends the launch without roslaunch's red "REQUIRED process [experiment] has died!" banner, which Debian's
/// roslaunch prints whenever a required node ends, cleanly or not: when our parent is roslaunch, it is asked to
/// shut down first (SIGINT, as Ctrl-C does), and this node waits to be stopped by it. The outcome is already in
/// the status files; a node run by anything else just returns.
void endLaunchQuietly() {
  const pid_t parent = getppid();
  std::ifstream cmdline("/proc/" + std::to_string(parent) + "/cmdline");
  const std::string command((std::istreambuf_iterator<char>(cmdline)), std::istreambuf_iterator<char>());
  if (command.find("roslaunch") == std::string::npos) return;
  std::signal(SIGINT, SIG_DFL);  // roslaunch's shutdown then ends this process at once
  std::signal(SIGTERM, SIG_DFL);
  if (kill(parent, SIGINT) != 0) return;
  for (int i = 0; i < 300 && getppid() == parent; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
}

}  // namespace

int main(int argc, char** argv) {
  // ROS's own arguments (remappings such as __name:=, which roslaunch adds) are taken out first: what is left is
  // this tool's command line.
  std::vector<std::string> words;
  ros::removeROSArgs(argc, argv, words);
  CLI::App app("Runs an experiment file from start to end as the one required node of launch/experiment.launch "
               "(its settings are private parameters); `check` checks a file without ROS (doc/experiments.md).",
               "xpersif_experiment");
  xpersif::tools::describe(app, xpersif::tools::exitCodes("every phase succeeded and the report was written",
                                                          "a phase or the report failed, or no ROS master") +
                                    " A bad experiment file exits 2: nothing started. A phase that stopped on a cause "
                                    "that fails every experiment (the loop cannot perceive) exits 5.");
  std::string file;
  std::vector<std::string> overrides, configs;
  auto* check_command = app.add_subcommand("check", "check the file (and its world) and print it as it will run");
  check_command->add_option("FILE", file, "the experiment file")->required();
  check_command->add_option("KEY=VALUE", overrides, "keys of the file to change, e.g. seed=3 phases.1.experiments=8");
  check_command->add_option("--components", configs, "the component configurations the parameters are checked against, "
                                                     "comma-separated")
      ->allow_extra_args(false)  // one word, split at commas: the words after it are KEY=VALUE
      ->delimiter(',');
  if (const auto done = xpersif::tools::parse(app, words)) return *done;
  if (check_command->parsed()) return check(file, overrides, configs);
  ros::init(argc, argv, "experiment_runner");
  if (!ros::master::check()) {
    std::cerr << "xpersif_experiment: no ROS master at " << ros::master::getURI()
              << "; run it through `roslaunch xpersif experiment.launch experiment:=FILE`\n";
    return 1;
  }
  ros::NodeHandle pnh("~");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  int code = 1;
  {
    Runner runner(pnh);
    code = runner.run();
  }
  ros::shutdown();
  endLaunchQuietly();
  return code;
}
