// xpersif_recover_bag: reindex bags left '.active' (unindexed) by a killed recorder; say what was kept.
#include <iomanip>
#include <iostream>

#include "xpersif/traces/bag_tools.h"

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help") {
    std::cerr << "usage: xpersif_recover_bag BAG.bag.active...\n"
                 "reindexes each with `rosbag reindex`, writes BAG.bag (the original is kept as BAG.bag.active.orig)\n"
                 "exit: 0 all recovered, 1 one could not be recovered, 2 usage\n";
    return 2;
  }
  int rc = 0;
  for (int i = 1; i < argc; ++i) {
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
      rc = 1;
    }
  }
  return rc;
}
