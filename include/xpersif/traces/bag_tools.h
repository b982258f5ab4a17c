/**
 * @file bag_tools.h
 * @brief Reading XPERSIF traces (rosbag files recorded by launch/record.launch): the list of a run's bags,
 *        its experiment records in recording order, the CSV export (schema in doc/traces.md) and the recovery
 *        of a bag whose recorder was killed.
 *
 * Every failure of a bag (missing, not a bag, truncated, unindexed, corrupt chunk, wrong message type) is a
 * BagError whose sentence names the file and what was wrong; rosbag's and roscpp's exceptions never escape.
 */
#pragma once

#include <cstddef>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "xpersif/ExperimentRecord.h"

namespace xpersif::traces {

class BagError : public std::runtime_error {
 public:
  explicit BagError(const std::string& what) : std::runtime_error(what) {}
};

/// The output could not be written (directory missing, disk full...).
class OutputError : public std::runtime_error {
 public:
  explicit OutputError(const std::string& what) : std::runtime_error(what) {}
};

constexpr const char* kExperimentsTopic = "/xpersif/knowledge_base/experiments";
/// FeatureVector topics exported to features.csv.
const std::vector<std::string>& defaultFeatureTopics();

/**
 * The bag files named by @p inputs: a file as given, a directory's `*.bag` files (not recursive). Each is
 * opened once to check it and to order them by start time (a split run's parts, several runs). A
 * `*.bag.active` file (a recording that was killed) is refused with a sentence telling to recover it first.
 * @throws BagError naming the file
 */
std::vector<std::string> bagFiles(const std::vector<std::string>& inputs);

/// A message as read: the bag it came from and its receipt time.
struct RecordedExperiment {
  std::string bag;
  double time = 0.0;  ///< receipt time (simulated seconds when /clock ran)
  xpersif::ExperimentRecord record;
};

/// Every ExperimentRecord on @p topic in the order recorded (bags in the given order, then receipt time).
/// @throws BagError naming the file (and how many messages had been read) for anything unreadable
std::vector<RecordedExperiment> readExperimentRecords(const std::vector<std::string>& files,
                                                      const std::string& topic = kExperimentsTopic);

struct ExportOptions {
  std::string out_dir = ".";
  std::string experiments_topic = kExperimentsTopic;
  bool poses = true;
  std::string frames_regex = ".*";   ///< child frames of /tf and /tf_static exported to poses.csv
  double pose_period = 0.0;          ///< s: at most one row per frame per period (0: every transform)
  bool features = false;             ///< also features.csv
  std::vector<std::string> feature_topics = defaultFeatureTopics();
};

struct ExportSummary {
  std::size_t bags = 0, experiments = 0, poses = 0, features = 0;
  std::vector<std::string> files_written;
};

/// Write experiments.csv, poses.csv (and features.csv) into options.out_dir. Tables are written to
/// temporary files and renamed at the end, so a failure leaves no half table behind.
/// @throws BagError (input), OutputError (output), std::regex_error (a bad frames_regex)
ExportSummary exportCsv(const std::vector<std::string>& files, const ExportOptions& options);

struct RecoverResult {
  std::string recovered;  ///< path of the readable bag written
  std::string backup;     ///< where the original .active file went
  std::size_t messages = 0;
  double start = 0.0, end = 0.0;  ///< s, first and last message time kept
  std::map<std::string, std::size_t> per_topic;
  std::size_t original_bytes = 0, recovered_bytes = 0;
};

/// Reindex a bag left unindexed by a killed recorder (`X.bag.active`, or any unindexed bag) with
/// `rosbag reindex`, write it as `X.bag` next to it (the original is kept as `X.bag.active.orig`), and count
/// what was kept by reading it back. @throws BagError naming the file and what went wrong
RecoverResult recoverBag(const std::string& path);

/// Messages per topic of a readable bag. @throws BagError
std::map<std::string, std::size_t> countMessages(const std::string& path);

}  // namespace xpersif::traces
