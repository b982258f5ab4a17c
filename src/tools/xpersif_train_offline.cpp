// xpersif_train_offline: MACHINELEARNING's PushLearner trained from recorded bags (see offline_learning.h).
// Exit codes as every tool of the package (core/command_line.h, doc/exit-codes.md).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "xpersif/core/common/command_line.h"
#include "xpersif/traces/offline_learning.h"
#include "tool_command_line.h"

namespace {

using namespace xpersif::core;

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  PushLearnerConfig config;
  std::string out;
  std::uint64_t run_id = 0;
  std::vector<std::string> inputs;
  CLI::App app("MACHINELEARNING's learner trained offline from recorded bags, as it would have learned live "
               "(doc/traces.md).",
               "xpersif_train_offline");
  xpersif::tools::describe(app, xpersif::tools::exitCodes("trained") + " A bad learner configuration exits 2.");
  app.add_option("-o", out, "write the trained model here (YAML)");
  app.add_option_function<std::string>(
      "--features", [&config](const std::string& v) { config.feature_names = split(v); },
      "the object features learned from, comma-separated (e.g. hue,size)");
  app.add_option_function<std::string>(
      "--one-hot",
      [&config](const std::string& v) {
        config.one_hot_identity = true;
        config.identities = split(v);
      },
      "learn the objects' identities one-hot, in this order (comma-separated)");
  app.add_option("--seed", config.seed, "the learner's seed")->check(xpersif::tools::wholeNumber());
  app.add_option("--run", run_id, "only this run's experiments (0: every run)")
      ->check(xpersif::tools::wholeNumber(0, INT64_MAX));
  app.add_option("BAG_OR_RUN_DIR", inputs, "bags, or run directories whose bags are read")->required();
  if (const auto done = xpersif::tools::parse(app, argc, argv)) return *done;
  for (const auto& input : inputs) {
    std::error_code ec;
    if (!std::filesystem::is_directory(input, ec)) {
      const std::string why = checkReadableFile("bag", input);
      if (!why.empty()) {
        std::cerr << "xpersif_train_offline: " << why << "\n";
        return kExitBadInput;
      }
    }
  }
  if (!out.empty()) {
    const std::string parent = std::filesystem::path(out).parent_path().string();
    const std::string why = checkWritableDirectory("the model's directory", parent.empty() ? "." : parent);
    if (!why.empty()) {
      std::cerr << "xpersif_train_offline: " << why << "\n";
      return kExitOutput;
    }
  }
  std::unique_ptr<PushLearner> learner;
  try {
    learner = std::make_unique<PushLearner>(config);
  } catch (const std::exception& e) {
    std::cerr << "xpersif_train_offline: bad learner configuration: " << e.what() << "\n" << app.help();
    return kExitUsage;
  }
  try {
    const auto files = xpersif::traces::bagFiles(inputs);
    const auto report = xpersif::traces::trainFromBags(*learner, files, run_id);
    std::cout << "records " << report.records << ", samples used " << report.used << ", skipped "
              << report.skipped.size() << "\n";
    for (const auto& s : report.skipped) std::cout << "  skipped " << s << "\n";
    if (!out.empty()) {
      std::ofstream f(out);
      f << learner->save();
      if (!f) {
        std::cerr << "xpersif_train_offline: cannot write '" << out << "'\n";
        return kExitOutput;
      }
      std::cout << "wrote " << out << " (" << PushLearner::kFormat << ")\n";
    }
    return kExitOk;
  } catch (const xpersif::traces::BagError& e) {
    std::cerr << "xpersif_train_offline: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {  // anything else a library throws: a sentence, never an abort
    std::cerr << "xpersif_train_offline: " << e.what() << "\n";
    return kExitFailed;
  }
}
