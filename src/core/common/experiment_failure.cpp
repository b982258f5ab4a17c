#include "xpersif/core/common/experiment_failure.h"

namespace xpersif::core {

std::string toString(ExperimentStage stage) {
  switch (stage) {
    case ExperimentStage::Plan: return "planning";
    case ExperimentStage::Execution: return "execution";
    case ExperimentStage::Prediction: return "prediction";
    case ExperimentStage::None: break;
  }
  return "";
}

FailureCause classifyFailure(const FailureEvidence& evidence) {
  FailureCause cause;
  if (!evidence.failed) return cause;
  cause.stage = evidence.stage;
  cause.code = evidence.code;
  // The camera's evidence only explains a failure where the experiment needed it: planning works from the
  // contracts, not from the scene.
  const bool needs_camera = evidence.stage == ExperimentStage::Execution || evidence.stage == ExperimentStage::Prediction;
  if (needs_camera && evidence.have_vector && evidence.robot_pose_observed && !evidence.robot_found) {
    cause.kind = FailureCause::Kind::RobotNotSeen;
  } else if (needs_camera && evidence.have_vector && evidence.object_missing) {
    cause.kind = FailureCause::Kind::ObjectNotSeen;
    cause.object = evidence.object;
  } else if (!evidence.tried_and_failed) {
    cause.kind = FailureCause::Kind::Refused;
  } else {
    cause.kind = FailureCause::Kind::Unexplained;
  }
  return cause;
}

std::string describeCause(const FailureCause& cause, const std::string& code_name) {
  const std::string code = code_name.empty() ? "code " + std::to_string(cause.code) : code_name;
  switch (cause.kind) {
    case FailureCause::Kind::RobotNotSeen:
      return "the overhead camera did not find the robot in its latest image (the robot's pose comes from it)";
    case FailureCause::Kind::ObjectNotSeen:
      return "the overhead camera did not find " + cause.object + " in its latest image";
    case FailureCause::Kind::Refused:
      return "the " + toString(cause.stage) + " was refused (" + code + ")";
    case FailureCause::Kind::Unexplained:
      return "the " + toString(cause.stage) + " failed (" + code + ")";
    case FailureCause::Kind::None: break;
  }
  return "no failure";
}

bool FailureStreak::add(const FailureCause& cause) {
  if (!cause.repeats()) {
    reset();
    return false;
  }
  if (length_ > 0 && cause == cause_) {
    ++length_;
  } else {
    cause_ = cause;
    length_ = 1;
  }
  return limit_ > 0 && length_ >= limit_;
}

}  // namespace xpersif::core
