#include "xpersif/core/kb/knowledge_base.h"

#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "xpersif/core/common/contract.h"
#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {

const char* const kSchema = R"SQL(
CREATE TABLE runs(
  id          INTEGER PRIMARY KEY,
  name        TEXT NOT NULL,
  status      TEXT NOT NULL CHECK(status IN ('running', 'finished', 'stopped')),
  parameters  TEXT NOT NULL CHECK(CASE WHEN json_valid(parameters) THEN json_type(parameters) = 'object' ELSE 0 END),
  seed        INTEGER NOT NULL,
  design      TEXT NOT NULL,
  started     TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  finished    TEXT);
CREATE TABLE experiments(
  id             INTEGER PRIMARY KEY,
  run_id         INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  seq            INTEGER NOT NULL CHECK(seq > 0),
  design         TEXT NOT NULL DEFAULT '',
  object         TEXT NOT NULL CHECK(length(object) > 0),
  side           TEXT NOT NULL CHECK(side IN ('-x', '+x', '-y', '+y')),
  push_offset    REAL NOT NULL,
  distance       REAL NOT NULL CHECK(distance > 0),
  before_json    TEXT NOT NULL CHECK(json_valid(before_json)),
  after_json     TEXT NOT NULL CHECK(json_valid(after_json)),
  dx REAL, dy REAL, dyaw REAL,
  pred_dx REAL, pred_dy REAL, pred_dyaw REAL,
  pred_std_dx REAL, pred_std_dy REAL, pred_std_dyaw REAL,
  surprise       REAL CHECK(surprise IS NULL OR surprise >= 0),
  status         TEXT NOT NULL CHECK(status IN ('planned', 'done', 'failed')),
  failure_reason TEXT NOT NULL DEFAULT '',
  started        REAL NOT NULL,
  finished       REAL NOT NULL,
  created        TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  CHECK(status != 'done' OR (dx IS NOT NULL AND dy IS NOT NULL AND dyaw IS NOT NULL)),
  UNIQUE(run_id, seq));
CREATE TABLE models(
  id           INTEGER PRIMARY KEY,
  run_id       INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  name         TEXT NOT NULL,
  format       TEXT NOT NULL,
  blob         BLOB NOT NULL,
  sample_count INTEGER NOT NULL CHECK(sample_count >= 0),
  created      TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')));
CREATE INDEX models_by_run_name ON models(run_id, name, id);
CREATE TABLE notions(
  id         INTEGER PRIMARY KEY,
  run_id     INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  subject    TEXT NOT NULL,
  predicate  TEXT NOT NULL,
  value      REAL NOT NULL,
  confidence REAL NOT NULL CHECK(confidence BETWEEN 0 AND 1),
  support    INTEGER NOT NULL CHECK(support >= 0),
  text       TEXT NOT NULL,
  created    TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')));
CREATE INDEX notions_by_run ON notions(run_id);
CREATE TABLE goals(
  id          INTEGER PRIMARY KEY,
  run_id      INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  object      TEXT NOT NULL,
  target_x    REAL NOT NULL,
  target_y    REAL NOT NULL,
  reached     INTEGER NOT NULL CHECK(reached IN (0, 1)),
  final_error REAL NOT NULL CHECK(final_error >= 0),
  pushes_used INTEGER NOT NULL CHECK(pushes_used >= 0),
  created     TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')));
CREATE INDEX goals_by_run ON goals(run_id);
CREATE TABLE events(
  id        INTEGER PRIMARY KEY,
  run_id    INTEGER REFERENCES runs(id) ON DELETE CASCADE,
  time      REAL NOT NULL,
  component TEXT NOT NULL,
  kind      TEXT NOT NULL,
  text      TEXT NOT NULL,
  created   TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')));
CREATE INDEX events_by_run ON events(run_id, id);
)SQL";

// Schema 3: every command and operation call a component reported, its grounded effects, and the facts they
// imply per run (the latest effect per predicate and subject), kept up to date in the calls' transaction so
// that reading the facts is one indexed query.
const char* const kCallsSchema = R"SQL(
CREATE TABLE calls(
  id        INTEGER PRIMARY KEY,
  run_id    INTEGER REFERENCES runs(id) ON DELETE CASCADE,
  time      REAL NOT NULL,
  component TEXT NOT NULL CHECK(length(component) > 0),
  kind      TEXT NOT NULL CHECK(kind IN ('command', 'operation')),
  name      TEXT NOT NULL CHECK(length(name) > 0),
  outcome   TEXT NOT NULL CHECK(length(outcome) > 0),
  code      INTEGER CHECK(code IS NULL OR code BETWEEN 0 AND 254),
  reason    TEXT NOT NULL DEFAULT '',
  duration  REAL NOT NULL CHECK(duration >= 0),
  created   TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')));
CREATE INDEX calls_by_run_time ON calls(coalesce(run_id, 0), time, id);
CREATE TABLE effects(
  call_id   INTEGER NOT NULL REFERENCES calls(id) ON DELETE CASCADE,
  position  INTEGER NOT NULL CHECK(position >= 0),
  literal   TEXT NOT NULL CHECK(length(literal) > 0),
  PRIMARY KEY(call_id, position));
CREATE TABLE facts(
  run_id    INTEGER NOT NULL,
  predicate TEXT NOT NULL,
  subject   TEXT NOT NULL,
  literal   TEXT NOT NULL,
  call_id   INTEGER NOT NULL REFERENCES calls(id) ON DELETE CASCADE,
  PRIMARY KEY(run_id, predicate, subject));
)SQL";

// Schema 4: XPERSim's world state at the start of a run's steps (experiments, then goals), so that a resumed run,
// whatever died, goes on from the world as it was (core::PhysicsWorld::saveState's JSON text).
const char* const kWorldStatesSchema = R"SQL(
CREATE TABLE world_states(
  run_id    INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  step      INTEGER NOT NULL CHECK(step >= 0),
  state     TEXT NOT NULL CHECK(json_valid(state)),
  created   TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  PRIMARY KEY(run_id, step));
)SQL";

void requireText(const std::string& field, const std::string& text, bool allow_empty = false) {
  if (!allow_empty && text.empty()) throw ValidationError(field + " is empty; it is required");
  throwIfInvalid(checkMaxLength(field, text, KnowledgeBase::kMaxTextLength));
}

}  // namespace

// ---- thin RAII wrappers over sqlite3_stmt and transactions ---------------------------------------------

class KnowledgeBase::Statement {
 public:
  Statement(KnowledgeBase& kb, const char* sql) : kb_(kb) {
    if (sqlite3_prepare_v2(kb.db_, sql, -1, &stmt_, nullptr) != SQLITE_OK) {
      throw KnowledgeBaseError(kb.fail("cannot prepare a statement"));
    }
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& bind(double value) { return check(sqlite3_bind_double(stmt_, ++index_, value)); }
  Statement& bind(std::int64_t value) { return check(sqlite3_bind_int64(stmt_, ++index_, value)); }
  Statement& bind(int value) { return bind(static_cast<std::int64_t>(value)); }
  Statement& bind(const std::string& text) {
    return check(sqlite3_bind_text(stmt_, ++index_, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT));
  }
  Statement& bind(const char* text) { return bind(std::string(text)); }
  Statement& bindBlob(const std::string& bytes) {
    return check(sqlite3_bind_blob64(stmt_, ++index_, bytes.data(), bytes.size(), SQLITE_TRANSIENT));
  }
  Statement& bindNull() { return check(sqlite3_bind_null(stmt_, ++index_)); }
  template <typename T>
  Statement& bindOptional(const std::optional<T>& value) {
    return value ? bind(*value) : bindNull();
  }

  /// true: a row is ready; false: done.
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw KnowledgeBaseError(kb_.fail("a statement failed"));
  }
  void run() {
    while (step()) {
    }
  }

  bool isNull(int column) const { return sqlite3_column_type(stmt_, column) == SQLITE_NULL; }
  double real(int column) const { return sqlite3_column_double(stmt_, column); }
  std::int64_t integer(int column) const { return sqlite3_column_int64(stmt_, column); }
  std::string text(int column) const {
    const auto* data = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, column));
    return data ? std::string(data, static_cast<std::size_t>(sqlite3_column_bytes(stmt_, column))) : std::string();
  }
  std::string blob(int column) const {
    const auto* data = static_cast<const char*>(sqlite3_column_blob(stmt_, column));
    return data ? std::string(data, static_cast<std::size_t>(sqlite3_column_bytes(stmt_, column))) : std::string();
  }

 private:
  Statement& check(int rc) {
    if (rc != SQLITE_OK) throw KnowledgeBaseError(kb_.fail("cannot bind a parameter"));
    return *this;
  }
  KnowledgeBase& kb_;
  sqlite3_stmt* stmt_ = nullptr;
  int index_ = 0;
};

/// BEGIN IMMEDIATE (take the write lock up front, so a busy database makes us wait, not fail mid-way);
/// rolled back unless commit() was called.
class KnowledgeBase::Transaction {
 public:
  explicit Transaction(KnowledgeBase& kb) : kb_(kb) { exec("BEGIN IMMEDIATE"); }
  ~Transaction() {
    if (!done_) sqlite3_exec(kb_.db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  void commit() {
    exec("COMMIT");
    done_ = true;
  }

 private:
  void exec(const char* sql) {
    if (sqlite3_exec(kb_.db_, sql, nullptr, nullptr, nullptr) != SQLITE_OK) {
      throw KnowledgeBaseError(kb_.fail(std::string("cannot ") + sql));
    }
  }
  KnowledgeBase& kb_;
  bool done_ = false;
};

// ---- opening -------------------------------------------------------------------------------------------

std::unique_ptr<KnowledgeBase> KnowledgeBase::open(const std::string& path) {
  if (path.empty()) throw ValidationError("knowledge base path is empty; give a file name or \":memory:\"");
  return std::unique_ptr<KnowledgeBase>(new KnowledgeBase(path));
}

KnowledgeBase::KnowledgeBase(const std::string& path) : path_(path) {
  const int rc = sqlite3_open_v2(path.c_str(), &db_,
                                 SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    const std::string message = fail("cannot be opened");
    sqlite3_close(db_);
    db_ = nullptr;
    throw KnowledgeBaseError(message);
  }
  try {
    initialize();
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

KnowledgeBase::~KnowledgeBase() {
  if (db_) sqlite3_close(db_);
}

std::string KnowledgeBase::fail(const std::string& what) const {
  std::string message = "knowledge base '" + path_ + "' " + what;
  if (db_) message += std::string(" (SQLite: ") + sqlite3_errmsg(db_) + ")";
  return message;
}

void KnowledgeBase::initialize() {
  sqlite3_extended_result_codes(db_, 1);
  sqlite3_busy_timeout(db_, 10000);

  auto pragma_int = [this](const char* sql) {
    Statement statement(*this, sql);
    return statement.step() ? statement.integer(0) : std::int64_t{0};
  };
  // The first read of the file: a file that is not a database fails here.
  std::int64_t application_id = 0, version = 0, tables = 0;
  try {
    application_id = pragma_int("PRAGMA application_id");
    version = pragma_int("PRAGMA user_version");
    tables = pragma_int("SELECT count(*) FROM sqlite_master");
  } catch (const KnowledgeBaseError&) {
    const int code = sqlite3_errcode(db_) & 0xff;
    if (code == SQLITE_NOTADB || code == SQLITE_CORRUPT) {
      throw KnowledgeBaseError("knowledge base '" + path_ +
                               "' is not an SQLite database (the file is corrupted or is some other kind of file); "
                               "move it away or choose another path");
    }
    throw;
  }
  // A database whose pages were damaged opens fine and fails later; find out now.
  {
    std::string verdict;
    try {
      Statement check(*this, "PRAGMA quick_check(1)");
      verdict = check.step() ? check.text(0) : "no answer";
    } catch (const KnowledgeBaseError&) {
      verdict = sqlite3_errmsg(db_);
    }
    if (verdict != "ok") {
      throw KnowledgeBaseError("knowledge base '" + path_ + "' is corrupted (SQLite's quick_check: " + verdict +
                               "); restore it from a copy or choose another path");
    }
  }
  if (application_id != 0 && application_id != kApplicationId) {
    throw KnowledgeBaseError("knowledge base '" + path_ +
                             "' is an SQLite database of another program (application id " +
                             std::to_string(application_id) + "); choose another path");
  }
  if (application_id == 0 && tables > 0) {
    throw KnowledgeBaseError("knowledge base '" + path_ +
                             "' is an SQLite database with tables but without the XPERSIF schema; "
                             "choose another path");
  }
  if (version > kSchemaVersion) {
    throw KnowledgeBaseError("knowledge base '" + path_ + "' has schema version " + std::to_string(version) +
                             ", newer than this program's (" + std::to_string(kSchemaVersion) +
                             "); open it with a newer XPERSIF");
  }

  // WAL: readers never block the writer and a crash never corrupts; FULL: a commit is on disk when it returns.
  { Statement(*this, "PRAGMA journal_mode=WAL").run(); }
  { Statement(*this, "PRAGMA synchronous=FULL").run(); }
  { Statement(*this, "PRAGMA foreign_keys=ON").run(); }

  if (version < kSchemaVersion) {
    Transaction transaction(*this);
    auto exec_script = [this](const char* sql, const std::string& what) {
      char* error = nullptr;
      if (sqlite3_exec(db_, sql, nullptr, nullptr, &error) != SQLITE_OK) {
        const std::string why = error ? error : "unknown error";
        sqlite3_free(error);
        throw KnowledgeBaseError("knowledge base '" + path_ + "' cannot " + what + ": " + why);
      }
    };
    // Another process may have created or migrated the schema while we waited for the write lock.
    std::int64_t now = pragma_int("PRAGMA user_version");
    if (now == 0) {
      exec_script(kSchema, "create its schema");  // schema 2's tables; 3 adds its own below
      Statement(*this, ("PRAGMA application_id=" + std::to_string(kApplicationId)).c_str()).run();
      now = 2;
    }
    if (now == 1) {
      // Schema 1 did not keep the design that chose an experiment: older experiments keep an empty one.
      Statement(*this, "ALTER TABLE experiments ADD COLUMN design TEXT NOT NULL DEFAULT ''").run();
      now = 2;
    }
    if (now == 2) {
      // Schema 2 kept no calls: a migrated database starts with none, and so with no facts.
      exec_script(kCallsSchema, "add the tables of calls, effects and facts");
      now = 3;
    }
    if (now == 3) {
      exec_script(kWorldStatesSchema, "add the table of world states");
      now = 4;
    }
    Statement(*this, ("PRAGMA user_version=" + std::to_string(now)).c_str()).run();
    transaction.commit();
  }
}

void KnowledgeBase::setFaultHookForTesting(std::function<void(const char*)> hook) {
  std::lock_guard<std::mutex> lock(mutex_);
  fault_hook_ = std::move(hook);
}

void KnowledgeBase::fault(const char* point) {
  if (fault_hook_) fault_hook_(point);
}

void KnowledgeBase::requireRun(std::int64_t run_id) {
  Statement statement(*this, "SELECT 1 FROM runs WHERE id = ?");
  statement.bind(run_id);
  if (!statement.step()) {
    throw ValidationError("run_id " + std::to_string(run_id) + " is not a run of this knowledge base");
  }
}

// ---- runs ----------------------------------------------------------------------------------------------

namespace {
const char* const kRunColumns = "SELECT id, name, status, parameters, seed, design, started, coalesce(finished, '') FROM runs ";

RunInfo readRun(const std::function<std::int64_t(int)>& integer, const std::function<std::string(int)>& text) {
  RunInfo run;
  run.id = integer(0);
  run.name = text(1);
  run.status = text(2);
  run.parameters_json = text(3);
  run.seed = integer(4);
  run.design = text(5);
  run.started = text(6);
  run.finished = text(7);
  return run;
}
}  // namespace

RunInfo KnowledgeBase::createRun(const std::string& name, const std::string& parameters_json, std::int64_t seed,
                                 const std::string& design) {
  requireText("run name", name);
  throwIfInvalid(checkMaxLength("run design", design, kMaxNameLength));
  throwIfInvalid(checkMaxLength("run parameters", parameters_json, kMaxBlobBytes));
  std::lock_guard<std::mutex> lock(mutex_);
  {
    Statement check(*this, "SELECT CASE WHEN json_valid(?1) THEN json_type(?1) = 'object' ELSE 0 END");
    check.bind(parameters_json);
    if (!check.step() || check.integer(0) != 1) {
      throw ValidationError("run parameters are not a JSON object: give e.g. {\"pushes\": 100} or {}");
    }
  }
  Transaction transaction(*this);
  Statement insert(*this, "INSERT INTO runs(name, status, parameters, seed, design) VALUES (?, 'running', ?, ?, ?)");
  insert.bind(name).bind(parameters_json).bind(seed).bind(design).run();
  RunInfo run = readRunLocked(sqlite3_last_insert_rowid(db_));
  transaction.commit();
  return run;
}

std::optional<RunInfo> KnowledgeBase::findResumableRun() {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, (std::string(kRunColumns) + "WHERE status = 'running' ORDER BY id DESC LIMIT 1").c_str());
  if (!select.step()) return std::nullopt;
  return readRun([&](int c) { return select.integer(c); }, [&](int c) { return select.text(c); });
}

std::optional<RunInfo> KnowledgeBase::resumeRun(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  Transaction transaction(*this);
  std::int64_t id = 0;
  {
    Statement find(*this, "SELECT id FROM runs WHERE name = ? AND status IN ('running', 'stopped') ORDER BY id DESC LIMIT 1");
    find.bind(name);
    if (!find.step()) return std::nullopt;
    id = find.integer(0);
  }
  Statement update(*this, "UPDATE runs SET status = 'running', finished = NULL WHERE id = ?");
  update.bind(id).run();
  RunInfo run = readRunLocked(id);
  transaction.commit();
  return run;
}

RunInfo KnowledgeBase::readRunLocked(std::int64_t run_id) {
  Statement select(*this, (std::string(kRunColumns) + "WHERE id = ?").c_str());
  select.bind(run_id);
  if (!select.step()) throw KnowledgeBaseError("run " + std::to_string(run_id) + " vanished from '" + path_ + "'");
  return readRun([&](int c) { return select.integer(c); }, [&](int c) { return select.text(c); });
}

std::optional<RunInfo> KnowledgeBase::run(std::int64_t run_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, (std::string(kRunColumns) + "WHERE id = ?").c_str());
  select.bind(run_id);
  if (!select.step()) return std::nullopt;
  return readRun([&](int c) { return select.integer(c); }, [&](int c) { return select.text(c); });
}

std::vector<RunInfo> KnowledgeBase::runs() {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, (std::string(kRunColumns) + "ORDER BY id").c_str());
  std::vector<RunInfo> all;
  while (select.step()) all.push_back(readRun([&](int c) { return select.integer(c); }, [&](int c) { return select.text(c); }));
  return all;
}

void KnowledgeBase::finishRun(std::int64_t run_id, const std::string& status) {
  throwIfInvalid(checkOneOf("final run status", status, {"finished", "stopped"}));
  std::lock_guard<std::mutex> lock(mutex_);
  Transaction transaction(*this);
  requireRun(run_id);
  Statement update(*this,
                   "UPDATE runs SET status = ?, finished = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') WHERE id = ?");
  update.bind(status).bind(run_id).run();
  transaction.commit();
}

// ---- experiments ---------------------------------------------------------------------------------------

namespace {

void validateExperiment(const ExperimentRecord& r) {
  requireExperiment("experiment", r.experiment);
  requireFeatureVector("experiment.before", r.before);
  requireFeatureVector("experiment.after", r.after);
  throwIfInvalid(checkOneOf("experiment.status", r.status, {"planned", "done", "failed"}));
  if (r.seq < 0) throw ValidationError("experiment.seq is " + std::to_string(r.seq) + "; it must be 0 (next) or more");
  if (r.status == "done" && !r.outcome) {
    throw ValidationError("experiment.outcome is missing; a done experiment needs its outcome");
  }
  if (r.outcome) requireOutcome("experiment.outcome", *r.outcome);
  if (r.prediction) {
    requireOutcome("experiment.prediction.mean", r.prediction->mean);
    const Outcome& s = r.prediction->std;
    throwIfInvalid(checkInRange("experiment.prediction.std.dx", s.dx, 0.0, 1e6));
    throwIfInvalid(checkInRange("experiment.prediction.std.dy", s.dy, 0.0, 1e6));
    throwIfInvalid(checkInRange("experiment.prediction.std.dyaw", s.dyaw, 0.0, 1e6));
  }
  if (r.surprise) throwIfInvalid(checkInRange("experiment.surprise", *r.surprise, 0.0, 1e12));
  if (r.status == "failed") requireText("experiment.failure_reason", r.failure_reason);
  requireText("experiment.failure_reason", r.failure_reason, /*allow_empty=*/true);
  throwIfInvalid(checkMaxLength("experiment.design", r.design, kMaxNameLength));
  requireFinite("experiment.started", r.started);
  requireFinite("experiment.finished", r.finished);
}

}  // namespace

ExperimentRecord KnowledgeBase::recordExperiment(const ExperimentRecord& record) {
  validateExperiment(record);
  // Serialize before touching the database: a serializer error must not leave a transaction behind.
  const std::string before_json = toJson(record.before), after_json = toJson(record.after);

  std::lock_guard<std::mutex> lock(mutex_);
  Transaction transaction(*this);
  {
    Statement status(*this, "SELECT status FROM runs WHERE id = ?");
    status.bind(record.run_id);
    if (!status.step()) {
      throw ValidationError("experiment.run_id " + std::to_string(record.run_id) +
                            " is not a run of this knowledge base");
    }
    if (status.text(0) != "running") {
      throw ValidationError("run " + std::to_string(record.run_id) + " is " + status.text(0) +
                            "; experiments can only be added to a running run");
    }
  }
  ExperimentRecord stored = record;
  {
    // A call repeated because its answer was lost (the manager died after the commit) stores nothing twice: the
    // same push of the same run, started and finished at the same simulated times, is answered with its row.
    Statement same(*this,
                   "SELECT id, seq FROM experiments WHERE run_id = ? AND started = ? AND finished = ? AND object = ? "
                   "AND side = ? AND push_offset = ? AND distance = ? AND status = ? AND (? = 0 OR seq = ?)");
    same.bind(record.run_id).bind(record.started).bind(record.finished).bind(record.experiment.object);
    same.bind(record.experiment.side).bind(record.experiment.offset).bind(record.experiment.distance);
    same.bind(record.status).bind(static_cast<std::int64_t>(record.seq)).bind(static_cast<std::int64_t>(record.seq));
    if (same.step()) {
      stored.id = same.integer(0);
      stored.seq = same.integer(1);
      return stored;  // the transaction rolls back: nothing was written
    }
  }
  if (stored.seq == 0) {
    Statement next(*this, "SELECT coalesce(max(seq), 0) + 1 FROM experiments WHERE run_id = ?");
    next.bind(record.run_id).step();
    stored.seq = next.integer(0);
  } else {
    Statement taken(*this, "SELECT 1 FROM experiments WHERE run_id = ? AND seq = ?");
    taken.bind(record.run_id).bind(record.seq);
    if (taken.step()) {
      throw ValidationError("experiment.seq " + std::to_string(record.seq) + " already exists in run " +
                            std::to_string(record.run_id));
    }
  }
  const std::optional<Outcome>& o = record.outcome;
  const std::optional<Prediction>& p = record.prediction;
  Statement insert(*this,
                   "INSERT INTO experiments(run_id, seq, design, object, side, push_offset, distance, before_json, "
                   "after_json, dx, dy, dyaw, pred_dx, pred_dy, pred_dyaw, pred_std_dx, pred_std_dy, pred_std_dyaw, "
                   "surprise, status, failure_reason, started, finished) "
                   "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  insert.bind(record.run_id).bind(stored.seq).bind(record.design).bind(record.experiment.object).bind(record.experiment.side);
  insert.bind(record.experiment.offset).bind(record.experiment.distance).bind(before_json).bind(after_json);
  if (o) insert.bind(o->dx).bind(o->dy).bind(o->dyaw);
  else insert.bindNull().bindNull().bindNull();
  if (p) {
    insert.bind(p->mean.dx).bind(p->mean.dy).bind(p->mean.dyaw).bind(p->std.dx).bind(p->std.dy).bind(p->std.dyaw);
  } else {
    for (int i = 0; i < 6; ++i) insert.bindNull();
  }
  insert.bindOptional(record.surprise).bind(record.status).bind(record.failure_reason);
  insert.bind(record.started).bind(record.finished).run();
  stored.id = sqlite3_last_insert_rowid(db_);
  fault("experiment:inserted");

  // The audit line goes in the same transaction: both or neither.
  Statement event(*this, "INSERT INTO events(run_id, time, component, kind, text) VALUES (?, ?, 'knowledge_base', "
                         "'experiment', ?)");
  event.bind(record.run_id).bind(record.finished);
  event.bind("experiment " + std::to_string(stored.seq) + " " + record.status + ": push " +
             record.experiment.object + " on " + record.experiment.side);
  event.run();
  fault("experiment:before_commit");
  transaction.commit();
  return stored;
}

namespace {
const char* const kExperimentColumns =
    "SELECT id, run_id, seq, object, side, push_offset, distance, before_json, after_json, dx, dy, dyaw, "
    "pred_dx, pred_dy, pred_dyaw, pred_std_dx, pred_std_dy, pred_std_dyaw, surprise, status, failure_reason, "
    "started, finished, design FROM experiments WHERE run_id = ?1 AND (?2 = '' OR status = ?2) ORDER BY seq";
}  // namespace

std::vector<ExperimentRecord> KnowledgeBase::experiments(std::int64_t run_id, const std::string& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, kExperimentColumns);
  select.bind(run_id).bind(status);
  std::vector<ExperimentRecord> records;
  while (select.step()) {
    ExperimentRecord r;
    r.id = select.integer(0);
    r.run_id = select.integer(1);
    r.seq = select.integer(2);
    r.experiment.object = select.text(3);
    r.experiment.side = select.text(4);
    r.experiment.offset = select.real(5);
    r.experiment.distance = select.real(6);
    try {
      r.before = featureVectorFromJson(select.text(7));
      r.after = featureVectorFromJson(select.text(8));
    } catch (const ValidationError& e) {  // written by another tool: the database is at fault, not the caller
      throw KnowledgeBaseError("knowledge base '" + path_ + "' experiment " + std::to_string(r.id) +
                               " holds a feature vector this program cannot read: " + e.what());
    }
    if (!select.isNull(9)) r.outcome = Outcome{select.real(9), select.real(10), select.real(11)};
    if (!select.isNull(12)) {
      r.prediction = Prediction{{select.real(12), select.real(13), select.real(14)},
                                {select.real(15), select.real(16), select.real(17)}};
    }
    if (!select.isNull(18)) r.surprise = select.real(18);
    r.status = select.text(19);
    r.failure_reason = select.text(20);
    r.started = select.real(21);
    r.finished = select.real(22);
    r.design = select.text(23);
    records.push_back(std::move(r));
  }
  return records;
}

std::int64_t KnowledgeBase::experimentCount(std::int64_t run_id, const std::string& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement count(*this, "SELECT count(*) FROM experiments WHERE run_id = ?1 AND (?2 = '' OR status = ?2)");
  count.bind(run_id).bind(status).step();
  return count.integer(0);
}

// ---- models --------------------------------------------------------------------------------------------

std::int64_t KnowledgeBase::storeModel(std::int64_t run_id, const std::string& name, const std::string& format,
                                       const std::string& blob, std::int64_t sample_count) {
  requireText("model name", name);
  requireText("model format", format);
  if (blob.empty()) throw ValidationError("model blob is empty; there is nothing to store");
  throwIfInvalid(checkMaxSize("model blob", blob.size(), kMaxBlobBytes));
  if (sample_count < 0) throw ValidationError("model sample_count is negative; it must be 0 or more");
  std::lock_guard<std::mutex> lock(mutex_);
  Transaction transaction(*this);
  requireRun(run_id);
  Statement insert(*this, "INSERT INTO models(run_id, name, format, blob, sample_count) VALUES (?, ?, ?, ?, ?)");
  insert.bind(run_id).bind(name).bind(format).bindBlob(blob).bind(sample_count).run();
  const std::int64_t id = sqlite3_last_insert_rowid(db_);
  transaction.commit();
  return id;
}

std::optional<ModelRecord> KnowledgeBase::latestModel(std::int64_t run_id, const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, "SELECT id, run_id, name, format, blob, sample_count, created FROM models "
                          "WHERE run_id = ? AND name = ? ORDER BY id DESC LIMIT 1");
  select.bind(run_id).bind(name);
  if (!select.step()) return std::nullopt;
  ModelRecord m;
  m.id = select.integer(0);
  m.run_id = select.integer(1);
  m.name = select.text(2);
  m.format = select.text(3);
  m.blob = select.blob(4);
  m.sample_count = select.integer(5);
  m.created = select.text(6);
  return m;
}

// ---- notions -------------------------------------------------------------------------------------------

void KnowledgeBase::replaceNotions(std::int64_t run_id, const std::vector<Notion>& notions) {
  throwIfInvalid(checkMaxSize("notions", notions.size(), 10000));
  for (std::size_t i = 0; i < notions.size(); ++i) {
    const Notion& n = notions[i];
    const std::string at = "notions[" + std::to_string(i) + "]";
    requireText(at + ".subject", n.subject);
    requireText(at + ".predicate", n.predicate);
    requireFinite(at + ".value", n.value);
    throwIfInvalid(checkInRange(at + ".confidence", n.confidence, 0.0, 1.0));
    if (n.support < 0) throw ValidationError(at + ".support is negative; it must be 0 or more");
    requireText(at + ".text", n.text);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  Transaction transaction(*this);
  requireRun(run_id);
  Statement(*this, "DELETE FROM notions WHERE run_id = ?").bind(run_id).run();
  for (const Notion& n : notions) {
    Statement insert(*this, "INSERT INTO notions(run_id, subject, predicate, value, confidence, support, text) "
                            "VALUES (?, ?, ?, ?, ?, ?, ?)");
    insert.bind(run_id).bind(n.subject).bind(n.predicate).bind(n.value).bind(n.confidence).bind(n.support);
    insert.bind(n.text).run();
    fault("notions:inserted");
  }
  transaction.commit();
}

std::vector<Notion> KnowledgeBase::notions(std::int64_t run_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, "SELECT subject, predicate, value, confidence, support, text FROM notions "
                          "WHERE run_id = ? ORDER BY id");
  select.bind(run_id);
  std::vector<Notion> result;
  while (select.step()) {
    result.push_back(Notion{select.text(0), select.text(1), select.real(2), select.real(3),
                            static_cast<int>(select.integer(4)), select.text(5)});
  }
  return result;
}

// ---- world states --------------------------------------------------------------------------------------

void KnowledgeBase::recordWorldState(std::int64_t run_id, std::int64_t step, const std::string& state) {
  if (step < 0) throw ValidationError("step is " + std::to_string(step) + "; it must be 0 or more");
  if (state.empty()) throw ValidationError("state is empty; it is required");
  if (state.size() > kMaxWorldStateBytes) {
    throw ValidationError("state has " + std::to_string(state.size()) + " bytes; at most " +
                          std::to_string(kMaxWorldStateBytes) + " are stored");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  Transaction transaction(*this);
  requireRun(run_id);
  {
    Statement valid(*this, "SELECT json_valid(?)");
    valid.bind(state).step();
    if (valid.integer(0) == 0) throw ValidationError("state is not JSON text");
  }
  // A step taken again (a resumed or redone one) replaces its state: the world as it was when it began.
  Statement insert(*this, "INSERT OR REPLACE INTO world_states(run_id, step, state) VALUES (?, ?, ?)");
  insert.bind(run_id).bind(step).bind(state).run();
  transaction.commit();
}

std::optional<std::string> KnowledgeBase::worldState(std::int64_t run_id, std::int64_t step) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, "SELECT state FROM world_states WHERE run_id = ? AND step = ?");
  select.bind(run_id).bind(step);
  if (!select.step()) return std::nullopt;
  return select.text(0);
}

// ---- goals ---------------------------------------------------------------------------------------------

GoalRecord KnowledgeBase::recordGoal(const GoalRecord& goal) {
  requireText("goal.object", goal.object);
  throwIfInvalid(checkMaxLength("goal.object", goal.object, kMaxNameLength));
  requireFinite("goal.target_x", goal.target_x);
  requireFinite("goal.target_y", goal.target_y);
  throwIfInvalid(checkInRange("goal.final_error", goal.final_error, 0.0, 1e6));
  if (goal.pushes_used < 0) throw ValidationError("goal.pushes_used is negative; it must be 0 or more");
  std::lock_guard<std::mutex> lock(mutex_);
  Transaction transaction(*this);
  requireRun(goal.run_id);
  Statement insert(*this, "INSERT INTO goals(run_id, object, target_x, target_y, reached, final_error, pushes_used) "
                          "VALUES (?, ?, ?, ?, ?, ?, ?)");
  insert.bind(goal.run_id).bind(goal.object).bind(goal.target_x).bind(goal.target_y).bind(goal.reached ? 1 : 0);
  insert.bind(goal.final_error).bind(goal.pushes_used).run();
  GoalRecord stored = goal;
  stored.id = sqlite3_last_insert_rowid(db_);
  Statement created(*this, "SELECT created FROM goals WHERE id = ?");
  created.bind(stored.id).step();
  stored.created = created.text(0);
  transaction.commit();
  return stored;
}

std::vector<GoalRecord> KnowledgeBase::goals(std::int64_t run_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, "SELECT id, run_id, object, target_x, target_y, reached, final_error, pushes_used, created "
                          "FROM goals WHERE run_id = ? ORDER BY id");
  select.bind(run_id);
  std::vector<GoalRecord> result;
  while (select.step()) {
    GoalRecord g;
    g.id = select.integer(0);
    g.run_id = select.integer(1);
    g.object = select.text(2);
    g.target_x = select.real(3);
    g.target_y = select.real(4);
    g.reached = select.integer(5) != 0;
    g.final_error = select.real(6);
    g.pushes_used = static_cast<int>(select.integer(7));
    g.created = select.text(8);
    result.push_back(std::move(g));
  }
  return result;
}

// ---- audit log -----------------------------------------------------------------------------------------

void KnowledgeBase::appendEvent(std::int64_t run_id, double time, const std::string& component,
                                const std::string& kind, const std::string& text) {
  requireFinite("event time", time);
  requireText("event component", component);
  requireText("event kind", kind);
  requireText("event text", text, /*allow_empty=*/true);
  std::lock_guard<std::mutex> lock(mutex_);
  Transaction transaction(*this);
  if (run_id != 0) requireRun(run_id);
  Statement insert(*this, "INSERT INTO events(run_id, time, component, kind, text) VALUES (?, ?, ?, ?, ?)");
  if (run_id != 0) insert.bind(run_id);
  else insert.bindNull();
  insert.bind(time).bind(component).bind(kind).bind(text).run();
  transaction.commit();
}

std::vector<EventRecord> KnowledgeBase::events(std::int64_t run_id, std::size_t limit) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, "SELECT id, coalesce(run_id, 0), time, component, kind, text FROM ("
                          "SELECT * FROM events WHERE coalesce(run_id, 0) = ? ORDER BY id DESC LIMIT ?) ORDER BY id");
  select.bind(run_id).bind(static_cast<std::int64_t>(limit));
  std::vector<EventRecord> result;
  while (select.step()) {
    result.push_back(EventRecord{select.integer(0), select.integer(1), select.real(2), select.text(3), select.text(4),
                                 select.text(5)});
  }
  return result;
}

// ---- calls and facts -----------------------------------------------------------------------------------

namespace {

void validateCall(const std::string& at, const CallRecord& call, std::vector<Literal>& parsed) {
  requireFinite(at + ".time", call.time);
  requireText(at + ".component", call.component);
  throwIfInvalid(checkMaxLength(at + ".component", call.component, kMaxNameLength));
  throwIfInvalid(checkOneOf(at + ".kind", call.kind, {"command", "operation"}));
  requireText(at + ".name", call.name);
  throwIfInvalid(checkMaxLength(at + ".name", call.name, kMaxNameLength));
  requireText(at + ".outcome", call.outcome);
  throwIfInvalid(checkMaxLength(at + ".outcome", call.outcome, kMaxNameLength));
  if (call.code && (*call.code < 0 || *call.code > 254)) {
    throw ValidationError(at + ".code is " + std::to_string(*call.code) + "; a ResultCode is 0 to 254");
  }
  requireText(at + ".reason", call.reason, /*allow_empty=*/true);
  throwIfInvalid(checkInRange(at + ".duration", call.duration, 0.0, 1e9));
  throwIfInvalid(checkMaxSize(at + ".effects", call.effects.size(), KnowledgeBase::kMaxEffectsPerCall));
  parsed.clear();
  for (std::size_t i = 0; i < call.effects.size(); ++i) {
    const std::string field = at + ".effects[" + std::to_string(i) + "]";
    requireText(field, call.effects[i]);
    Literal literal;
    try {
      literal = parseLiteral(call.effects[i]);
    } catch (const ContractError& e) {
      throw ValidationError(field + " '" + call.effects[i] + "' is malformed: " + e.what());
    }
    for (const auto& argument : literal.arguments) {
      if (!argument.empty() && argument[0] == '?') {
        throw ValidationError(field + " '" + call.effects[i] + "' has the parameter " + argument +
                              "; effects are stored grounded");
      }
    }
    parsed.push_back(std::move(literal));
  }
}

std::string subjectOf(const Literal& literal) { return literal.arguments.empty() ? "" : literal.arguments[0]; }

}  // namespace

std::vector<CallRecord> KnowledgeBase::recordCalls(const std::vector<CallRecord>& calls) {
  std::vector<std::vector<Literal>> parsed(calls.size());
  for (std::size_t i = 0; i < calls.size(); ++i) validateCall("calls[" + std::to_string(i) + "]", calls[i], parsed[i]);
  std::vector<CallRecord> stored = calls;
  if (calls.empty()) return stored;

  std::lock_guard<std::mutex> lock(mutex_);
  Transaction transaction(*this);
  std::set<std::int64_t> known_runs;
  for (std::size_t i = 0; i < calls.size(); ++i) {
    const CallRecord& call = calls[i];
    if (call.run_id != 0 && known_runs.insert(call.run_id).second) {
      Statement exists(*this, "SELECT 1 FROM runs WHERE id = ?");
      exists.bind(call.run_id);
      if (!exists.step()) {
        throw ValidationError("calls[" + std::to_string(i) + "].run_id " + std::to_string(call.run_id) +
                              " is not a run of this knowledge base");
      }
    }
    Statement insert(*this, "INSERT INTO calls(run_id, time, component, kind, name, outcome, code, reason, duration) "
                            "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)");
    if (call.run_id != 0) insert.bind(call.run_id);
    else insert.bindNull();
    insert.bind(call.time).bind(call.component).bind(call.kind).bind(call.name).bind(call.outcome);
    insert.bindOptional(call.code).bind(call.reason).bind(call.duration).run();
    stored[i].id = sqlite3_last_insert_rowid(db_);
    // Effects of one call apply as STRIPS applies them: deletes first, then adds.
    for (std::size_t e = 0; e < call.effects.size(); ++e) {
      Statement effect(*this, "INSERT INTO effects(call_id, position, literal) VALUES (?, ?, ?)");
      effect.bind(stored[i].id).bind(static_cast<std::int64_t>(e)).bind(parsed[i][e].toString()).run();
    }
    for (const Literal& literal : parsed[i]) {
      if (!literal.negated) continue;
      Statement remove(*this, "DELETE FROM facts WHERE run_id = ? AND predicate = ? AND subject = ?");
      remove.bind(call.run_id).bind(literal.predicate).bind(subjectOf(literal)).run();
    }
    for (const Literal& literal : parsed[i]) {
      if (literal.negated) continue;
      Statement set(*this, "INSERT OR REPLACE INTO facts(run_id, predicate, subject, literal, call_id) "
                           "VALUES (?, ?, ?, ?, ?)");
      set.bind(call.run_id).bind(literal.predicate).bind(subjectOf(literal)).bind(literal.toString());
      set.bind(stored[i].id).run();
    }
    fault("calls:inserted");
  }
  transaction.commit();
  return stored;
}

std::vector<CallRecord> KnowledgeBase::calls(const CallFilter& filter, bool* more) {
  if (filter.run_id < 0) throw ValidationError("run_id is negative; give a run's id or 0 for calls outside any run");
  throwIfInvalid(checkMaxLength("component", filter.component, kMaxNameLength));
  throwIfInvalid(checkOneOf("kind", filter.kind, {"", "command", "operation"}));
  requireFinite("since", filter.since);
  throwIfInvalid(checkInRange("limit", static_cast<double>(filter.limit), 1.0, static_cast<double>(kMaxCallsPerQuery)));
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, "SELECT id, coalesce(run_id, 0), time, component, kind, name, outcome, code, reason, duration "
                          "FROM calls WHERE coalesce(run_id, 0) = ?1 AND time >= ?2 AND (?3 = '' OR component = ?3) "
                          "AND (?4 = '' OR kind = ?4) ORDER BY time, id LIMIT ?5");
  select.bind(filter.run_id).bind(filter.since).bind(filter.component).bind(filter.kind);
  select.bind(static_cast<std::int64_t>(filter.limit) + 1);  // one more: tells whether there are more
  std::vector<CallRecord> result;
  bool truncated = false;
  while (select.step()) {
    if (result.size() == filter.limit) {
      truncated = true;
      break;
    }
    CallRecord c;
    c.id = select.integer(0);
    c.run_id = select.integer(1);
    c.time = select.real(2);
    c.component = select.text(3);
    c.kind = select.text(4);
    c.name = select.text(5);
    c.outcome = select.text(6);
    if (!select.isNull(7)) c.code = static_cast<int>(select.integer(7));
    c.reason = select.text(8);
    c.duration = select.real(9);
    result.push_back(std::move(c));
  }
  for (auto& c : result) {
    Statement effects(*this, "SELECT literal FROM effects WHERE call_id = ? ORDER BY position");
    effects.bind(c.id);
    while (effects.step()) c.effects.push_back(effects.text(0));
  }
  if (more) *more = truncated;
  return result;
}

std::vector<Fact> KnowledgeBase::facts(std::int64_t run_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  Statement select(*this, "SELECT f.literal, c.component, c.time, f.call_id FROM facts f JOIN calls c ON c.id = f.call_id "
                          "WHERE f.run_id = ? ORDER BY f.literal");
  select.bind(run_id);
  std::vector<Fact> result;
  while (select.step()) result.push_back(Fact{select.text(0), select.text(1), select.real(2), select.integer(3)});
  return result;
}

}  // namespace xpersif::core
