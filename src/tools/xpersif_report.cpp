// xpersif_report: what a run of the default experiment learned, from the knowledge base alone. ROS-free.
//
//   xpersif_report --database FILE --out DIR [--evaluation NAME] [--designs NAME,NAME...] [--goals NAME]
//
// Writes DIR/report.md (also printed), DIR/learning_curve.csv and DIR/learning_curve.png: the prediction
// error on the evaluation run's experiments against the number of experiments learned from, for each design
// run (the latest run of each name), the experiments each design needed to reach the error random design ends
// with, the notions learned, and the goal-directed pushes' success.
//
// Exit codes as every tool of the package (core/command_line.h, doc/exit-codes.md): 0 written, 1 the report
// failed (a run it needs is missing), 2 usage, 3 the knowledge base is missing, unreadable or corrupt, 4 DIR
// cannot be written.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "xpersif/core/common/command_line.h"
#include "xpersif/core/common/contract.h"
#include "xpersif/core/evaluation/evaluation.h"
#include "xpersif/core/kb/knowledge_base.h"

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

void plot(const std::vector<LearningCurve>& curves, const std::string& path) {
  const int w = 720, h = 440, left = 70, right = 20, top = 30, bottom = 50;
  cv::Mat image(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double max_error = 0;
  int max_k = 1;
  for (const auto& c : curves) {
    for (double e : c.error) max_error = std::max(max_error, std::isfinite(e) ? e : 0.0);
    for (int k : c.experiments) max_k = std::max(max_k, k);
  }
  max_error = max_error > 0 ? max_error * 1.1 : 1;
  auto px = [&](int k) { return left + static_cast<int>((w - left - right) * k / static_cast<double>(max_k)); };
  auto py = [&](double e) { return h - bottom - static_cast<int>((h - top - bottom) * e / max_error); };
  cv::line(image, {left, h - bottom}, {w - right, h - bottom}, cv::Scalar(0, 0, 0));
  cv::line(image, {left, top}, {left, h - bottom}, cv::Scalar(0, 0, 0));
  for (int i = 0; i <= 4; ++i) {
    const double e = max_error * i / 4;
    std::ostringstream label;
    label << std::fixed << std::setprecision(3) << e;
    cv::putText(image, label.str(), {5, py(e) + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
  }
  cv::putText(image, "experiments learned from", {w / 2 - 90, h - 12}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0));
  cv::putText(image, "RMS prediction error on the evaluation pushes (m)", {left, 18}, cv::FONT_HERSHEY_SIMPLEX, 0.5,
              cv::Scalar(0, 0, 0));
  for (int k = 0; k <= max_k; k += std::max(1, max_k / 10)) {
    cv::putText(image, std::to_string(k), {px(k) - 5, h - bottom + 16}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
  }
  const std::vector<cv::Scalar> colours = {{200, 80, 0}, {0, 0, 200}, {0, 150, 0}, {150, 0, 150}};
  for (std::size_t c = 0; c < curves.size(); ++c) {
    const auto& curve = curves[c];
    const cv::Scalar colour = colours[c % colours.size()];
    for (std::size_t i = 1; i < curve.error.size(); ++i) {
      cv::line(image, {px(curve.experiments[i - 1]), py(curve.error[i - 1])}, {px(curve.experiments[i]), py(curve.error[i])},
               colour, 2, cv::LINE_AA);
    }
    cv::putText(image, curve.name, {w - right - 150, top + 20 + 18 * static_cast<int>(c)}, cv::FONT_HERSHEY_SIMPLEX,
                0.5, colour, 1, cv::LINE_AA);
  }
  cv::imwrite(path, image);
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

}  // namespace

int main(int argc, char** argv) {
  std::string database, out = ".", evaluation_name = "evaluation", goals_name;
  std::vector<std::string> designs = {"curiosity", "random"};
  const char* usage =
      "usage: xpersif_report --database FILE --out DIR [--evaluation NAME] [--designs A,B] [--goals NAME]\n"
      "exit: 0 written, 1 the report failed, 2 usage, 3 bad knowledge base, 4 DIR not writable\n";
  for (int i = 1; i < argc; i += 2) {
    const std::string key = argv[i];
    if (key == "-h" || key == "--help") {
      std::cout << usage;
      return kExitOk;
    }
    if (key != "--database" && key != "--out" && key != "--evaluation" && key != "--designs" && key != "--goals") {
      std::cerr << "xpersif_report: unknown option " << key << "\n" << usage;
      return kExitUsage;
    }
    if (i + 1 >= argc) {
      std::cerr << "xpersif_report: " << key << " needs a value\n" << usage;
      return kExitUsage;
    }
    const std::string value = argv[i + 1];
    if (key == "--database") database = value;
    else if (key == "--out") out = value;
    else if (key == "--evaluation") evaluation_name = value;
    else if (key == "--designs") designs = split(value);
    else if (key == "--goals") goals_name = value;
  }
  if (database.empty()) {
    std::cerr << "xpersif_report: give the knowledge base with --database\n" << usage;
    return kExitUsage;
  }
  if (designs.empty()) {
    std::cerr << "xpersif_report: --designs names no run\n" << usage;
    return kExitUsage;
  }
  // Never create a knowledge base where none is (KnowledgeBase::open would).
  if (const std::string why = checkReadableFile("knowledge base", database); !why.empty()) {
    std::cerr << "xpersif_report: " << why << "\n";
    return kExitBadInput;
  }
  if (const std::string why = checkWritableDirectory("output directory", out); !why.empty()) {
    std::cerr << "xpersif_report: " << why << "\n";
    return kExitOutput;
  }
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) {
    std::cerr << "xpersif_report: output directory " << out << " cannot be created: " << ec.message() << "\n";
    return kExitOutput;
  }
  try {
    auto kb = KnowledgeBase::open(database);
    std::map<std::string, RunInfo> latest;  // by name
    for (const auto& run : kb->runs()) latest[run.name] = run;
    auto need = [&](const std::string& name) -> const RunInfo& {
      auto it = latest.find(name);
      if (it == latest.end()) throw std::runtime_error("the knowledge base " + database + " has no run called '" + name + "'");
      return it->second;
    };
    std::vector<std::string> identities;
    const auto evaluation_records = kb->experiments(need(evaluation_name).id, "done");
    for (const auto& r : evaluation_records) {
      for (const auto& o : r.before.objects) {
        if (std::find(identities.begin(), identities.end(), o.name) == identities.end()) identities.push_back(o.name);
      }
    }
    // In the order the scene lists them (the world file's), as MACHINELEARNING's one-hot code has them.
    const PushLearnerConfig config = loopLearnerConfig(identities);
    const auto evaluation = pushSamples(evaluation_records);

    std::ostringstream md;
    md << std::fixed;
    md << "# What the robot learned\n\nKnowledge base: `" << database << "`\n\n";
    md << "Evaluation set: the " << evaluation.size() << " successful pushes of run '" << evaluation_name
       << "' (random design); each design's model after k experiments is judged on them (RMS error, m; a turn "
          "counts as the distance a point 2 cm from the centre travels).\n\n";
    std::vector<LearningCurve> curves;
    std::map<std::string, int> failed;
    for (const auto& name : designs) {
      const RunInfo& run = need(name);
      // Only the designed experiments (seq 1..N, N from the run's parameters), not the goal-directed pushes
      // that follow them in the same run.
      std::vector<ExperimentRecord> designed;
      const long n = designedCount(run.parameters_json);
      for (const auto& r : kb->experiments(run.id, "done")) {
        if (n < 0 || r.seq <= n) designed.push_back(r);
      }
      const auto training = pushSamples(designed);
      for (const auto& r : kb->experiments(run.id, "failed")) failed[name] += n < 0 || r.seq <= n;
      std::vector<int> checkpoints;
      for (int k = 0; k <= static_cast<int>(training.size()); ++k) checkpoints.push_back(k);
      curves.push_back(learningCurve(name, training, evaluation, config, checkpoints));
    }
    md << "| experiments |";
    for (const auto& c : curves) md << " " << c.name << " |";
    md << "\n|---|";
    for (std::size_t i = 0; i < curves.size(); ++i) md << "---|";
    md << "\n";
    std::size_t rows = 0;
    for (const auto& c : curves) rows = std::max(rows, c.experiments.size());
    std::ofstream csv(out + "/learning_curve.csv");
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
    plot(curves, out + "/learning_curve.png");
    md << "\n![learning curve](learning_curve.png)\n\n";
    for (const auto& c : curves) md << "- " << c.name << ": " << failed[c.name] << " experiments failed (not learned from)\n";
    const auto random = std::find_if(curves.begin(), curves.end(), [](const LearningCurve& c) { return c.name == "random"; });
    if (random != curves.end() && !random->error.empty()) {
      const double target = random->error.back();
      md << "\nRandom design ends at " << std::setprecision(4) << target << " m after " << random->experiments.back()
         << " experiments.\n";
      for (const auto& c : curves) {
        if (c.name == "random") continue;
        const int k = experimentsToReach(c, target);
        md << "- " << c.name << " reaches it after " << (k < 0 ? std::string("(never)") : std::to_string(k))
           << " experiments";
        if (k >= 0 && random->experiments.back() > 0) {
          md << " (" << std::setprecision(0) << 100.0 * k / random->experiments.back() << " % of random's)";
        }
        md << "\n";
      }
    }
    md << "\n## Features learned from (FEATURESELECTION)\n\n";
    std::vector<std::string> choice_runs = designs;
    if (!goals_name.empty() && std::find(designs.begin(), designs.end(), goals_name) == designs.end()) {
      choice_runs.push_back(goals_name);
    }
    for (const auto& name : choice_runs) md << "- " << name << ": " << featureChoice(*kb, need(name).id) << "\n";
    const std::string notion_run = goals_name.empty() ? designs.front() : goals_name;
    md << "\n## Notions (run '" << notion_run << "')\n\n";
    for (const auto& n : kb->notions(need(notion_run).id)) {
      md << "- " << n.text << " (confidence " << std::setprecision(2) << n.confidence << ", " << n.support
         << " experiments)\n";
    }
    if (!goals_name.empty()) {
      const auto goals = kb->goals(need(goals_name).id);
      int reached = 0;
      md << "\n## Goal-directed pushes with the learned model (run '" << goals_name << "')\n\n";
      md << "| object | target | reached | final error (m) | pushes |\n|---|---|---|---|---|\n";
      for (const auto& g : goals) {
        reached += g.reached;
        md << "| " << g.object << " | (" << std::setprecision(3) << g.target_x << ", " << g.target_y << ") | "
           << (g.reached ? "yes" : "no") << " | " << g.final_error << " | " << g.pushes_used << " |\n";
      }
      // The tolerance the run was judged by, as LOOPMODEL stored it (runs from before it was stored: 5 cm).
      const double tolerance = runParameter(need(goals_name).parameters_json, "goal_tolerance", 0.05);
      std::vector<double> errors;
      for (const auto& g : goals) errors.push_back(g.final_error);
      md << "\nSuccess rate: " << reached << " of " << goals.size() << " goals reached within "
         << std::setprecision(1) << tolerance * 100 << " cm";
      if (!errors.empty()) {
        std::sort(errors.begin(), errors.end());
        const std::size_t n = errors.size();
        md << "; median final error " << std::setprecision(3) << 0.5 * (errors[(n - 1) / 2] + errors[n / 2]) << " m";
      }
      md << ".\n";
    }
    std::ofstream report(out + "/report.md");
    report << md.str();
    if (!report) {
      std::cerr << "xpersif_report: cannot write " << out << "/report.md\n";
      return kExitOutput;
    }
    std::cout << md.str();
  } catch (const KnowledgeBaseError& e) {
    std::cerr << "xpersif_report: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "xpersif_report: " << e.what() << "\n";
    return kExitFailed;
  }
  return kExitOk;
}
