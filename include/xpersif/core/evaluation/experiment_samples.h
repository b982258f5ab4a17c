/**
 * @file experiment_samples.h
 * @brief The ONE rule that turns a recorded experiment into a PushLearner sample, shared by MACHINELEARNING's
 *        live training (a record arriving on knowledge_base/experiments) and by offline training from bags
 *        or the knowledge base, so that both give the learner the same samples in the same order and hence
 *        the same model (see push_learner.h, "Determinism").
 *
 * The rule: a record gives a sample when its status is "done", the pushed object (experiment.object) is in
 * the `before` feature vector and its outcome is set. The sample's input is the experiment and that object's
 * features from `before` (pose and every extra feature; the learner keeps those in its config: hue, size, and
 * encodes the one-hot identity from the name); its outcome is the record's (dx, dy, dyaw) as stored, not
 * recomputed. A sample the learner refuses (a feature it needs is missing, a NaN) is skipped, not fatal.
 */
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "xpersif/core/kb/knowledge_base.h"
#include "xpersif/core/learning/push_learner.h"

namespace xpersif::core {

/// The learner's sample of @p record, or nullopt, with @p why (if given) set to the sentence saying why not.
std::optional<PushSample> pushSampleOf(const ExperimentRecord& record, std::string* why = nullptr);

/// Live training step: add @p record's sample to @p learner if it gives one the learner accepts.
/// Returns true when added; otherwise false with @p why set, and the learner unchanged.
bool learnFromRecord(PushModel& learner, const ExperimentRecord& record, std::string* why = nullptr);

struct OfflineTrainingReport {
  std::size_t records = 0;  ///< records seen
  std::size_t used = 0;     ///< samples added
  std::vector<std::string> skipped;  ///< one sentence per record skipped ("record run 1 seq 4: ...")
};

/// Offline training: the same as learnFromRecord() on each record in order (the same samples, the same model),
/// but trains once (PushModel::addSamples).
OfflineTrainingReport trainFromRecords(PushModel& learner, const std::vector<ExperimentRecord>& records);

}  // namespace xpersif::core
