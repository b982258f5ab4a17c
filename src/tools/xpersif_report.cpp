// xpersif_report: what a run of the default experiment learned, from the knowledge base alone. ROS-free.
//
//   xpersif_report --database FILE --out DIR [--evaluation NAME] [--designs NAME,NAME...] [--goals NAME]
//
// Writes DIR/report.md (also printed), DIR/learning_curve.csv and DIR/learning_curve.png (drawn by
// scripts/plot_learning_curve.py with matplotlib, as the study report's figures are): the prediction
// error on the evaluation run's experiments against the number of experiments learned from, for each design
// run (the latest run of each name), the designs compared on the studies' primary measure (doc/studies.md) with
// what one seed can and cannot say, the competence at one-push goals after ¼, ½ and all of the run beside a
// chooser at random and the best one, the experiments each design needed to reach the error random design ends
// with (secondary), the notions learned, and the goal-directed pushes' success.
//
// Exit codes as every tool of the package (core/command_line.h, doc/exit-codes.md): 0 written, 1 the report
// failed (a run it needs is missing), 2 usage, 3 the knowledge base is missing, unreadable or corrupt, 4 DIR
// cannot be written.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <sys/wait.h>
#include <unistd.h>

#include "xpersif/core/common/command_line.h"
#include "xpersif/core/common/contract.h"
#include "xpersif/core/evaluation/evaluation.h"
#include "xpersif/core/kb/knowledge_base.h"
#include "xpersif/core/sim/world_spec.h"
#include "tool_command_line.h"

using namespace xpersif::core;

namespace {

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

/// The items of a literal's tuple argument "(a, b)"; none for "none".
std::vector<std::string> tupleItems(const std::string& argument) {
  std::vector<std::string> items;
  if (argument.size() < 2 || argument.front() != '(') return items;
  std::stringstream in(argument.substr(1, argument.size() - 2));
  for (std::string item; std::getline(in, item, ',');) {
    const auto begin = item.find_first_not_of(' ');
    if (begin != std::string::npos) items.push_back(item.substr(begin));
  }
  return items;
}

/// FEATURESELECTION's choice in a run, from the facts its choose_features call left (doc/loop.md).
std::string featureChoice(KnowledgeBase& kb, std::int64_t run_id) {
  std::string chosen, experiments, scores;
  for (const auto& fact : kb.facts(run_id)) {
    Literal literal;
    try {
      literal = parseLiteral(fact.literal);
    } catch (const std::exception&) {
      continue;
    }
    if (literal.predicate == "features_chosen" && literal.arguments.size() == 3) {
      const auto items = tupleItems(literal.arguments[1]);
      for (const auto& item : items) chosen += (chosen.empty() ? "" : ", ") + item;
      if (items.empty()) chosen = "no feature (none helped)";
      experiments = literal.arguments[2];
    } else if (literal.predicate == "feature_scores" && literal.arguments.size() == 2) {
      for (const auto& item : tupleItems(literal.arguments[1])) {
        const auto slash = item.find('/');
        scores += (scores.empty() ? "" : ", ") +
                  (slash == std::string::npos ? item : item.substr(0, slash) + " " + item.substr(slash + 1));
      }
    }
  }
  if (chosen.empty()) return "no choice stored (MACHINELEARNING learned from its ~features)";
  return "chose " + chosen + " after its first " + experiments + " experiments" +
         (scores.empty() ? "" : "; scores (held-out error rise when shuffled, share of the variance): " + scores);
}

/// The command line's choices.
struct Options {
  std::string database, out = ".", evaluation = "evaluation", goals, world;
  std::vector<std::string> designs = {"curiosity", "random"};
};

/// The options, or an exit code when the command line is done with (help) or wrong (usage).
std::optional<int> parseArguments(int argc, char** argv, Options& options) {
  CLI::App app("What a run of an experiment learned, from the knowledge base alone: DIR/report.md (also printed), "
               "learning_curve.csv and learning_curve.png.",
               "xpersif_report");
  xpersif::tools::describe(app, xpersif::tools::exitCodes("written", "the report failed (a run it needs is missing)"));
  app.add_option("--database", options.database, "the knowledge base (knowledge.db)")->required();
  app.add_option("--out", options.out, "where the report goes")->capture_default_str();
  app.add_option("--evaluation", options.evaluation, "the run whose pushes every model is judged on")
      ->capture_default_str();
  app.add_option_function<std::string>(
         "--designs",
         [&options](const std::string& value) {
           options.designs = split(value);
           if (options.designs.empty()) throw CLI::ValidationError("--designs", "names no run");
         },
         "the design runs to compare, comma-separated")
      ->default_str("curiosity,random");
  app.add_option("--goals", options.goals, "the run whose goals are reported");
  app.add_option("--world", options.world,
                 "the world the runs ran in: objects whose friction the simulator redraws before every push are "
                 "unlearnable and left out of the designs' measure");
  return xpersif::tools::parse(app, argc, argv);
}

/// kExitOk when the knowledge base can be read and the output directory written (and now exists), else the
/// exit code, the sentence on stderr.
int checkFiles(const Options& options) {
  // Never create a knowledge base where none is (KnowledgeBase::open would).
  if (const std::string why = checkReadableFile("knowledge base", options.database); !why.empty()) {
    std::cerr << "xpersif_report: " << why << "\n";
    return kExitBadInput;
  }
  if (!options.world.empty()) {
    if (const std::string why = checkReadableFile("world file", options.world); !why.empty()) {
      std::cerr << "xpersif_report: " << why << "\n";
      return kExitBadInput;
    }
  }
  if (const std::string why = checkWritableDirectory("output directory", options.out); !why.empty()) {
    std::cerr << "xpersif_report: " << why << "\n";
    return kExitOutput;
  }
  std::error_code ec;
  std::filesystem::create_directories(options.out, ec);
  if (ec) {
    std::cerr << "xpersif_report: output directory " << options.out << " cannot be created: " << ec.message() << "\n";
    return kExitOutput;
  }
  return kExitOk;
}

/// The knowledge base's runs, the latest of each name.
class Runs {
 public:
  Runs(KnowledgeBase& kb, std::string database) : database_(std::move(database)) {
    for (const auto& run : kb.runs()) latest_[run.name] = run;
  }
  const RunInfo& operator[](const std::string& name) const {
    auto it = latest_.find(name);
    if (it == latest_.end()) throw std::runtime_error("the knowledge base " + database_ + " has no run called '" + name + "'");
    return it->second;
  }

 private:
  std::string database_;
  std::map<std::string, RunInfo> latest_;
};

/// The learning curves of the design runs on the evaluation run's pushes, and each design's failed experiments.
struct Curves {
  std::vector<LearningCurve> curves;
  std::map<std::string, int> failed;
  std::size_t evaluation_size = 0;
  std::vector<std::string> objects;      ///< the evaluation set's objects, in the order first pushed
  std::vector<std::string> moving;       ///< the learnable ones that move when pushed (core::movingObjects)
  std::vector<std::string> unlearnable;  ///< redrawn by the simulator before every push (--world)
};

/// The objects of the world file whose properties the simulator redraws: nothing the loop sees predicts them.
std::vector<std::string> unlearnableObjects(const std::string& world_file) {
  std::vector<std::string> out;
  if (world_file.empty()) return out;
  for (const auto& object : loadWorldFile(world_file).objects) {
    if (object.redrawn()) out.push_back(object.name);
  }
  return out;
}

Curves designCurves(KnowledgeBase& kb, const Runs& runs, const Options& options,
                    const std::vector<std::string>& unlearnable) {
  std::vector<std::string> identities;
  const auto evaluation_records = kb.experiments(runs[options.evaluation].id, "done");
  for (const auto& r : evaluation_records) {
    for (const auto& o : r.before.objects) {
      if (std::find(identities.begin(), identities.end(), o.name) == identities.end()) identities.push_back(o.name);
    }
  }
  // In the order the scene lists them (the world file's), as MACHINELEARNING's one-hot code has them.
  const PushLearnerConfig config = loopLearnerConfig(identities);
  const auto evaluation = pushSamples(evaluation_records);
  Curves out;
  out.evaluation_size = evaluation.size();
  out.unlearnable = unlearnable;
  for (const auto& object : movingObjects(evaluation)) {
    if (std::find(out.unlearnable.begin(), out.unlearnable.end(), object) == out.unlearnable.end()) {
      out.moving.push_back(object);
    }
  }
  for (const auto& sample : evaluation) {
    const std::string& object = sample.input.experiment.object;
    if (std::find(out.objects.begin(), out.objects.end(), object) == out.objects.end()) out.objects.push_back(object);
  }
  for (const auto& name : options.designs) {
    const RunInfo& run = runs[name];
    // Only the designed experiments (seq 1..N, N from the run's parameters), not the goal-directed pushes
    // that follow them in the same run.
    std::vector<ExperimentRecord> designed;
    const long n = designedCount(run.parameters_json);
    for (const auto& r : kb.experiments(run.id, "done")) {
      if (n < 0 || r.seq <= n) designed.push_back(r);
    }
    const auto training = pushSamples(designed);
    int& failed = out.failed[name];
    for (const auto& r : kb.experiments(run.id, "failed")) failed += n < 0 || r.seq <= n;
    std::vector<int> checkpoints;
    for (int k = 0; k <= static_cast<int>(training.size()); ++k) checkpoints.push_back(k);
    out.curves.push_back(learningCurve(name, training, evaluation, config, checkpoints));
  }
  return out;
}

/// The curves as a Markdown table (into md) and as CSV (into csv): one row per number of experiments.
void writeCurveTable(const std::vector<LearningCurve>& curves, std::ostream& md, std::ostream& csv) {
  md << "| experiments |";
  for (const auto& c : curves) md << " " << c.name << " |";
  md << "\n|---|";
  for (std::size_t i = 0; i < curves.size(); ++i) md << "---|";
  md << "\n";
  std::size_t rows = 0;
  for (const auto& c : curves) rows = std::max(rows, c.experiments.size());
  csv << "experiments";
  for (const auto& c : curves) csv << "," << c.name;
  csv << "\n";
  for (std::size_t i = 0; i < rows; ++i) {
    md << "| " << i << " |";
    csv << i;
    for (const auto& c : curves) {
      if (i < c.error.size()) {
        md << " " << std::setprecision(4) << c.error[i] << " |";
        csv << "," << std::setprecision(6) << c.error[i];
      } else {
        md << " |";
        csv << ",";
      }
    }
    md << "\n";
    csv << "\n";
  }
}

/// scripts/plot_learning_curve.py: $XPERSIF_SCRIPTS_DIR's, else an install space's (lib/xpersif/ -> share/xpersif/
/// scripts/), else the source tree's this was built from.
std::string plotScript() {
  const std::string name = "/plot_learning_curve.py";
  if (const char* dir = std::getenv("XPERSIF_SCRIPTS_DIR"); dir && *dir) return dir + name;
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto installed = exe.parent_path().parent_path().parent_path() / "share" / "xpersif" / "scripts";
    if (std::filesystem::exists(installed.string() + name, ec)) return installed.string() + name;
  }
  return XPERSIF_SCRIPTS_DIR + name;
}

/// Draws the CSV's curves into png with scripts/plot_learning_curve.py (matplotlib); "" when drawn, else why not.
std::string drawLearningCurve(const std::string& csv, const std::string& png) {
  const std::string script = plotScript();
  const pid_t pid = fork();
  if (pid < 0) return "cannot start " + script;
  if (pid == 0) {
    execl("/usr/bin/python3", "python3", script.c_str(), csv.c_str(), png.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  if (waitpid(pid, &status, 0) < 0 || !WIFEXITED(status)) return script + " did not finish";
  if (WEXITSTATUS(status) == 127) return "/usr/bin/python3 cannot run " + script;
  if (WEXITSTATUS(status) != 0) return script + " failed (exit " + std::to_string(WEXITSTATUS(status)) + ")";
  return "";
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& name : names) out += (out.empty() ? "" : ", ") + name;
  return out;
}

/// The primary measure of doc/studies.md on this run's designs, and what one seed per design can and cannot say.
void describeDesigns(const Curves& curves, std::ostream& md) {
  md << "\n## Which design did better\n\n";
  std::vector<std::string> still, unlearnable;
  auto listed = [](const std::vector<std::string>& names, const std::string& name) {
    return std::find(names.begin(), names.end(), name) != names.end();
  };
  for (const auto& object : curves.objects) {
    if (listed(curves.unlearnable, object)) unlearnable.push_back(object);
    else if (!listed(curves.moving, object)) still.push_back(object);
  }
  if (curves.moving.empty()) {
    // Say why, object by object: "nothing moved" is wrong when the objects moved but the world redraws them.
    md << "No learnable object of the evaluation set moves when pushed, so no design can be judged on it"
       << (curves.objects.empty() ? " (the evaluation set is empty)" : "")
       << (still.empty() ? "" : "; " + joined(still) + " did not move")
       << (unlearnable.empty() ? "" : "; the world redraws " + joined(unlearnable) + " before every push")
       << ".\n";
    return;
  }
  md << "Measured as studies measure it (doc/studies.md): the mean over the run of the log of the prediction error, "
        "averaged with equal weight over the learnable objects that move when pushed (" << joined(curves.moving)
     << (still.empty() ? "" : "; not counted: " + joined(still) + ", which did not move")
     << (unlearnable.empty() ? "" : "; nor " + joined(unlearnable) + ", which the world redraws before every push")
     << "). The geometric-mean error over the run, and its ratio to random design's:\n\n";
  std::map<std::string, double> area;
  for (const auto& c : curves.curves) area[c.name] = logArea(c.experiments, balancedError(c, curves.moving));
  const bool has_random = area.count("random") > 0;
  md << "| design | geometric-mean error (m) |" << (has_random ? " ratio to random |" : "") << "\n|---|---|"
     << (has_random ? "---|" : "") << "\n";
  std::string best;
  for (const auto& c : curves.curves) {
    md << "| " << c.name << " | " << std::setprecision(4) << std::exp(area[c.name]) << " |";
    if (has_random) md << " " << std::setprecision(3) << std::exp(area[c.name] - area["random"]) << " |";
    md << "\n";
    if (best.empty() || area[c.name] < area[best]) best = c.name;
  }
  md << "\nLowest in this run: " << best << ". One seed per design cannot tell a design from chance: random design "
        "on other seeds differs from itself too. Only a study over seeds with its null arm "
        "(`bash scripts/study.sh --designs random,random_null,...`, doc/studies.md) can say whether a difference "
        "is real.\n";
}

/// A number for a table cell: four decimals, or a dash where there is none.
std::string cell(double value, int precision = 4) {
  if (!std::isfinite(value)) return "—";
  std::ostringstream out;
  out << std::fixed << std::setprecision(precision) << value;
  return out.str();
}

/// Competence at one-push goals (core::oneShotGoalErrors, doc/studies.md) after a quarter, half and all of each
/// design's experiments, weighed over the same objects as the prediction error, beside two choosers that learn nothing.
void describeCompetence(const Curves& curves, std::ostream& md) {
  if (curves.moving.empty() || curves.curves.empty() || curves.curves.front().experiments.empty()) return;
  const int budget = curves.curves.front().experiments.back();
  const int at[3] = {std::max(1, (budget + 3) / 4), std::max(1, (budget + 1) / 2), budget};
  md << "\n## Competence: one-push goals\n\nFor each evaluation push's outcome as a target, the model picks the object's "
        "evaluation push it predicts closest to it; the error is how far that push's measured outcome is from the "
        "target (m), averaged over the same objects as above. Lower is better.\n\n"
     << "| design | after " << at[0] << " | after " << at[1] << " | after " << at[2] << " | ratio to random (all) |\n"
     << "|---|---|---|---|---|\n";
  std::map<std::string, std::vector<double>> goal_of;  // each design's balanced goal error, computed once
  std::map<std::string, double> at_end;
  for (const auto& c : curves.curves) {
    goal_of[c.name] = balancedGoalError(c, curves.moving);
    at_end[c.name] = valueAt(c.experiments, goal_of[c.name], at[2]);
  }
  const bool has_random = at_end.count("random") && std::isfinite(at_end["random"]) && at_end["random"] > 0;
  for (const auto& c : curves.curves) {
    const std::vector<double>& goal = goal_of[c.name];
    md << "| " << c.name;
    for (int k : at) md << " | " << cell(valueAt(c.experiments, goal, k));
    md << " | " << (has_random ? cell(at_end[c.name] / at_end["random"], 3) : "—") << " |\n";
  }
  double random_choice = 0, best_choice = 0;
  int counted = 0;
  for (const auto& object : curves.moving) {
    const auto& references = curves.curves.front().object_goal_random_best;
    if (const auto it = references.find(object); it != references.end()) {
      random_choice += it->second.first;
      best_choice += it->second.second;
      ++counted;
    }
  }
  if (counted == 0) {
    md << "\nNo object counted has two evaluation pushes, so no one-push goal can be judged (a dash).\n";
    return;
  }
  md << "\nWithout learning: picking a push at random gives " << cell(random_choice / counted)
     << " m; picking the best push the evaluation set holds, " << cell(best_choice / counted)
     << " m (the floor). A design near the first has learned little it can act on; as above, one seed per design "
        "cannot rank designs.\n";
}

/// How many experiments each design needed to reach the error random design ends with (secondary: one crossing
/// of two noisy curves; chance alone often gives "never").
void describeReach(const std::vector<LearningCurve>& curves, std::ostream& md) {
  const auto random = std::find_if(curves.begin(), curves.end(), [](const LearningCurve& c) { return c.name == "random"; });
  if (random == curves.end() || random->error.empty()) return;
  const double target = random->error.back();
  md << "\nSecondary, and as noisy as one seed makes it (where one curve first crosses the other's end point): "
        "random design ends at " << std::setprecision(4) << target << " m after " << random->experiments.back()
     << " experiments.\n";
  for (const auto& c : curves) {
    if (c.name == "random") continue;
    const int k = experimentsToReach(c, target);
    if (k < 0) {
      md << "- " << c.name << " never reaches it\n";
      continue;
    }
    md << "- " << c.name << " reaches it after " << k << " experiments";
    if (random->experiments.back() > 0) {
      md << " (" << std::setprecision(0) << 100.0 * k / random->experiments.back() << " % of random's)";
    }
    md << "\n";
  }
}

/// FEATURESELECTION's choice in each design run and in the goals' run.
void describeFeatures(KnowledgeBase& kb, const Runs& runs, const Options& options, std::ostream& md) {
  md << "\n## Features learned from (FEATURESELECTION)\n\n";
  std::vector<std::string> choice_runs = options.designs;
  if (!options.goals.empty() && std::find(choice_runs.begin(), choice_runs.end(), options.goals) == choice_runs.end()) {
    choice_runs.push_back(options.goals);
  }
  for (const auto& name : choice_runs) md << "- " << name << ": " << featureChoice(kb, runs[name].id) << "\n";
}

/// The notions of the goals' run (or the first design's when there are no goals).
void describeNotions(KnowledgeBase& kb, const Runs& runs, const Options& options, std::ostream& md) {
  const std::string notion_run = options.goals.empty() ? options.designs.front() : options.goals;
  md << "\n## Notions (run '" << notion_run << "')\n\n";
  for (const auto& n : kb.notions(runs[notion_run].id)) {
    md << "- " << n.text << " (confidence " << std::setprecision(2) << n.confidence << ", " << n.support
       << " experiments)\n";
  }
}

/// The goal-directed pushes: each goal, the success rate within the run's tolerance, the median final error.
void describeGoals(KnowledgeBase& kb, const Runs& runs, const std::string& goals_name, std::ostream& md) {
  const auto goals = kb.goals(runs[goals_name].id);
  int reached = 0;
  md << "\n## Goal-directed pushes with the learned model (run '" << goals_name << "')\n\n";
  md << "| object | target | reached | final error (m) | pushes |\n|---|---|---|---|---|\n";
  for (const auto& g : goals) {
    reached += g.reached;
    md << "| " << g.object << " | (" << std::setprecision(3) << g.target_x << ", " << g.target_y << ") | "
       << (g.reached ? "yes" : "no") << " | " << g.final_error << " | " << g.pushes_used << " |\n";
  }
  // The tolerance the run was judged by, as LOOPMODEL stored it (runs from before it was stored: 5 cm).
  const double tolerance = runParameter(runs[goals_name].parameters_json, "goal_tolerance", 0.05);
  std::vector<double> errors;
  for (const auto& g : goals) errors.push_back(g.final_error);
  md << "\nSuccess rate: " << reached << " of " << goals.size() << " goals reached within " << std::setprecision(1)
     << tolerance * 100 << " cm";
  if (!errors.empty()) {
    std::sort(errors.begin(), errors.end());
    const std::size_t n = errors.size();
    md << "; median final error " << std::setprecision(3) << 0.5 * (errors[(n - 1) / 2] + errors[n / 2]) << " m";
  }
  md << ".\n";
}

/// The whole report as Markdown; the curve's CSV and PNG are written into options.out on the way.
std::string buildReport(KnowledgeBase& kb, const Options& options, const std::vector<std::string>& unlearnable) {
  const Runs runs(kb, options.database);
  const Curves curves = designCurves(kb, runs, options, unlearnable);
  std::ostringstream md;
  md << std::fixed;
  md << "# What the robot learned\n\nKnowledge base: `" << options.database << "`\n\n";
  md << "Evaluation set: the " << curves.evaluation_size << " successful pushes of run '" << options.evaluation
     << "' (random design); each design's model after k experiments is judged on them (RMS error, m; a turn "
        "counts as the distance a point 2 cm from the centre travels).\n\n";
  const std::string csv_path = options.out + "/learning_curve.csv", png_path = options.out + "/learning_curve.png";
  {
    std::ofstream csv(csv_path);
    writeCurveTable(curves.curves, md, csv);
  }
  if (const std::string why = drawLearningCurve(csv_path, png_path); why.empty()) {
    md << "\n![learning curve](learning_curve.png)\n\n";
  } else {
    std::cerr << "xpersif_report: no learning_curve.png: " << why << "\n";
    md << "\n(No figure: " << why << ".)\n\n";
  }
  for (const auto& c : curves.curves) {
    md << "- " << c.name << ": " << curves.failed.at(c.name) << " experiments failed (not learned from)\n";
  }
  describeDesigns(curves, md);
  describeCompetence(curves, md);
  if (!curves.moving.empty()) describeReach(curves.curves, md);  // on nothing learnable it is noise alone
  describeFeatures(kb, runs, options, md);
  describeNotions(kb, runs, options, md);
  if (!options.goals.empty()) describeGoals(kb, runs, options.goals, md);
  return md.str();
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (const auto done = parseArguments(argc, argv, options)) return *done;
  if (const int code = checkFiles(options); code != kExitOk) return code;
  try {
    const auto unlearnable = unlearnableObjects(options.world);  // a bad world file is refused before any work
    auto kb = KnowledgeBase::open(options.database);
    const std::string md = buildReport(*kb, options, unlearnable);
    std::ofstream report(options.out + "/report.md");
    report << md;
    if (!report) {
      std::cerr << "xpersif_report: cannot write " << options.out << "/report.md\n";
      return kExitOutput;
    }
    std::cout << md;
  } catch (const KnowledgeBaseError& e) {
    std::cerr << "xpersif_report: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const WorldError& e) {
    std::cerr << "xpersif_report: --world: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "xpersif_report: " << e.what() << "\n";
    return kExitFailed;
  }
  return kExitOk;
}
