#include "xpersif/traces/offline_learning.h"

#include "xpersif/ros/experiment_conversions.h"

namespace xpersif::traces {

core::OfflineTrainingReport trainFromBags(core::PushLearner& learner, const std::vector<std::string>& files,
                                          std::uint64_t run_id, const std::string& topic) {
  std::vector<core::ExperimentRecord> records;
  for (const auto& r : readExperimentRecords(files, topic)) {
    if (run_id != 0 && r.record.run_id != run_id) continue;
    try {
      records.push_back(fromMsg(r.record));
    } catch (const std::exception& e) {
      throw BagError("bag '" + r.bag + "': experiment record run " + std::to_string(r.record.run_id) + " seq " +
                     std::to_string(r.record.seq) + " is malformed: " + e.what());
    }
  }
  return core::trainFromRecords(learner, records);
}

}  // namespace xpersif::traces
