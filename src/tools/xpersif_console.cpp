// xpersif: the console client of the paper. It finds every component by its ~status topic and shows or
// changes its state, and it drives LOOPMODEL: configure and start a run, pause, resume, stop, confirm,
// hand-chosen experiments (sliding autonomy), progress.
#include <ros/master.h>
#include <ros/ros.h>

#include <iomanip>
#include <iterator>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <actionlib/client/simple_action_client.h>
#include <std_srvs/Trigger.h>

#include <csignal>
#include <ctime>
#include <filesystem>
#include <sys/wait.h>
#include <unistd.h>
#include <fstream>

#include "xpersif/core/perception/feature_extractor.h"
#include "xpersif/core/common/command_line.h"
#include "xpersif/core/common/package_path.h"
#include "xpersif/core/perception/perception_check.h"
#include "xpersif/core/sim/physics_world.h"
#include "xpersif/core/common/setup.h"
#include "xpersif/core/common/validation.h"
#include "xpersif/core/sim/world_generator.h"
#include "xpersif/core/sim/world_spec.h"
#include "xpersif/ComponentStatus.h"
#include "xpersif/RunLoopAction.h"
#include "run_driver.h"
#include "tool_command_line.h"
#include "xpersif/SetExperiment.h"
#include "xpersif/GetContracts.h"
#include "xpersif/Transition.h"

namespace {


using StatusMap = std::map<std::string, xpersif::ComponentStatus>;

std::vector<std::string> statusTopics() {
  ros::master::V_TopicInfo topics;
  ros::master::getTopics(topics);
  std::vector<std::string> out;
  for (const auto& t : topics) {
    if (t.datatype == "xpersif/ComponentStatus") out.push_back(t.name);
  }
  return out;
}

// Collect the latest status of every component until all have spoken once or the time is up.
StatusMap collectStatus(double timeout) {
  ros::NodeHandle nh;
  StatusMap latest;
  std::vector<ros::Subscriber> subscribers;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  std::vector<std::string> topics = statusTopics();
  for (const auto& topic : topics) {
    subscribers.push_back(nh.subscribe<xpersif::ComponentStatus>(
        topic, 10, [&latest](const xpersif::ComponentStatus::ConstPtr& s) { latest[s->component] = *s; }));
  }
  while (ros::ok() && ros::WallTime::now() < end && latest.size() < topics.size()) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
  return latest;
}

const char* healthName(std::uint8_t health) {
  switch (health) {
    case xpersif::ComponentStatus::HEALTH_OK: return "ok";
    case xpersif::ComponentStatus::HEALTH_WARN: return "warn";
    case xpersif::ComponentStatus::HEALTH_ERROR: return "error";
    case xpersif::ComponentStatus::HEALTH_STALE: return "stale";
  }
  return "?";
}

void printStatus(const StatusMap& statuses) {
  std::cout << std::left << std::setw(34) << "COMPONENT" << std::setw(14) << "STATE" << std::setw(8) << "HEALTH"
            << std::setw(10) << "HEARTBEAT" << "TYPE / NOTE\n";
  for (const auto& [name, s] : statuses) {
    std::cout << std::setw(34) << name << std::setw(14) << s.state_name << std::setw(8) << healthName(s.health)
              << std::setw(10) << s.heartbeat << s.type;
    if (!s.running_commands.empty()) {
      std::cout << "  running:";
      for (const auto& c : s.running_commands) std::cout << " " << c;
    }
    if (!s.last_error.empty()) std::cout << "  error: " << s.last_error;
    std::cout << "\n";
    for (const auto& p : s.parts) {
      std::cout << "  - " << std::setw(30) << p.name << std::setw(14) << p.state_name << std::setw(8)
                << healthName(p.health) << std::setw(10) << "" << p.message << "\n";
    }
  }
  if (statuses.empty()) std::cout << "(no component answered)\n";
}

// "" when the component and all its parts are ACTIVE, else what is not.
std::string notReady(const StatusMap& statuses, const std::string& name) {
  auto it = statuses.find(name);
  if (it == statuses.end()) return name + " has not reported its status";
  const auto& s = it->second;
  if (s.state != xpersif::ComponentStatus::ACTIVE) {
    return name + " is " + s.state_name + (s.last_error.empty() ? "" : " (" + s.last_error + ")");
  }
  for (const auto& p : s.parts) {
    if (p.state != xpersif::ComponentStatus::ACTIVE) {
      return name + ": part " + p.name + " is " + p.state_name + (p.message.empty() ? "" : " (" + p.message + ")");
    }
  }
  return "";
}

int waitActive(const std::vector<std::string>& names, double timeout) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  std::string reason = "nothing heard";
  while (ros::ok()) {
    const StatusMap statuses = collectStatus(0.5);
    reason.clear();
    for (const auto& n : names) {
      reason = notReady(statuses, n);
      if (!reason.empty()) break;
    }
    if (reason.empty()) {
      printStatus(statuses);
      return 0;
    }
    if (ros::WallTime::now() > end) break;
    ros::WallDuration(0.2).sleep();
  }
  std::cerr << "xpersif: not ACTIVE within " << timeout << " s: " << reason << "\n";
  return 1;
}

int transition(const std::string& verb, const std::string& component) {
  const std::string service = component + "/" + verb;
  if (!ros::service::waitForService(service, ros::Duration(5.0))) {
    std::cerr << "xpersif: " << component << " offers no " << service << " service (is it running?)\n";
    return 1;
  }
  xpersif::Transition call;
  if (!ros::service::call(service, call)) {
    std::cerr << "xpersif: the call to " << service << " failed\n";
    return 1;
  }
  if (!call.response.success) {
    std::cerr << "xpersif: " << call.response.message << "\n";
    return 1;
  }
  std::cout << component << ": " << call.response.state_name << "\n";
  return 0;
}

int contracts(const std::string& component, const std::string& name) {
  xpersif::GetContracts call;
  call.request.name = name;
  if (!ros::service::call(component + "/get_contracts", call)) {
    std::cerr << "xpersif: " << component << "/get_contracts did not answer\n";
    return 1;
  }
  if (!call.response.success) {
    std::cerr << "xpersif: " << call.response.message << "\n";
    return 1;
  }
  for (const auto& c : call.response.contracts) {
    std::cout << c.kind << " " << c.name << " (" << c.interface_type << "): " << c.description << "\n";
    if (!c.parameters.empty()) {
      std::cout << "  parameters:";
      for (const auto& p : c.parameters) std::cout << " " << p;
      std::cout << "\n";
    }
    for (const auto& p : c.preconditions) std::cout << "  requires " << p.literal << "  -- " << p.description << "\n";
    for (const auto& e : c.effects) std::cout << "  effect   " << e << "\n";
  }
  return 0;
}

std::string loop_name = "/xpersif/loop_model";

bool parseExperiment(const std::vector<std::string>& words, std::size_t at, xpersif::Experiment* e) {
  if (words.size() < at + 4) return false;
  e->object = words[at];
  e->side = words[at + 1];
  try {
    e->offset = xpersif::core::parseRealNumber("OFFSET", words[at + 2], -1e3, 1e3);
    e->distance = xpersif::core::parseRealNumber("DISTANCE", words[at + 3], -1e3, 1e3);
  } catch (const std::exception&) {
    return false;
  }
  return true;
}

int trigger(const std::string& operation) {
  std_srvs::Trigger call;
  const std::string service = loop_name + "/" + operation;
  if (!ros::service::waitForService(service, ros::Duration(5.0)) || !ros::service::call(service, call)) {
    std::cerr << "xpersif: " << service << " did not answer (is the loop running?)\n";
    return 1;
  }
  if (!call.response.success) {
    std::cerr << "xpersif: " << call.response.message << "\n";
    return 1;
  }
  std::cout << operation << ": " << call.response.message << "\n";
  return 0;
}

int next(const std::vector<std::string>& rest) {
  xpersif::SetExperiment call;
  if (!parseExperiment(rest, 0, &call.request.experiment)) {
    std::cerr << "xpersif: next needs OBJECT SIDE OFFSET DISTANCE, e.g. next box_1 -x 0.01 0.05\n";
    return 2;
  }
  const std::string service = loop_name + "/set_next_experiment";
  if (!ros::service::call(service, call)) {
    std::cerr << "xpersif: " << service << " did not answer\n";
    return 1;
  }
  if (!call.response.success) {
    std::cerr << "xpersif: " << call.response.message << "\n";
    return 1;
  }
  std::cout << "next: " << call.response.message << "\n";
  return 0;
}

void printProgress(const xpersif::RunLoopFeedback& p) {
  std::cout << "[" << p.state << "] experiment " << p.experiment << ", surprise " << std::fixed << std::setprecision(4)
            << p.surprise << " m: " << p.last << std::endl;
}

int progress() {
  ros::NodeHandle nh;
  bool got = false;
  auto sub = nh.subscribe<xpersif::RunLoopFeedback>(loop_name + "/progress", 1,
                                                    [&](const xpersif::RunLoopFeedback::ConstPtr& p) {
                                                      printProgress(*p);
                                                      got = true;
                                                    });
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(3.0);
  while (!got && ros::WallTime::now() < end) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
  if (!got) std::cerr << "xpersif: no progress from " << loop_name << "\n";
  return got ? 0 : 1;
}

volatile std::sig_atomic_t interrupted = 0;

/// The plan file's experiments (one per line: OBJECT SIDE OFFSET DISTANCE; '#' comments) appended to the goal:
/// kExitOk, or kExitUsage after the sentence has been printed.
int readPlanFile(const std::string& file, xpersif::RunLoopGoal& goal) {
  std::ifstream in(file);
  if (!in) {
    std::cerr << "xpersif: cannot read the plan file " << file << "\n";
    return xpersif::core::kExitUsage;
  }
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    std::istringstream fields(line);
    std::vector<std::string> parts{std::istream_iterator<std::string>(fields), {}};
    if (parts.empty() || parts[0][0] == '#') continue;
    xpersif::Experiment e;
    if (!parseExperiment(parts, 0, &e)) {
      std::cerr << "xpersif: " << file << ":" << number
                << ": expected OBJECT SIDE OFFSET DISTANCE (offset and distance finite numbers)\n";
      return xpersif::core::kExitUsage;
    }
    goal.plan.push_back(e);
  }
  return xpersif::core::kExitOk;
}

int runLoop(xpersif::RunLoopGoal goal) {
  actionlib::SimpleActionClient<xpersif::RunLoopAction> client(loop_name + "/run", true);
  if (!client.waitForServer(ros::Duration(30.0))) {
    std::cerr << "xpersif: " << loop_name << "/run is not offered (is the loop running?)\n";
    return 1;
  }
  std::signal(SIGINT, [](int) { interrupted = 1; });
  // A run whose LOOPMODEL died and came back goes on (resumed); one whose master or LOOPMODEL stays gone ends
  // with a sentence instead of waiting for ever.
  bool said_cancel = false;
  xpersif::RunDriver driver(client, loop_name + "/run", [](const std::string& s) { std::cout << "xpersif: " << s << std::endl; });
  const xpersif::RunDriver::Outcome outcome = driver.run(
      goal, [](const xpersif::RunLoopFeedbackConstPtr& p) { printProgress(*p); },
      [&] {
        if (interrupted && !said_cancel) {
          std::cout << "xpersif: cancelling the run (it can be resumed with --resume)" << std::endl;
          said_cancel = true;
        }
        return interrupted != 0;
      },
      {});
  if (!outcome.ended) {
    std::cerr << "xpersif: " << outcome.problem << "\n";
    return 1;
  }
  const auto& state = outcome.state;
  const auto& result = outcome.result;
  std::cout << "run " << (result ? result->run_id : 0) << ": " << state.toString() << ": " << state.getText() << "\n";
  if (state == actionlib::SimpleClientGoalState::SUCCEEDED) return xpersif::core::kExitOk;
  if (result && result->code == xpersif::RunLoopResult::REPEATING_CAUSE) return xpersif::core::kExitRepeatingCause;
  return xpersif::core::kExitFailed;
}

}  // namespace

/// The world file as the loop will see it, ROS-free: what XPERSim builds from it, the catalogue the components
/// read, and whether the cameras can tell every object apart.
int checkWorld(const std::string& file) {
  try {
    const xpersif::core::WorldSpec spec = xpersif::core::loadWorldFile(file);
    const xpersif::core::PhysicsWorld world(spec);
    const xpersif::core::SetupCatalogue catalogue = xpersif::core::SetupCatalogue::fromScene(world.scene());
    const xpersif::core::PerceptionCatalogue seen = xpersif::core::PerceptionCatalogue::fromScene(world.scene());
    const std::string alike = xpersif::core::checkDistinguishable(seen);
    if (!alike.empty()) throw xpersif::core::ValidationError(file + ": " + alike);
    std::cout << file << ": " << spec.name << ", arena " << catalogue.arena_size_x << " x " << catalogue.arena_size_y
              << " m, robot '" << spec.robot.name << "' of radius " << catalogue.robot_radius << " m\n";
    const auto& fiducial = spec.robot.fiducial;
    if (!fiducial.automatic_reason.empty()) {
      std::cout << "  the robot carries an ArUco fiducial (" << fiducial.dictionary << ", id " << fiducial.id << ", "
                << fiducial.size << " m) that XPERSim puts on its top, as the overhead camera could not find it by "
                << "its own colours: " << fiducial.automatic_reason << " (robot.fiducial in the world file chooses one)\n";
    }
    for (const auto& o : catalogue.objects) {
      std::cout << "  " << o.name << ": " << o.footprint.describe() << ", " << o.height << " m high, offsets up to "
                << xpersif::core::maxPushOffset(o.footprint, "-x") << " (-x/+x) and "
                << xpersif::core::maxPushOffset(o.footprint, "-y") << " (-y/+y) m\n";
    }
    std::cout << "  pushes of " << catalogue.minPushDistance() << " to " << catalogue.maxPushDistance()
              << " m; tidying keeps objects " << catalogue.wallMargin() << " m from the walls and "
              << catalogue.objectSpacing() << " m apart\n";
    // The start scene through the cameras, with the loop's FEATUREEXTRACTION: the run this world would have.
    const xpersif::core::PerceptionCheck perceived =
        xpersif::core::checkPerception(world.scene(), world.dynamicTransforms());
    std::cout << "  the cameras at the start:\n" << perceived.describe();
    const std::string problem = perceived.problem();
    if (!problem.empty()) throw xpersif::core::ValidationError(file + ": the loop could not run: " + problem);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "xpersif: " << e.what() << "\n";
    return xpersif::core::kExitBadInput;
  }
}

/// The package's file @p relative (e.g. urdf/khepera.urdf): an install space's (lib/xpersif/ -> share/xpersif/),
/// else the source tree's this was built from.
std::string packageFile(const std::string& relative) {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto installed = exe.parent_path().parent_path().parent_path() / "share" / "xpersif" / relative;
    if (std::filesystem::exists(installed, ec)) return installed.string();
  }
  return std::string(XPERSIF_SOURCE_DIR) + "/" + relative;
}

/// How a generated world names its robot's URDF: package://xpersif/urdf/khepera.urdf when ROS_PACKAGE_PATH finds
/// that file (the world then loads wherever it is copied), else its path relative to FILE (absolute on stdout).
std::string generatedRobotUrdf(const std::string& out) {
  namespace fs = std::filesystem;
  const fs::path urdf = fs::absolute(packageFile("urdf/khepera.urdf")).lexically_normal();
  const std::string uri = "package://xpersif/urdf/khepera.urdf";
  try {
    std::error_code ec;
    if (fs::equivalent(xpersif::core::resolvePackageUri(uri, xpersif::core::rosPackagePath()), urdf, ec)) return uri;
  } catch (const std::invalid_argument&) {
    // not on ROS_PACKAGE_PATH: a path it is
  }
  if (out.empty()) return urdf.string();
  return urdf.lexically_relative(fs::absolute(out).parent_path()).string();
}

/// `xpersif generate-world`: a world drawn from a seed (core::generateWorld), checked as check-world checks it, into
/// FILE or onto stdout.
int generateWorldFile(xpersif::core::WorldGeneratorOptions options, const std::string& out) {
  namespace fs = std::filesystem;
  const fs::path dir = out.empty() ? fs::current_path() : fs::absolute(out).parent_path();
  options.robot_urdf = generatedRobotUrdf(out);
  std::string text;
  try {
    text = xpersif::core::generateWorld(options);
  } catch (const std::invalid_argument& e) {
    std::cerr << "xpersif: generate-world: " << e.what() << "\n";
    return xpersif::core::kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << "xpersif: " << e.what() << "\n";
    return xpersif::core::kExitFailed;
  }
  try {  // the same checks as check-world: a generated world the loop could not run is a bug, said as one
    const xpersif::core::PhysicsWorld world(xpersif::core::parseWorld(text, dir.string(), "the generated world"));
    std::string problem = xpersif::core::checkDistinguishable(
        xpersif::core::PerceptionCatalogue::fromScene(world.scene()));
    if (problem.empty()) problem = xpersif::core::checkPerception(world.scene(), world.dynamicTransforms()).problem();
    if (!problem.empty()) throw std::runtime_error(problem);
  } catch (const std::exception& e) {
    std::cerr << "xpersif: generate-world: the world drawn from seed " << options.seed << " fails its check: "
              << e.what() << "\n";
    return xpersif::core::kExitFailed;
  }
  if (out.empty()) {
    std::cout << text;
    return xpersif::core::kExitOk;
  }
  if (const std::string why = xpersif::core::checkWritableDirectory("output directory", dir.string()); !why.empty()) {
    std::cerr << "xpersif: generate-world: " << why << "\n";
    return xpersif::core::kExitOutput;
  }
  std::ofstream file(out);
  file << text;
  if (!file.flush()) {
    std::cerr << "xpersif: generate-world: cannot write " << out << "\n";
    return xpersif::core::kExitOutput;
  }
  std::cout << "xpersif: wrote " << fs::absolute(out).string() << " (" << options.objects << " objects, seed "
            << options.seed << ")\n";
  return xpersif::core::kExitOk;
}

/// `xpersif rerun`: experiment.launch pointed at the stored experiment, on the master of ROS_MASTER_URI (started
/// by roslaunch when none runs there). The outcome is the runner's status file, since roslaunch exits 0 anyway.
int rerun(std::string old_dir, std::string new_dir, const std::vector<std::string>& overrides) {
  // Absolute: the runner works in another directory.
  old_dir = std::filesystem::absolute(old_dir).lexically_normal().string();
  while (old_dir.size() > 1 && old_dir.back() == '/') old_dir.pop_back();
  if (!new_dir.empty()) new_dir = std::filesystem::absolute(new_dir).lexically_normal().string();
  const std::string experiment = old_dir + "/experiment.yaml";
  if (!std::ifstream(experiment)) {
    std::cerr << "xpersif: " << old_dir << " holds no experiment.yaml (was it run from an experiment file?)\n";
    return 2;
  }
  if (new_dir.empty()) {
    char stamp[32];
    const std::time_t now = std::time(nullptr);
    std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::localtime(&now));
    new_dir = old_dir + "-rerun-" + stamp;
  }
  std::string joined;
  for (const auto& o : overrides) joined += (joined.empty() ? "" : " ") + o;
  const char* master = std::getenv("ROS_MASTER_URI");
  const std::string uri = master ? master : "";
  const std::string port = uri.substr(uri.rfind(':') + 1);
  std::vector<std::string> args = {"roslaunch"};
  if (!port.empty() && uri.rfind(':') != std::string::npos) args.insert(args.end(), {"-p", port});
  args.insert(args.end(), {"xpersif", "experiment.launch", "experiment:=" + experiment, "run_dir:=" + new_dir,
                           "overrides:=" + joined});
  std::cout << "xpersif: repeating " << experiment << " into " << new_dir << std::endl;
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execvp(argv[0], argv.data());
    std::perror("xpersif: roslaunch");
    ::_exit(127);
  }
  if (pid < 0) return 1;
  std::signal(SIGINT, SIG_IGN);  // Ctrl-C reaches roslaunch, which stops the experiment; we wait for it
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return 2;  // the check refused the file: nothing started
  std::ifstream outcome(new_dir + "/status");
  int code = 1;
  std::string sentence;
  if (!(outcome >> code)) {
    std::cerr << "xpersif: the rerun ended without an outcome in " << new_dir << "/status\n";
    return 1;
  }
  std::getline(outcome, sentence);
  std::cout << "xpersif: rerun:" << sentence << "\n";
  return code;
}

namespace {

/// What the command line asked for: the subcommand and its arguments, checked before anything talks to ROS.
struct Request {
  CLI::App* command = nullptr;
  double timeout = -1;  // s; -1: the command's default
  std::vector<std::string> components;  // wait
  std::string component, contract;      // transitions, contracts
  std::string file;                     // check-world, generate-world --out
  xpersif::core::WorldGeneratorOptions world;  // generate-world
  std::string run_dir, new_run_dir;     // rerun
  std::vector<std::string> overrides;   // rerun KEY=VALUE
  xpersif::RunLoopGoal goal;            // run
  std::string plan;                     // run --plan
  std::vector<std::string> experiment;  // next OBJECT SIDE OFFSET DISTANCE
};

void addCommands(CLI::App& app, Request& r) {
  app.require_subcommand(1, 1);
  app.fallthrough();  // --timeout and --loop also after the command
  app.add_option("--timeout", r.timeout, "seconds to wait (default 3 for status, 60 for wait)")
      ->check(xpersif::tools::finiteNumber(1e-3, 1e6));
  app.add_option("--loop", loop_name, "LOOPMODEL's node")->capture_default_str();
  app.add_subcommand("status", "show every component's state, health, heartbeat and parts");
  app.add_subcommand("wait", "wait until the components (and all their parts) are ACTIVE; exit 1 with the reason "
                             "when they are not within the timeout")
      ->add_option("COMPONENT", r.components, "node names such as /loop/supervisor")
      ->required();
  for (const char* verb : {"configure", "activate", "deactivate", "shutdown"}) {
    app.add_subcommand(verb, std::string("ask a component to ") + verb)
        ->add_option("COMPONENT", r.component, "a node name such as /xpersif/xpersim")
        ->required();
  }
  auto* contracts = app.add_subcommand("contracts", "show the preconditions and effects of a component's commands "
                                                    "and operations");
  contracts->add_option("COMPONENT", r.component, "a node name such as /xpersif/manipulation")->required();
  contracts->add_option("NAME", r.contract, "only this command or operation");
  app.add_subcommand("check-world", "check a world file without ROS: what the loop will be told about its objects "
                                    "and the limits derived from them; exit 3 with the reason")
      ->add_option("FILE", r.file, "the world file")
      ->required();
  auto* generate = app.add_subcommand("generate-world", "write a world drawn from a seed: an arena and objects in "
                                                       "roles (light, elongated, immovable, redrawn), checked as "
                                                       "check-world checks it (doc/worlds.md)");
  generate->add_option("--seed", r.world.seed, "the seed: the same seed gives the same world")
      ->check(xpersif::tools::wholeNumber(0, UINT32_MAX))
      ->required();
  generate->add_option("--objects", r.world.objects, "how many objects")
      ->check(xpersif::tools::wholeNumber(1, 8))
      ->capture_default_str();
  generate->add_option_function<std::string>(
      "--roles",
      [&r](const std::string& value) {
        std::stringstream in(value);
        for (std::string role; std::getline(in, role, ',');) {
          if (!role.empty()) r.world.roles.push_back(role);
        }
        if (r.world.roles.empty()) throw CLI::ValidationError("--roles", "names no role");
      },
      "the roles objects are drawn from, comma-separated (default: all four, each once while there are objects)");
  generate->add_option("--out", r.file, "the world file to write (default: standard output)");
  auto* rerun = app.add_subcommand("rerun", "repeat the experiment of a run directory from what it stored, through "
                                            "`roslaunch xpersif experiment.launch`; exit status: the experiment's");
  rerun->add_option("RUN_DIR", r.run_dir, "a run directory of an experiment file's run")->required();
  rerun->add_option("KEY=VALUE", r.overrides, "keys of the stored experiment to change");
  rerun->add_option("--run-dir", r.new_run_dir, "where the rerun goes (default RUN_DIR-rerun-<time>)");
  auto* run = app.add_subcommand("run", "start a run of the loop and follow it to the end (Ctrl-C cancels it)");
  r.goal.experiments = 20;
  r.goal.goals = 5;
  r.goal.design = "curiosity";
  r.goal.seed = 1;
  run->add_option("NAME", r.goal.name, "the run's name in the knowledge base")->required();
  run->add_option("--experiments", r.goal.experiments, "experiments to design and run")
      ->check(xpersif::tools::wholeNumber(0, UINT32_MAX))
      ->capture_default_str();
  run->add_option("--goals", r.goal.goals, "goals to reach afterwards")
      ->check(xpersif::tools::wholeNumber(0, UINT32_MAX))
      ->capture_default_str();
  run->add_option("--design", r.goal.design, "curiosity, random, grid or another design plugin")->capture_default_str();
  run->add_option("--seed", r.goal.seed, "the run's seed")->check(xpersif::tools::wholeNumber())->capture_default_str();
  run->add_flag("--resume", r.goal.resume, "continue the latest unfinished run of NAME");
  run->add_flag("--confirm-each", r.goal.confirm_each, "wait for `xpersif confirm` before every step");
  run->add_option("--plan", r.plan, "a file of pre-planned experiments, one per line: OBJECT SIDE OFFSET DISTANCE");
  for (const char* verb : {"pause", "resume", "stop", "confirm"}) {
    app.add_subcommand(verb, std::string("sliding autonomy: ") + verb + " the running loop");
  }
  app.add_subcommand("next", "run this experiment next instead of the designed one: OBJECT SIDE OFFSET DISTANCE, "
                             "e.g. next red_cube -x 0.01 0.05")
      ->add_option("OBJECT SIDE OFFSET DISTANCE", r.experiment, "the experiment (SIDE: -x, +x, -y or +y)")
      ->expected(1, 8);
  app.add_subcommand("progress", "the loop's state and its last experiment");
}

/// The request's remaining checks (those that read files or need all its words): kExitOk, or the exit code after
/// the sentence.
int checkRequest(Request& r) {
  const std::string name = r.command->get_name();
  if (name == "run" && !r.plan.empty()) return readPlanFile(r.plan, r.goal);
  if (name == "next") {
    xpersif::Experiment e;
    if (r.experiment.size() != 4 || !parseExperiment(r.experiment, 0, &e)) {
      std::string given;
      for (const auto& word : r.experiment) given += (given.empty() ? "" : " ") + word;
      std::cerr << "xpersif: next needs OBJECT SIDE OFFSET DISTANCE, e.g. next box_1 -x 0.01 0.05 (finite numbers), "
                << "not '" << given << "'\n"
                << r.command->help();
      return xpersif::core::kExitUsage;
    }
  }
  return xpersif::core::kExitOk;
}

/// Runs a command that talks to the running system.
int runOnSystem(int argc, char** argv, Request& r) {
  const std::string command = r.command->get_name();
  ros::init(argc, argv, "xpersif_console", ros::init_options::AnonymousName | ros::init_options::NoSigintHandler);
  if (command == "wait") {
    // The system may still be starting: give the master the same time as the components.
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(r.timeout > 0 ? r.timeout : 60.0);
    while (!ros::master::check() && ros::WallTime::now() < end) ros::WallDuration(0.2).sleep();
  }
  if (!ros::master::check()) {
    std::cerr << "xpersif: no ROS master at " << ros::master::getURI() << " (start the system first)\n";
    return xpersif::core::kExitFailed;
  }
  // Keep the node up for the whole command: the helpers' short-lived NodeHandles would otherwise
  // shut it down when the first of them goes away.
  ros::start();
  if (command == "status") {
    printStatus(collectStatus(r.timeout > 0 ? r.timeout : 3.0));
    return xpersif::core::kExitOk;
  }
  if (command == "wait") return waitActive(r.components, r.timeout > 0 ? r.timeout : 60.0);
  if (command == "contracts") return contracts(r.component, r.contract);
  if (command == "run") {
    ros::AsyncSpinner spinner(1);
    spinner.start();
    return runLoop(r.goal);
  }
  if (command == "next") return next(r.experiment);
  if (command == "progress") return progress();
  if (command == "pause" || command == "resume" || command == "stop" || command == "confirm") return trigger(command);
  return transition(command, r.component);  // configure, activate, deactivate, shutdown
}

}  // namespace

/// The command line with "--" after `next`: its SIDE (-x, +x, -y, +y) and a negative OFFSET are words of the
/// experiment, not options.
std::vector<std::string> wordsOf(int argc, char** argv) {
  std::vector<std::string> words(argv, argv + argc);
  for (std::size_t i = 1; i < words.size(); ++i) {
    if (words[i] == "--timeout" || words[i] == "--loop") {
      ++i;  // its value
    } else if (words[i].empty() || words[i][0] != '-') {
      const bool help = i + 1 < words.size() && (words[i + 1] == "-h" || words[i + 1] == "--help");
      if (words[i] == "next" && !help) words.insert(words.begin() + static_cast<long>(i) + 1, "--");
      break;  // the command
    }
  }
  return words;
}

int main(int argc, char** argv) {
  CLI::App app("The console client of a running XPERSIF system (doc/console.md); check-world, generate-world and "
               "rerun work without one.",
               "xpersif");
  xpersif::tools::describe(app, xpersif::tools::exitCodes("done", "the command failed or the system did not answer") +
                                    " `run` and `rerun` exit with the run's outcome (0 done; 5 it stopped on a cause that "
                                    "fails every experiment, e.g. the loop cannot perceive).");
  Request request;
  addCommands(app, request);
  if (const auto done = xpersif::tools::parse(app, wordsOf(argc, argv))) return *done;
  request.command = app.get_subcommands().front();
  // Arguments are checked before anything talks to ROS: a typo is a usage error whether or not a system runs.
  if (const int code = checkRequest(request); code != xpersif::core::kExitOk) return code;
  const std::string command = request.command->get_name();
  if (command == "check-world") return checkWorld(request.file);
  if (command == "generate-world") return generateWorldFile(request.world, request.file);
  if (command == "rerun") return rerun(request.run_dir, request.new_run_dir, request.overrides);
  return runOnSystem(argc, argv, request);
}
