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
// DIR/curve.csv (experiments,error). `--learner per_object` trains one model per object instead, each on that
// object's pushes alone (core::LearnerScope; bench/loop.md compares the two on a study's knowledge bases). DIR/notions.csv gets the run's notions (subject,predicate,confidence,
// support,text), DIR/experiments.csv every designed experiment of the run in order (seq,object,side,offset,
// distance,status,surprise). Exit 0, or 1 with one sentence (a missing run, an empty evaluation set).
#include <algorithm>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "xpersif/core/evaluation/evaluation.h"

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
  for (int i = 1; i < argc; i += 2) {
    const std::string key = argv[i];
    if (i + 1 >= argc) {
      std::cerr << "xpersif_study_curve: " << key << " needs a value\n";
      return 2;
    }
    const std::string value = argv[i + 1];
    if (key == "--evaluation-database") evaluation_database = value;
    else if (key == "--evaluation-run") evaluation_run = value;
    else if (key == "--database") database = value;
    else if (key == "--run") run_name = value;
    else if (key == "--out") out = value;
    else if (key == "--every") every = std::atoi(value.c_str());
    else if (key == "--learner") learner = value;
    else {
      std::cerr << "xpersif_study_curve: unknown option " << key << "\n";
      return 2;
    }
  }
  if (evaluation_database.empty() || database.empty() || run_name.empty() || out.empty() || every < 1 ||
      (learner != "shared" && learner != "per_object")) {
    std::cerr << "usage: xpersif_study_curve --evaluation-database FILE [--evaluation-run NAME] --database FILE "
                 "--run NAME --out DIR [--every K >= 1] [--learner shared|per_object]\n";
    return 2;
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
    std::ofstream notions(out + "/notions.csv");
    notions << "subject,predicate,confidence,support,text\n";
    for (const auto& notion : kb->notions(run.id)) {
      notions << notion.subject << "," << notion.predicate << "," << notion.confidence << "," << notion.support << ","
              << csvText(notion.text) << "\n";
    }
    if (!csv || !notions || !experiments) throw std::runtime_error("cannot write into " + out);
    std::cout << run_name << ": " << training.size() << " experiments learned, " << evaluation.size()
              << " evaluation pushes, final error " << curve.error.back() << " m\n";
  } catch (const std::exception& e) {
    std::cerr << "xpersif_study_curve: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
