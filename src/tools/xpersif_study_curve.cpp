// xpersif_study_curve: one study cell's learning curve on the study's held-out evaluation set, from the knowledge
// bases alone (ROS-free; scripts/study.py calls it for every finished cell).
//
//   xpersif_study_curve --evaluation-database FILE [--evaluation-run NAME] --database FILE --run NAME
//                       --out DIR [--every K] [--learner shared|per_object]
//
// The evaluation set is the successful experiments of run NAME (default "evaluation") of the evaluation database:
// the same pushes for every design and seed of a study. The cell's model after k experiments is MACHINELEARNING's
// learner, configured as MACHINELEARNING configures it (evaluation.h), trained on the run's first k successful
// designed experiments; its RMS error on the evaluation set (m) for k = 0, K, 2K, ... and the last k goes to
// DIR/curve.csv (experiments,error), and per object of the evaluation set to DIR/curve_objects.csv
// (experiments,object,error,pushes), and the model's competence at one-push goals per object to DIR/curve_goals.csv
// (experiments,object,goal_error,random_choice,best_choice; core::oneShotGoalErrors). `--learner per_object` trains one model per object instead, each on that
// object's pushes alone (core::LearnerScope; bench/loop.md compares the two on a study's knowledge bases). DIR/notions.csv gets the run's notions (subject,predicate,confidence,
// support,text), DIR/experiments.csv every designed experiment of the run in order (seq,object,side,offset,
// distance,status,surprise). Exit codes: --help.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "xpersif/core/common/command_line.h"
#include "xpersif/core/evaluation/evaluation.h"
#include "tool_command_line.h"

using namespace xpersif::core;

namespace {

/// The latest run called @p name.
RunInfo latestRun(KnowledgeBase& kb, const std::string& name, const std::string& database) {
  std::map<std::string, RunInfo> latest;
  for (const auto& run : kb.runs()) latest[run.name] = run;
  const auto it = latest.find(name);
  if (it == latest.end()) throw std::runtime_error("the knowledge base " + database + " has no run called '" + name + "'");
  return it->second;
}

std::string csvText(const std::string& text) {
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

int main(int argc, char** argv) {
  std::string evaluation_database, evaluation_run = "evaluation", database, run_name, out;
  int every = 1;
  std::string learner = "shared";
  CLI::App app("One study cell's learning curve on the study's evaluation set, from the knowledge bases alone "
               "(scripts/study.py calls it for every finished cell): DIR/curve.csv, notions.csv, experiments.csv.",
               "xpersif_study_curve");
  xpersif::tools::describe(app, xpersif::tools::exitCodes("written", "a run is missing or the evaluation set is empty"));
  app.add_option("--evaluation-database", evaluation_database, "the knowledge base holding the evaluation run")
      ->required();
  app.add_option("--evaluation-run", evaluation_run, "the evaluation run's name")->capture_default_str();
  app.add_option("--database", database, "the cell's knowledge base")->required();
  app.add_option("--run", run_name, "the cell's run")->required();
  app.add_option("--out", out, "where the CSV files go")->required();
  app.add_option("--every", every, "a point every K experiments (and the last)")
      ->check(xpersif::tools::wholeNumber(1, 1000000))
      ->capture_default_str();
  app.add_option("--learner", learner, "one model for every object, or one per object")
      ->check(CLI::IsMember({"shared", "per_object"}))
      ->capture_default_str();
  if (const auto done = xpersif::tools::parse(app, argc, argv)) return *done;
  // Never create a knowledge base where none is (KnowledgeBase::open would).
  for (const auto* path : {&evaluation_database, &database}) {
    if (const std::string why = checkReadableFile("knowledge base", *path); !why.empty()) {
      std::cerr << "xpersif_study_curve: " << why << "\n";
      return kExitBadInput;
    }
  }
  if (const std::string why = checkWritableDirectory("output directory", out); !why.empty()) {
    std::cerr << "xpersif_study_curve: " << why << "\n";
    return kExitOutput;
  }
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) {
    std::cerr << "xpersif_study_curve: output directory " << out << " cannot be created: " << ec.message() << "\n";
    return kExitOutput;
  }
  try {
    auto eval_kb = KnowledgeBase::open(evaluation_database);
    const auto evaluation_records = eval_kb->experiments(latestRun(*eval_kb, evaluation_run, evaluation_database).id, "done");
    const std::vector<std::string> identities = sceneIdentities(evaluation_records);
    const auto evaluation = pushSamples(evaluation_records);
    if (evaluation.empty()) {
      throw std::runtime_error("run '" + evaluation_run + "' of " + evaluation_database +
                               " has no successful experiment to evaluate on");
    }
    auto kb = KnowledgeBase::open(database);
    const RunInfo run = latestRun(*kb, run_name, database);
    const long n = designedCount(run.parameters_json);
    std::vector<ExperimentRecord> designed;
    std::ofstream experiments(out + "/experiments.csv");
    experiments << "seq,object,side,offset,distance,status,surprise\n" << std::setprecision(9);
    for (const auto& r : kb->experiments(run.id)) {
      if (n >= 0 && r.seq > n) continue;  // the goal-directed pushes that follow the designed ones
      experiments << r.seq << "," << r.experiment.object << "," << r.experiment.side << "," << r.experiment.offset << ","
                  << r.experiment.distance << "," << r.status << "," << (r.surprise ? std::to_string(*r.surprise) : "")
                  << "\n";
      if (r.status == "done") designed.push_back(r);
    }
    const auto training = pushSamples(designed);
    std::vector<int> checkpoints;
    for (int k = 0; k <= static_cast<int>(training.size()); k += every) checkpoints.push_back(k);
    if (checkpoints.back() != static_cast<int>(training.size())) checkpoints.push_back(static_cast<int>(training.size()));
    const LearningCurve curve = learningCurve(run_name, training, evaluation, loopLearnerConfig(identities), checkpoints,
                                              learner == "per_object" ? LearnerScope::PerObject : LearnerScope::Shared);
    std::ofstream csv(out + "/curve.csv");
    csv << "experiments,error\n" << std::setprecision(9);
    for (std::size_t i = 0; i < curve.experiments.size(); ++i) csv << curve.experiments[i] << "," << curve.error[i] << "\n";
    std::ofstream objects(out + "/curve_objects.csv");
    objects << "experiments,object,error,pushes\n" << std::setprecision(9);
    for (const auto& [object, errors] : curve.object_error) {
      for (std::size_t i = 0; i < errors.size(); ++i) {
        objects << curve.experiments[i] << "," << object << "," << errors[i] << "," << curve.object_pushes.at(object) << "\n";
      }
    }
    std::ofstream goals(out + "/curve_goals.csv");
    goals << "experiments,object,goal_error,random_choice,best_choice\n" << std::setprecision(9);
    for (const auto& [object, errors] : curve.object_goal_error) {
      const auto& [random_choice, best_choice] = curve.object_goal_random_best.at(object);
      for (std::size_t i = 0; i < errors.size(); ++i) {
        goals << curve.experiments[i] << "," << object << "," << errors[i] << "," << random_choice << "," << best_choice
              << "\n";
      }
    }
    std::ofstream notions(out + "/notions.csv");
    notions << "subject,predicate,confidence,support,text\n";
    for (const auto& notion : kb->notions(run.id)) {
      notions << notion.subject << "," << notion.predicate << "," << notion.confidence << "," << notion.support << ","
              << csvText(notion.text) << "\n";
    }
    if (!csv || !objects || !goals || !notions || !experiments) throw std::runtime_error("cannot write into " + out);
    std::cout << run_name << ": " << training.size() << " experiments learned, " << evaluation.size()
              << " evaluation pushes, final error " << curve.error.back() << " m\n";
  } catch (const KnowledgeBaseError& e) {
    std::cerr << "xpersif_study_curve: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "xpersif_study_curve: " << e.what() << "\n";
    return kExitFailed;
  }
  return kExitOk;
}
