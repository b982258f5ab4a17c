// xpersif_recover_bag: reindex bags left '.active' (unindexed) by a killed recorder; say what was kept.
// Exit codes as every tool of the package (core/command_line.h, doc/exit-codes.md).
#include <filesystem>
#include <iomanip>
#include <iostream>

#include "xpersif/core/common/command_line.h"
#include "xpersif/traces/bag_tools.h"

using namespace xpersif::core;

int main(int argc, char** argv) {
  const char* usage =
      "usage: xpersif_recover_bag BAG.bag.active...\n"
      "reindexes each with `rosbag reindex`, writes BAG.bag (the original is kept as BAG.bag.active.orig)\n"
      "exit: 0 all recovered, 2 usage, 3 one is missing or could not be recovered, 4 its directory is not writable\n";
  if (argc < 2) {
    std::cerr << "xpersif_recover_bag: give at least one bag\n" << usage;
    return kExitUsage;
  }
  if (std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help") {
    std::cout << usage;
    return kExitOk;
  }
  for (int i = 1; i < argc; ++i) {
    if (argv[i][0] == '-') {
      std::cerr << "xpersif_recover_bag: unknown option " << argv[i] << "\n" << usage;
      return kExitUsage;
    }
  }
  int rc = kExitOk;
  for (int i = 1; i < argc; ++i) {
    if (const std::string why = checkReadableFile("bag", argv[i]); !why.empty()) {
      std::cerr << "xpersif_recover_bag: " << why << "\n";
      rc = std::max(rc, kExitBadInput);
      continue;
    }
    const std::string dir = std::filesystem::path(argv[i]).parent_path().string();
    if (const std::string why = checkWritableDirectory("the bag's directory", dir.empty() ? "." : dir); !why.empty()) {
      std::cerr << "xpersif_recover_bag: cannot recover " << argv[i] << ": " << why << "\n";
      rc = std::max(rc, kExitOutput);
      continue;
    }
    try {
      const auto r = xpersif::traces::recoverBag(argv[i]);
      std::cout << "recovered " << argv[i] << " -> " << r.recovered << ": kept " << r.messages << " messages";
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
