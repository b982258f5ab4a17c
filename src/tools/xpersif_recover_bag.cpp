// xpersif_recover_bag: reindex bags left '.active' (unindexed) by a killed recorder; say what was kept.
// Exit codes as every tool of the package (core/command_line.h, doc/exit-codes.md).
#include <filesystem>
#include <iomanip>
#include <iostream>

#include "xpersif/core/common/command_line.h"
#include "xpersif/traces/bag_tools.h"
#include "tool_command_line.h"

using namespace xpersif::core;

int main(int argc, char** argv) {
  std::vector<std::string> bags;
  CLI::App app("Reindexes bags a killed recorder left unindexed (BAG.bag.active) with `rosbag reindex`: writes BAG.bag "
               "and keeps the original as BAG.bag.active.orig; says what was kept (doc/traces.md).",
               "xpersif_recover_bag");
  xpersif::tools::describe(app, xpersif::tools::exitCodes("all recovered", "") +
                                    " A bag that is missing or cannot be recovered exits 3, its directory not writable 4.");
  app.add_option("BAG", bags, "the bags to recover (BAG.bag.active)")->required();
  if (const auto done = xpersif::tools::parse(app, argc, argv)) return *done;
  int rc = kExitOk;
  for (const std::string& bag : bags) {
    if (const std::string why = checkReadableFile("bag", bag); !why.empty()) {
      std::cerr << "xpersif_recover_bag: " << why << "\n";
      rc = std::max(rc, kExitBadInput);
      continue;
    }
    const std::string dir = std::filesystem::path(bag).parent_path().string();
    if (const std::string why = checkWritableDirectory("the bag's directory", dir.empty() ? "." : dir); !why.empty()) {
      std::cerr << "xpersif_recover_bag: cannot recover " << bag << ": " << why << "\n";
      rc = std::max(rc, kExitOutput);
      continue;
    }
    try {
      const auto r = xpersif::traces::recoverBag(bag);
      std::cout << "recovered " << bag << " -> " << r.recovered << ": kept " << r.messages << " messages";
      if (r.messages > 0) std::cout << std::fixed << std::setprecision(3) << " from t=" << r.start << " to " << r.end
                                    << " s (" << (r.end - r.start) << " s)";
      std::cout << ", " << r.recovered_bytes << " of " << r.original_bytes << " bytes; original kept as " << r.backup
                << "\n";
      for (const auto& [topic, n] : r.per_topic) std::cout << "  " << topic << ": " << n << "\n";
    } catch (const std::exception& e) {
      std::cerr << "xpersif_recover_bag: " << e.what() << "\n";
      rc = std::max(rc, kExitBadInput);
    }
  }
  return rc;
}
