/**
 * @file experiment_failure.h
 * @brief Why an experiment failed, decided on result codes and on what the overhead camera reported (never on
 *        a sentence's wording), and the streak of consecutive experiments failing for the same cause that ends
 *        LOOPMODEL's experimentation phase early (`~max_same_failures`) instead of spending the run's budget.
 *
 * A cause is one of:
 *  - the robot not seen: the robot's pose comes from the overhead camera, and its latest feature vector before
 *    the failure listed the robot as not found (it repeats until the camera sees the robot);
 *  - the object not seen: the pushed object was among that vector's missing objects;
 *  - a refusal: a stage (plan, execution, prediction) answered with a code other than FAILED (INVALID,
 *    UNAVAILABLE, NOT_ACTIVE, PRECONDITION_FAILED): the same request is refused the same way again;
 *  - unexplained: a step tried and failed (FAILED), e.g. a push the object resisted. That depends on the
 *    experiment and need not repeat, so it never counts towards a streak, and it ends one.
 */
#pragma once

#include <cstdint>
#include <string>

namespace xpersif::core {

/// Where in an experiment it failed.
enum class ExperimentStage : std::uint8_t { None, Plan, Execution, Prediction };

/// "planning", "execution", "prediction" ("" for None).
std::string toString(ExperimentStage stage);

/// Why one experiment failed.
struct FailureCause {
  enum class Kind : std::uint8_t {
    None,           ///< the experiment was done
    Unexplained,    ///< a step tried and failed: need not repeat (never counts towards a streak)
    RobotNotSeen,   ///< the overhead camera's latest vector listed the robot as not found
    ObjectNotSeen,  ///< the pushed object was missing from the overhead camera's latest vector
    Refused,        ///< a stage answered with a code other than FAILED
  };
  Kind kind = Kind::None;
  ExperimentStage stage = ExperimentStage::None;
  std::uint8_t code = 0;  ///< the failing stage's xpersif/ResultCode value
  std::string object;     ///< the pushed object (ObjectNotSeen)

  /// Whether the same cause will fail the next experiment too (what a streak counts).
  bool repeats() const { return kind != Kind::None && kind != Kind::Unexplained; }
  bool operator==(const FailureCause& other) const {
    return kind == other.kind && stage == other.stage && code == other.code && object == other.object;
  }
  bool operator!=(const FailureCause& other) const { return !(*this == other); }
};

/// What the loop knows of one experiment, as data: which stage failed with which code, and what the overhead
/// camera's latest feature vector before the failure said.
struct FailureEvidence {
  bool failed = false;
  ExperimentStage stage = ExperimentStage::None;
  std::uint8_t code = 0;              ///< the failing stage's xpersif/ResultCode value
  bool tried_and_failed = false;      ///< that code is FAILED (the stage tried): not a refusal
  bool robot_pose_observed = false;   ///< the robot's pose comes from the overhead camera (pose_source observation)
  bool have_vector = false;           ///< a vector of the overhead camera was seen before the failure
  bool robot_found = true;            ///< in that vector
  std::string object;                 ///< the object the experiment pushed
  bool object_missing = false;        ///< it is among that vector's missing objects
};

/// The cause of the experiment @p evidence describes. The camera's evidence comes first: a robot or an object it
/// does not see fails any stage that needs it, whatever code that stage gave.
FailureCause classifyFailure(const FailureEvidence& evidence);

/// The cause in words, for the run's outcome, e.g. "the overhead camera did not find the robot in its latest
/// image (the robot's pose comes from it)". @p code_name names the code of a refusal ("UNAVAILABLE").
std::string describeCause(const FailureCause& cause, const std::string& code_name = "");

/// Consecutive experiments failing for the same cause. Thread-compatible (one run's thread).
class FailureStreak {
 public:
  /// @param limit how many consecutive experiments failing for the same cause end the phase; 0: never
  explicit FailureStreak(std::uint32_t limit = 0) : limit_(limit) {}

  /// Counts one experiment (Kind::None when it was done); true once the last `limit` experiments all failed
  /// for this cause, which then stays the streak's cause until reset().
  bool add(const FailureCause& cause);
  /// How many consecutive experiments failed for cause() (0 after a success or an unexplained failure).
  std::uint32_t length() const { return length_; }
  const FailureCause& cause() const { return cause_; }
  std::uint32_t limit() const { return limit_; }
  void reset() {
    length_ = 0;
    cause_ = FailureCause();
  }

 private:
  std::uint32_t limit_;
  std::uint32_t length_ = 0;
  FailureCause cause_;
};

}  // namespace xpersif::core
