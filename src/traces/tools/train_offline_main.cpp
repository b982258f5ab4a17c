// xpersif_train_offline: MACHINELEARNING's PushLearner trained from recorded bags (see offline_learning.h).
#include <fstream>
#include <iostream>
#include <sstream>

#include "xpersif/traces/offline_learning.h"

namespace {
std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}
}  // namespace

int main(int argc, char** argv) {
  xpersif::core::PushLearnerConfig config;
  std::string out;
  std::uint64_t run_id = 0;
  std::vector<std::string> inputs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "-o" && has_value) out = argv[++i];
    else if (a == "--features" && has_value) config.feature_names = split(argv[++i]);
    else if (a == "--one-hot" && has_value) config.one_hot_identity = true, config.identities = split(argv[++i]);
    else if (a == "--seed" && has_value) config.seed = std::stoull(argv[++i]);
    else if (a == "--run" && has_value) run_id = std::stoull(argv[++i]);
    else if (!a.empty() && a[0] == '-') {
      std::cerr << "usage: xpersif_train_offline [-o MODEL.yaml] [--features hue,size] [--one-hot id1,id2] [--seed N]\n"
                   "                             [--run RUN_ID] BAG_OR_RUN_DIR...\n"
                   "exit: 0 trained, 1 a bag is unreadable, 2 usage or bad config, 3 output not writable\n";
      return 2;
    } else inputs.push_back(a);
  }
  if (inputs.empty()) {
    std::cerr << "xpersif_train_offline: give at least one bag or run directory\n";
    return 2;
  }
  try {
    xpersif::core::PushLearner learner(config);
    const auto files = xpersif::traces::bagFiles(inputs);
    const auto report = xpersif::traces::trainFromBags(learner, files, run_id);
    std::cout << "records " << report.records << ", samples used " << report.used << ", skipped "
              << report.skipped.size() << "\n";
    for (const auto& s : report.skipped) std::cout << "  skipped " << s << "\n";
    if (!out.empty()) {
      std::ofstream f(out);
      f << learner.save();
      if (!f) {
        std::cerr << "xpersif_train_offline: cannot write '" << out << "'\n";
        return 3;
      }
      std::cout << "wrote " << out << " (" << xpersif::core::PushLearner::kFormat << ")\n";
    }
    return 0;
  } catch (const xpersif::traces::BagError& e) {
    std::cerr << "xpersif_train_offline: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "xpersif_train_offline: " << e.what() << "\n";
    return 2;
  }
}
