// xpersif_train_offline: MACHINELEARNING's PushLearner trained from recorded bags (see offline_learning.h).
// Exit codes as every tool of the package (core/command_line.h, doc/exit-codes.md).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "xpersif/core/common/command_line.h"
#include "xpersif/traces/offline_learning.h"

namespace {

using namespace xpersif::core;

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

const char* kUsageText =
    "usage: xpersif_train_offline [-o MODEL.yaml] [--features hue,size] [--one-hot id1,id2] [--seed N]\n"
    "                             [--run RUN_ID] BAG_OR_RUN_DIR...\n"
    "exit: 0 trained, 2 usage or bad config, 3 a bag is missing or unreadable, 4 output not writable\n";

int usage(const std::string& error) {
  std::cerr << "xpersif_train_offline: " << error << "\n" << kUsageText;
  return kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  PushLearnerConfig config;
  std::string out;
  std::uint64_t run_id = 0;
  std::vector<std::string> inputs;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw UsageError(a + " needs a value");
        return argv[++i];
      };
      if (a == "-h" || a == "--help") {
        std::cout << kUsageText;
        return kExitOk;
      } else if (a == "-o") {
        out = value();
      } else if (a == "--features") {
        config.feature_names = split(value());
      } else if (a == "--one-hot") {
        config.one_hot_identity = true;
        config.identities = split(value());
      } else if (a == "--seed") {
        config.seed = parseWholeNumber("--seed", value());
      } else if (a == "--run") {
        run_id = parseWholeNumber("--run", value(), 0, INT64_MAX);
      } else if (!a.empty() && a[0] == '-') {
        throw UsageError("unknown option " + a);
      } else {
        inputs.push_back(a);
      }
    }
  } catch (const UsageError& e) {
    return usage(e.what());
  }
  if (inputs.empty()) return usage("give at least one bag or run directory");
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
    return usage(std::string("bad learner configuration: ") + e.what());
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
