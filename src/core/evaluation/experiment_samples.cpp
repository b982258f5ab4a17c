#include "xpersif/core/evaluation/experiment_samples.h"

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

std::optional<PushSample> pushSampleOf(const ExperimentRecord& record, std::string* why) {
  auto no = [why](const std::string& reason) -> std::optional<PushSample> {
    if (why) *why = reason;
    return std::nullopt;
  };
  if (record.status != "done") return no("status is '" + record.status + "', not 'done'");
  if (!record.outcome) return no("the record has no outcome");
  const ObjectFeatures* object = record.before.find(record.experiment.object);
  if (!object) return no("the pushed object '" + record.experiment.object + "' is not in the 'before' features");
  PushSample sample;
  sample.input.experiment = record.experiment;
  sample.input.object = *object;
  sample.outcome = *record.outcome;
  if (why) why->clear();
  return sample;
}

namespace {
/// The sample if the learner would accept it (the same checks as addSample), else nullopt with why.
std::optional<PushSample> acceptedSample(const PushModel& learner, const ExperimentRecord& record, std::string* why) {
  auto sample = pushSampleOf(record, why);
  if (!sample) return sample;
  try {
    learner.check(sample->input);  // validates the input against the learner's config
    requireOutcome("outcome", sample->outcome);
  } catch (const ValidationError& e) {
    if (why) *why = e.what();
    return std::nullopt;
  }
  return sample;
}
}  // namespace

bool learnFromRecord(PushModel& learner, const ExperimentRecord& record, std::string* why) {
  auto sample = acceptedSample(learner, record, why);
  if (!sample) return false;
  try {
    learner.addSample(sample->input, sample->outcome);
  } catch (const ValidationError& e) {  // e.g. the learner is full
    if (why) *why = e.what();
    return false;
  }
  return true;
}

OfflineTrainingReport trainFromRecords(PushModel& learner, const std::vector<ExperimentRecord>& records) {
  OfflineTrainingReport report;
  std::vector<PushSample> samples;
  for (const auto& record : records) {
    ++report.records;
    std::string why;
    auto sample = acceptedSample(learner, record, &why);
    if (!sample) {
      report.skipped.push_back("record run " + std::to_string(record.run_id) + " seq " + std::to_string(record.seq) +
                               ": " + why);
      continue;
    }
    samples.push_back(std::move(*sample));
  }
  learner.addSamples(samples);
  report.used = samples.size();
  return report;
}

}  // namespace xpersif::core
