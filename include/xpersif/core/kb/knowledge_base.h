/**
 * @file knowledge_base.h
 * @brief KNOWLEDGEBASE's store: runs, experiments (with their feature vectors, outcomes, predictions and
 *        surprise), learned models, notions, goals and a light audit log, in one SQLite database.
 *
 * Why SQLite: nothing committed may be lost when a process dies, and a run must be resumable. The database
 * runs in WAL mode with synchronous=FULL, so a committed transaction survives a crash of the process (and of
 * the machine); every write is one transaction, so a crash mid-write leaves nothing partial. Foreign keys
 * tie every row to its run. The schema carries its version in PRAGMA user_version and an application id, so
 * that a file of another program, or of a newer XPERSIF, is refused with a sentence instead of being
 * misread.
 *
 * Feature vectors are stored as JSON text (see toJson() in experiment.h; SQLite's JSON functions can query
 * them, e.g. `json_extract(before_json, '$.objects[0].x')`), outcomes and predictions as plain columns.
 *
 * Thread-safe: one connection per KnowledgeBase, guarded by a mutex. Several processes may open the same
 * file (SQLite's locking; the busy timeout makes writers wait for each other).
 */
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "xpersif/core/common/experiment.h"

struct sqlite3;

namespace xpersif::core {

/// The database cannot be used: not a database, a newer schema, a disk error... what() says which.
class KnowledgeBaseError : public std::runtime_error {
 public:
  explicit KnowledgeBaseError(const std::string& what) : std::runtime_error(what) {}
};

struct RunInfo {
  std::int64_t id = 0;
  std::string name;
  std::string status;            ///< "running", "finished" or "stopped"
  std::string parameters_json;   ///< the run's parameters as a JSON object (checked with json_valid)
  std::int64_t seed = 0;
  std::string design;            ///< e.g. "curiosity" or "random"
  std::string started;           ///< wall clock, ISO 8601 UTC (written by the database)
  std::string finished;          ///< "" while running
};

struct ExperimentRecord {
  std::int64_t id = 0;       ///< set by the database
  std::int64_t run_id = 0;
  std::int64_t seq = 0;      ///< 1, 2, ... within the run; 0 = assign the next one
  std::string design;        ///< what chose it: curiosity, random, grid, hand, goal ("" before schema 2)
  Experiment experiment;
  FeatureVector before, after;
  std::optional<Outcome> outcome;      ///< required when status is "done"
  std::optional<Prediction> prediction;
  std::optional<double> surprise;      ///< >= 0
  std::string status = "done";         ///< "planned", "done" or "failed"
  std::string failure_reason;          ///< required when status is "failed"
  double started = 0.0, finished = 0.0;  ///< s, the caller's (simulated) clock
};

struct ModelRecord {
  std::int64_t id = 0;
  std::int64_t run_id = 0;
  std::string name;      ///< e.g. "push_learner"
  std::string format;    ///< e.g. "opencv-yaml/1"
  std::string blob;      ///< the model's bytes
  std::int64_t sample_count = 0;
  std::string created;
};

struct GoalRecord {
  std::int64_t id = 0;
  std::int64_t run_id = 0;
  std::string object;
  double target_x = 0.0, target_y = 0.0;
  bool reached = false;
  double final_error = 0.0;  ///< m, >= 0
  int pushes_used = 0;
  std::string created;
};

struct EventRecord {
  std::int64_t id = 0;
  std::int64_t run_id = 0;
  double time = 0.0;
  std::string component, kind, text;
};

/// One command or operation call of a component, as its ~events reported it (outcome and effects).
struct CallRecord {
  std::int64_t id = 0;        ///< set by the database, increasing in arrival order
  std::int64_t run_id = 0;    ///< 0: outside any run
  double time = 0.0;          ///< s, the caller's (simulated) clock when the call ended
  std::string component;      ///< who served it, e.g. "manipulation"
  std::string kind;           ///< "command" or "operation"
  std::string name;           ///< e.g. "push"
  std::string outcome;        ///< e.g. "ok", "refused", "failed", "succeeded", "aborted", "preempted", "rejected"
  std::optional<int> code;    ///< the operation's ResultCode (0..254); none for commands
  std::string reason;         ///< the component's sentence; may be empty
  std::vector<std::string> effects;  ///< grounded literals that hold after a successful call
  double duration = 0.0;      ///< s, >= 0
};

/// Which calls calls() returns. Every filter is optional; the result is bounded by limit.
struct CallFilter {
  std::int64_t run_id = 0;    ///< 0: calls outside any run
  std::string component;      ///< "": any
  std::string kind;           ///< "": any, else "command" or "operation"
  double since = 0.0;         ///< calls whose time is >= since
  std::size_t limit = 100;    ///< 1 .. KnowledgeBase::kMaxCallsPerQuery
};

/**
 * The current truth of one (predicate, subject) pair: the latest effect that set it. The subject is a
 * literal's first argument ("" for none), so `at(box, 0.1, 0.2)` replaces an earlier `at(box, ...)`, and
 * `not at(box, ...)` removes it.
 */
struct Fact {
  std::string literal;        ///< e.g. "pushed(box_1, -x, 0.01, 0.05)"
  std::string component;      ///< whose call set it
  double time = 0.0;          ///< when that call ended
  std::int64_t call_id = 0;
};

class KnowledgeBase {
 public:
  /// 2: experiments keep their design; 3: calls, their effects and the facts they imply; 4: world states (1 to 3
  /// are migrated on open).
  static constexpr int kSchemaVersion = 4;
  static constexpr std::size_t kMaxCallsPerQuery = 1000;
  static constexpr std::size_t kMaxEffectsPerCall = 64;
  static constexpr std::int32_t kApplicationId = 0x58505346;  ///< "XPSF"
  static constexpr std::size_t kMaxTextLength = 4096;           ///< reasons, event texts, notion texts
  static constexpr std::size_t kMaxBlobBytes = 64u << 20;       ///< one model
  static constexpr std::size_t kMaxWorldStateBytes = 4u << 20;  ///< one world state (a few kB per body)

  /// Open (and create if missing) the database at @p path; ":memory:" gives a private in-memory one.
  /// Throws KnowledgeBaseError when the file is not a database, belongs to another program, or has a newer
  /// schema.
  static std::unique_ptr<KnowledgeBase> open(const std::string& path);
  ~KnowledgeBase();
  KnowledgeBase(const KnowledgeBase&) = delete;
  KnowledgeBase& operator=(const KnowledgeBase&) = delete;

  const std::string& path() const { return path_; }

  // ---- runs ----
  /// A new run with status "running". parameters_json must be a JSON object ("{}" for none).
  RunInfo createRun(const std::string& name, const std::string& parameters_json, std::int64_t seed,
                    const std::string& design);
  /// The latest run still "running" (a run whose process died), if any.
  std::optional<RunInfo> findResumableRun();
  /// Resume the latest run called @p name that has not finished (still "running" after a crash, or "stopped"):
  /// it is "running" again. None: no such run (then start a new one).
  std::optional<RunInfo> resumeRun(const std::string& name);
  std::optional<RunInfo> run(std::int64_t run_id);
  /// Every run, oldest first.
  std::vector<RunInfo> runs();
  /// Mark a run "finished" or "stopped" and stamp its end.
  void finishRun(std::int64_t run_id, const std::string& status = "finished");

  // ---- experiments ----
  /// Validate and store one experiment in one transaction; returns it with id and seq set. Bad input throws
  /// ValidationError and writes nothing.
  ExperimentRecord recordExperiment(const ExperimentRecord& record);
  /// The run's experiments in seq order (optionally only those with @p status).
  std::vector<ExperimentRecord> experiments(std::int64_t run_id, const std::string& status = "");
  std::int64_t experimentCount(std::int64_t run_id, const std::string& status = "");

  // ---- models ----
  std::int64_t storeModel(std::int64_t run_id, const std::string& name, const std::string& format,
                          const std::string& blob, std::int64_t sample_count);
  std::optional<ModelRecord> latestModel(std::int64_t run_id, const std::string& name);

  // ---- notions ----
  /// Replace all notions of the run by @p notions, in one transaction (all or nothing).
  void replaceNotions(std::int64_t run_id, const std::vector<Notion>& notions);
  std::vector<Notion> notions(std::int64_t run_id);

  // ---- world states ----
  /// Store the simulator's state at the start of step @p step of a run (experiments are steps 0, 1, ...; goal g
  /// of a run of E experiments is step E + g), replacing one stored before for that step. Bad input (an unknown
  /// run, a negative step, text that is not JSON or is larger than kMaxWorldStateBytes) throws ValidationError
  /// and writes nothing.
  void recordWorldState(std::int64_t run_id, std::int64_t step, const std::string& state);
  /// The state stored for a run's step, if any.
  std::optional<std::string> worldState(std::int64_t run_id, std::int64_t step);

  // ---- goals ----
  GoalRecord recordGoal(const GoalRecord& goal);
  std::vector<GoalRecord> goals(std::int64_t run_id);

  // ---- audit log ----
  void appendEvent(std::int64_t run_id, double time, const std::string& component, const std::string& kind,
                   const std::string& text);
  /// The run's last @p limit events, oldest first.
  std::vector<EventRecord> events(std::int64_t run_id, std::size_t limit = 1000);

  // ---- calls and facts ----
  /// Validate every call, then store them all in one transaction (all or nothing) with their effects, and
  /// update the facts of each call's run. Returns the calls with their ids. Bad input throws ValidationError
  /// (naming the call's index and field) and writes nothing; an unknown run_id is bad input.
  std::vector<CallRecord> recordCalls(const std::vector<CallRecord>& calls);
  /// The calls that match @p filter, oldest first (by time, then id), at most filter.limit of them; @p more
  /// (if given) tells whether further calls matched. Throws ValidationError for a bad filter.
  std::vector<CallRecord> calls(const CallFilter& filter, bool* more = nullptr);
  /// The facts of @p run_id (0: outside any run), sorted by literal.
  std::vector<Fact> facts(std::int64_t run_id);

  /// For crash tests only: called at named points inside write transactions (e.g.
  /// "experiment:inserted", before COMMIT), so a test can kill the process exactly there.
  void setFaultHookForTesting(std::function<void(const char* point)> hook);

 private:
  explicit KnowledgeBase(const std::string& path);
  class Statement;
  class Transaction;
  void initialize();
  void requireRun(std::int64_t run_id);
  /// The run @p run_id, which must exist (callers hold mutex_).
  RunInfo readRunLocked(std::int64_t run_id);
  void fault(const char* point);
  std::string fail(const std::string& what) const;  // composes what + SQLite's message

  std::string path_;
  sqlite3* db_ = nullptr;
  std::mutex mutex_;
  std::function<void(const char*)> fault_hook_;
};

}  // namespace xpersif::core
