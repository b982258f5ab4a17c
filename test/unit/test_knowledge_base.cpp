#include <gtest/gtest.h>

#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <set>
#include <thread>

#include "xpersif/core/kb/knowledge_base.h"
#include "xpersif/core/common/validation.h"

using namespace xpersif::core;

namespace {

/// A fresh directory per test, removed at the end.
class TempDir {
 public:
  TempDir() {
    char pattern[] = "/tmp/xpersif_kb_XXXXXX";
    path_ = mkdtemp(pattern);
  }
  ~TempDir() { std::system(("rm -rf '" + path_ + "'").c_str()); }
  std::string file(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

FeatureVector scene(double red_x, double stamp) {
  FeatureVector f;
  f.stamp = stamp;
  ObjectFeatures red;
  red.name = "red_cube";
  red.x = red_x;
  red.y = 0.1;
  red.yaw = 0.2;
  red.extra = {{"hue", 0.0}, {"size", 0.04}};
  ObjectFeatures blue;
  blue.name = "blue_cube";
  blue.x = -0.3;
  blue.y = 0.25;
  blue.extra = {{"hue", 240.0}, {"size", 0.04}};
  f.objects = {red, blue};
  return f;
}

/// The i-th experiment of a run: values derived from i, so that a reader can check every field.
ExperimentRecord experimentNumber(std::int64_t run_id, int i) {
  ExperimentRecord r;
  r.run_id = run_id;
  r.experiment = {"red_cube", pushSides()[i % 4], 0.001 * (i % 20 - 10), 0.005 * (i % 30 + 1)};
  r.before = scene(0.01 * i, i);
  r.after = scene(0.01 * i + 0.03, i + 0.5);
  r.outcome = Outcome{0.03, 0.001 * i, 0.01};
  r.prediction = Prediction{{0.02, 0.0, 0.0}, {0.01, 0.02, 0.1}};
  r.surprise = 1.0 + i;
  r.started = i;
  r.finished = i + 0.5;
  return r;
}

void expectIsExperimentNumber(const ExperimentRecord& r, int i) {
  const ExperimentRecord e = experimentNumber(r.run_id, i);
  EXPECT_EQ(r.seq, i);
  EXPECT_EQ(r.experiment.object, e.experiment.object);
  EXPECT_EQ(r.experiment.side, e.experiment.side);
  EXPECT_EQ(r.experiment.offset, e.experiment.offset);
  EXPECT_EQ(r.experiment.distance, e.experiment.distance);
  EXPECT_EQ(toJson(r.before), toJson(e.before));
  EXPECT_EQ(toJson(r.after), toJson(e.after));
  ASSERT_TRUE(r.outcome.has_value());
  EXPECT_EQ(r.outcome->dy, e.outcome->dy);
  ASSERT_TRUE(r.prediction.has_value());
  EXPECT_EQ(r.prediction->std.dyaw, 0.1);
  ASSERT_TRUE(r.surprise.has_value());
  EXPECT_EQ(*r.surprise, 1.0 + i);
  EXPECT_EQ(r.status, "done");
  EXPECT_EQ(r.finished, i + 0.5);
}

std::int64_t countRows(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  std::int64_t n = -1;
  if (sqlite3_step(stmt) == SQLITE_ROW) n = sqlite3_column_int64(stmt, 0);
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  return n;
}

void execRaw(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  sqlite3_close(db);
}

std::string openError(const std::string& path) {
  try {
    KnowledgeBase::open(path);
  } catch (const KnowledgeBaseError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(KnowledgeBase, OpensWithTheDurablePragmasAndVersion) {
  TempDir dir;
  const std::string path = dir.file("kb.sqlite");
  { auto kb = KnowledgeBase::open(path); }
  EXPECT_EQ(countRows(path, "PRAGMA user_version"), KnowledgeBase::kSchemaVersion);
  EXPECT_EQ(countRows(path, "PRAGMA application_id"), KnowledgeBase::kApplicationId);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &stmt, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0)), "wal");  // persistent in the file
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  // Re-opening an existing knowledge base works and keeps it.
  auto kb = KnowledgeBase::open(path);
  EXPECT_FALSE(kb->findResumableRun().has_value());
  EXPECT_NO_THROW(KnowledgeBase::open(":memory:"));
}

TEST(KnowledgeBase, RunsAndExperimentsRoundTrip) {
  auto kb = KnowledgeBase::open(":memory:");
  const RunInfo run = kb->createRun("first", "{\"pushes\": 100, \"note\": \"a \\\"quoted\\\" word\"}", 42, "curiosity");
  EXPECT_GT(run.id, 0);
  EXPECT_EQ(run.status, "running");
  EXPECT_EQ(run.seed, 42);
  EXPECT_EQ(run.design, "curiosity");
  EXPECT_FALSE(run.started.empty());
  EXPECT_TRUE(run.finished.empty());

  for (int i = 1; i <= 5; ++i) {
    const ExperimentRecord stored = kb->recordExperiment(experimentNumber(run.id, i));
    EXPECT_EQ(stored.seq, i);
    EXPECT_GT(stored.id, 0);
  }
  ExperimentRecord planned = experimentNumber(run.id, 6);
  planned.status = "planned";
  planned.outcome.reset();
  planned.prediction.reset();
  planned.surprise.reset();
  kb->recordExperiment(planned);
  ExperimentRecord failed = experimentNumber(run.id, 7);
  failed.status = "failed";
  failed.failure_reason = "the robot lost contact with the cube";
  failed.outcome.reset();
  kb->recordExperiment(failed);

  EXPECT_EQ(kb->experimentCount(run.id), 7);
  EXPECT_EQ(kb->experimentCount(run.id, "done"), 5);
  const auto all = kb->experiments(run.id);
  ASSERT_EQ(all.size(), 7u);
  for (int i = 1; i <= 5; ++i) expectIsExperimentNumber(all[i - 1], i);
  EXPECT_EQ(all[5].status, "planned");
  EXPECT_FALSE(all[5].outcome.has_value());
  EXPECT_FALSE(all[5].prediction.has_value());
  EXPECT_FALSE(all[5].surprise.has_value());
  EXPECT_EQ(all[6].status, "failed");
  EXPECT_EQ(all[6].failure_reason, "the robot lost contact with the cube");
  EXPECT_EQ(kb->experiments(run.id, "failed").size(), 1u);

  // Each experiment left one audit line, in the same transaction.
  const auto events = kb->events(run.id);
  ASSERT_EQ(events.size(), 7u);
  EXPECT_EQ(events[0].kind, "experiment");
  EXPECT_EQ(events[0].text, "experiment 1 done: push red_cube on +x");

  ASSERT_TRUE(kb->findResumableRun().has_value());
  EXPECT_EQ(kb->findResumableRun()->id, run.id);
  kb->finishRun(run.id);
  EXPECT_FALSE(kb->findResumableRun().has_value());
  EXPECT_EQ(kb->run(run.id)->status, "finished");
  EXPECT_FALSE(kb->run(run.id)->finished.empty());
  EXPECT_EQ(kb->run(run.id)->parameters_json, run.parameters_json);
  // A finished run takes no more experiments.
  EXPECT_THROW(kb->recordExperiment(experimentNumber(run.id, 8)), ValidationError);
  EXPECT_THROW(kb->finishRun(run.id, "done"), ValidationError);
}

TEST(KnowledgeBase, InvalidInputWritesNothing) {
  TempDir dir;
  const std::string path = dir.file("kb.sqlite");
  auto kb = KnowledgeBase::open(path);
  const RunInfo run = kb->createRun("r", "{}", 1, "random");
  kb->recordExperiment(experimentNumber(run.id, 1));
  const std::int64_t events_before = countRows(path, "SELECT count(*) FROM events");

  auto expectRejected = [&](ExperimentRecord r, const std::string& expected_phrase) {
    try {
      kb->recordExperiment(r);
      ADD_FAILURE() << "accepted; expected: " << expected_phrase;
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find(expected_phrase), std::string::npos) << e.what();
    }
  };
  ExperimentRecord r = experimentNumber(run.id, 2);
  r.experiment.offset = std::nan("");
  expectRejected(r, "experiment.offset is NaN");
  r = experimentNumber(run.id, 2);
  r.experiment.side = "top";
  expectRejected(r, "experiment.side");
  r = experimentNumber(run.id, 2);
  r.experiment.object = "";
  expectRejected(r, "experiment.object is empty");
  r = experimentNumber(run.id, 2);
  r.after.objects[1].extra["hue"] = std::numeric_limits<double>::infinity();
  expectRejected(r, "experiment.after.objects[1].extra[hue] is +inf");
  r = experimentNumber(run.id, 2);
  r.before.objects.resize(kMaxObjectsPerFeatureVector + 1, r.before.objects[0]);
  expectRejected(r, "experiment.before.objects has 65 elements");
  r = experimentNumber(run.id, 2);
  r.outcome.reset();
  expectRejected(r, "experiment.outcome is missing");
  r = experimentNumber(run.id, 2);
  r.outcome->dyaw = 4.0;
  expectRejected(r, "experiment.outcome.dyaw is 4");
  r = experimentNumber(run.id, 2);
  r.prediction->std.dx = -1;
  expectRejected(r, "experiment.prediction.std.dx is -1");
  r = experimentNumber(run.id, 2);
  r.status = "failed";
  expectRejected(r, "experiment.failure_reason is empty");
  r = experimentNumber(run.id, 2);
  r.seq = 1;
  expectRejected(r, "experiment.seq 1 already exists in run");
  r = experimentNumber(run.id + 10, 2);
  expectRejected(r, "is not a run of this knowledge base");
  r = experimentNumber(run.id, 2);
  r.failure_reason = std::string(KnowledgeBase::kMaxTextLength + 1, 'a');
  expectRejected(r, "experiment.failure_reason");

  EXPECT_THROW(kb->createRun("r2", "not json", 1, "random"), ValidationError);
  EXPECT_THROW(kb->createRun("r2", "[1, 2]", 1, "random"), ValidationError);
  EXPECT_THROW(kb->createRun("", "{}", 1, "random"), ValidationError);
  Notion bad{"red_cube", "moves_when_pushed", 1.0, 1.5, 3, "red moves"};
  kb->replaceNotions(run.id, {Notion{"red_cube", "moves_when_pushed", 1.0, 0.9, 3, "The red cube moves."}});
  EXPECT_THROW(kb->replaceNotions(run.id, {Notion{"a", "b", 0, 0.5, 1, "ok"}, bad}), ValidationError);
  EXPECT_THROW(kb->storeModel(run.id, "m", "f", "", 0), ValidationError);
  EXPECT_THROW(kb->recordGoal(GoalRecord{0, run.id, "red_cube", std::nan(""), 0, false, 0, 0, ""}), ValidationError);
  EXPECT_THROW(kb->appendEvent(run.id, 0, "", "kind", "text"), ValidationError);

  // Nothing of the above reached the file.
  EXPECT_EQ(countRows(path, "SELECT count(*) FROM experiments"), 1);
  EXPECT_EQ(countRows(path, "SELECT count(*) FROM runs"), 1);
  EXPECT_EQ(countRows(path, "SELECT count(*) FROM events"), events_before);
  EXPECT_EQ(countRows(path, "SELECT count(*) FROM models"), 0);
  EXPECT_EQ(countRows(path, "SELECT count(*) FROM goals"), 0);
  ASSERT_EQ(kb->notions(run.id).size(), 1u);
  EXPECT_EQ(kb->notions(run.id)[0].text, "The red cube moves.");
  // And the knowledge base still works.
  EXPECT_EQ(kb->recordExperiment(experimentNumber(run.id, 2)).seq, 2);
}

TEST(KnowledgeBase, ModelsNotionsGoalsEvents) {
  auto kb = KnowledgeBase::open(":memory:");
  const RunInfo run = kb->createRun("r", "{}", 7, "curiosity");
  EXPECT_FALSE(kb->latestModel(run.id, "push_learner").has_value());
  std::string bytes("\0\x01\xff binary \0 bytes", 17);
  kb->storeModel(run.id, "push_learner", "opencv-yaml/1", "old", 3);
  kb->storeModel(run.id, "push_learner", "opencv-yaml/1", bytes, 10);
  kb->storeModel(run.id, "other", "x", "other", 1);
  const auto model = kb->latestModel(run.id, "push_learner");
  ASSERT_TRUE(model.has_value());
  EXPECT_EQ(model->blob, bytes);
  EXPECT_EQ(model->sample_count, 10);
  EXPECT_EQ(model->format, "opencv-yaml/1");

  const std::vector<Notion> first{{"blue_cube", "does_not_move_when_pushed", 0.01, 0.9, 5, "The blue cube does not move."},
                                  {"red_cube", "moves_when_pushed", 0.95, 1.0, 6, "The red cube moves."}};
  kb->replaceNotions(run.id, first);
  const std::vector<Notion> second{{"red_cube", "slides_further_than_pushed", 1.2, 0.8, 9, "It slides."}};
  kb->replaceNotions(run.id, second);
  const auto notions = kb->notions(run.id);
  ASSERT_EQ(notions.size(), 1u);
  EXPECT_EQ(notions[0].predicate, "slides_further_than_pushed");
  EXPECT_EQ(notions[0].support, 9);
  EXPECT_DOUBLE_EQ(notions[0].value, 1.2);

  GoalRecord goal{0, run.id, "red_cube", 0.3, -0.2, true, 0.012, 4, ""};
  const GoalRecord stored = kb->recordGoal(goal);
  EXPECT_GT(stored.id, 0);
  const auto goals = kb->goals(run.id);
  ASSERT_EQ(goals.size(), 1u);
  EXPECT_TRUE(goals[0].reached);
  EXPECT_EQ(goals[0].pushes_used, 4);
  EXPECT_DOUBLE_EQ(goals[0].final_error, 0.012);

  for (int i = 0; i < 5; ++i) kb->appendEvent(run.id, i, "motivation", "note", "event " + std::to_string(i));
  kb->appendEvent(0, 9, "supervisor", "start", "no run");
  const auto last = kb->events(run.id, 2);
  ASSERT_EQ(last.size(), 2u);
  EXPECT_EQ(last[0].text, "event 3");
  EXPECT_EQ(last[1].text, "event 4");
  EXPECT_EQ(kb->events(0).size(), 1u);
}

TEST(KnowledgeBase, NotionReplacementIsAllOrNothing) {
  TempDir dir;
  const std::string path = dir.file("kb.sqlite");
  std::int64_t run_id = 0;
  {
    auto kb = KnowledgeBase::open(path);
    run_id = kb->createRun("r", "{}", 1, "random").id;
    kb->replaceNotions(run_id, {{"a", "p", 1, 1, 1, "old one"}, {"b", "p", 1, 1, 1, "old two"}});
  }
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    auto kb = KnowledgeBase::open(path);
    int inserted = 0;
    kb->setFaultHookForTesting([&](const char* point) {
      if (std::string(point) == "notions:inserted" && ++inserted == 2) _exit(3);
    });
    kb->replaceNotions(run_id, {{"c", "p", 1, 1, 1, "new one"}, {"d", "p", 1, 1, 1, "new two"},
                                {"e", "p", 1, 1, 1, "new three"}});
    _exit(0);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 3);
  auto kb = KnowledgeBase::open(path);
  const auto notions = kb->notions(run_id);
  ASSERT_EQ(notions.size(), 2u);
  EXPECT_EQ(notions[0].text, "old one");
  EXPECT_EQ(notions[1].text, "old two");
}

// A process that dies inside a write transaction (clean _exit, abort, at each point of the transaction)
// loses none of its committed experiments and leaves no part of the one it was writing.
TEST(KnowledgeBase, CrashMidTransactionKeepsCommittedAndNothingPartial) {
  constexpr int kCommitted = 20;
  for (const char* point : {"experiment:inserted", "experiment:before_commit"}) {
    for (const bool use_abort : {false, true}) {
      SCOPED_TRACE(std::string(point) + (use_abort ? " abort" : " _exit"));
      TempDir dir;
      const std::string path = dir.file("kb.sqlite");
      std::int64_t run_id = 0;
      {
        auto kb = KnowledgeBase::open(path);
        run_id = kb->createRun("crash", "{}", 3, "random").id;
      }
      const pid_t child = fork();
      ASSERT_GE(child, 0);
      if (child == 0) {
        auto kb = KnowledgeBase::open(path);
        for (int i = 1; i <= kCommitted; ++i) kb->recordExperiment(experimentNumber(run_id, i));
        const std::string where = point;
        kb->setFaultHookForTesting([where, use_abort](const char* p) {
          if (where != p) return;
          if (use_abort) {
            signal(SIGABRT, SIG_DFL);
            std::abort();
          }
          _exit(3);
        });
        kb->recordExperiment(experimentNumber(run_id, kCommitted + 1));
        _exit(0);  // not reached: the hook ends the process
      }
      int status = 0;
      ASSERT_EQ(waitpid(child, &status, 0), child);
      if (use_abort) {
        ASSERT_TRUE(WIFSIGNALED(status));
        EXPECT_EQ(WTERMSIG(status), SIGABRT);
      } else {
        ASSERT_TRUE(WIFEXITED(status));
        EXPECT_EQ(WEXITSTATUS(status), 3);
      }

      auto kb = KnowledgeBase::open(path);
      const auto resumable = kb->findResumableRun();
      ASSERT_TRUE(resumable.has_value());
      EXPECT_EQ(resumable->id, run_id);
      EXPECT_EQ(kb->experimentCount(run_id), kCommitted);
      const auto all = kb->experiments(run_id);
      ASSERT_EQ(all.size(), static_cast<std::size_t>(kCommitted));
      for (int i = 1; i <= kCommitted; ++i) expectIsExperimentNumber(all[i - 1], i);
      EXPECT_EQ(countRows(path, "SELECT count(*) FROM events WHERE kind = 'experiment'"), kCommitted);
      // The run continues where it stopped.
      EXPECT_EQ(kb->recordExperiment(experimentNumber(run_id, kCommitted + 1)).seq, kCommitted + 1);
    }
  }
}

// SIGKILL at an arbitrary moment while a child writes as fast as it can: every experiment the child reported
// as committed is there, complete, and the rows form an unbroken 1..N.
TEST(KnowledgeBase, KilledWriterLosesNoCommittedExperiment) {
  TempDir dir;
  const std::string path = dir.file("kb.sqlite");
  std::int64_t run_id = 0;
  {
    auto kb = KnowledgeBase::open(path);
    run_id = kb->createRun("killed", "{}", 3, "random").id;
  }
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    close(fds[0]);
    auto kb = KnowledgeBase::open(path);
    for (int i = 1;; ++i) {
      const std::int64_t seq = kb->recordExperiment(experimentNumber(run_id, i)).seq;
      if (write(fds[1], &seq, sizeof seq) != sizeof seq) _exit(2);
    }
  }
  close(fds[1]);
  std::int64_t reported = 0, seq = 0;
  while (reported < 40 && read(fds[0], &seq, sizeof seq) == sizeof seq) reported = seq;
  kill(child, SIGKILL);
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFSIGNALED(status));
  while (read(fds[0], &seq, sizeof seq) == sizeof seq) reported = seq;  // what it committed before dying
  close(fds[0]);
  ASSERT_GE(reported, 40);

  auto kb = KnowledgeBase::open(path);
  const auto all = kb->experiments(run_id);
  ASSERT_GE(static_cast<std::int64_t>(all.size()), reported);
  ASSERT_LE(static_cast<std::int64_t>(all.size()), reported + 1);  // at most one committed but not yet reported
  for (std::size_t i = 0; i < all.size(); ++i) expectIsExperimentNumber(all[i], static_cast<int>(i + 1));
  EXPECT_EQ(countRows(path, "SELECT count(*) FROM events WHERE kind = 'experiment'"),
            static_cast<std::int64_t>(all.size()));
}

TEST(KnowledgeBase, ThreadsShareOneKnowledgeBase) {
  TempDir dir;
  auto kb = KnowledgeBase::open(dir.file("kb.sqlite"));
  const RunInfo run = kb->createRun("threads", "{}", 1, "random");
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < 25; ++i) {
        ExperimentRecord r = experimentNumber(run.id, 1);
        r.experiment.offset = 0.001 * t;
        r.started = 100 * t + i;  // distinct experiments (an identical one is a repeated call: stored once)
        kb->recordExperiment(r);
        kb->experimentCount(run.id);
      }
    });
  }
  for (auto& thread : threads) thread.join();
  const auto all = kb->experiments(run.id);
  ASSERT_EQ(all.size(), 100u);
  std::set<std::int64_t> seqs;
  for (const auto& r : all) seqs.insert(r.seq);
  EXPECT_EQ(seqs.size(), 100u);
  EXPECT_EQ(*seqs.rbegin(), 100);
}

TEST(KnowledgeBase, RefusesFilesThatAreNotItsDatabase) {
  TempDir dir;
  // Garbage bytes.
  const std::string garbage = dir.file("garbage.sqlite");
  {
    std::ofstream out(garbage, std::ios::binary);
    unsigned state = 12345;
    for (int i = 0; i < 16384; ++i) {
      state = state * 1103515245u + 12345u;
      out.put(static_cast<char>(state >> 16));
    }
  }
  EXPECT_NE(openError(garbage).find("is not an SQLite database"), std::string::npos) << openError(garbage);
  // A text file.
  const std::string text = dir.file("notes.txt");
  std::ofstream(text) << "these are my notes, not a database\n";
  EXPECT_NE(openError(text).find("is not an SQLite database"), std::string::npos) << openError(text);
  // Another program's SQLite database.
  const std::string other = dir.file("other.sqlite");
  execRaw(other, "CREATE TABLE accounts(id INTEGER PRIMARY KEY, owner TEXT)");
  EXPECT_NE(openError(other).find("without the XPERSIF schema"), std::string::npos) << openError(other);
  // A newer schema.
  const std::string newer = dir.file("newer.sqlite");
  { KnowledgeBase::open(newer); }
  execRaw(newer, "PRAGMA user_version = 5");
  EXPECT_NE(openError(newer).find("has schema version 5, newer than this program's (4)"), std::string::npos)
      << openError(newer);
  // A directory that does not exist.
  EXPECT_NE(openError(dir.file("no/such/dir/kb.sqlite")).find("cannot be opened"), std::string::npos);
}

TEST(KnowledgeBase, CorruptedPagesAreFoundAtOpen) {
  TempDir dir;
  const std::string path = dir.file("kb.sqlite");
  {
    auto kb = KnowledgeBase::open(path);
    const RunInfo run = kb->createRun("r", "{}", 1, "random");
    for (int i = 1; i <= 60; ++i) kb->recordExperiment(experimentNumber(run.id, i));
  }  // the last connection checkpoints the WAL into the main file
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  const auto size = static_cast<long>(in.tellg());
  in.close();
  ASSERT_GT(size, 8 * 4096);
  {
    std::fstream out(path, std::ios::binary | std::ios::in | std::ios::out);
    out.seekp(3 * 4096);
    for (int i = 0; i < 4 * 4096; ++i) out.put(static_cast<char>((i * 7919) & 0xff));
  }
  const std::string error = openError(path);
  EXPECT_FALSE(error.empty());
  EXPECT_TRUE(error.find("is corrupted") != std::string::npos ||
              error.find("is not an SQLite database") != std::string::npos)
      << error;
}

TEST(KnowledgeBase, ARepeatedRecordCallStoresTheExperimentOnce) {
  TempDir dir;
  auto kb = KnowledgeBase::open(dir.file("kb.sqlite"));
  const RunInfo run = kb->createRun("retry", "{}", 1, "random");
  const ExperimentRecord first = kb->recordExperiment(experimentNumber(run.id, 1));
  // The caller never heard the answer (the manager was killed after the commit) and calls again.
  const ExperimentRecord again = kb->recordExperiment(experimentNumber(run.id, 1));
  EXPECT_EQ(again.seq, first.seq);
  EXPECT_EQ(again.id, first.id);
  ExperimentRecord explicit_seq = experimentNumber(run.id, 1);
  explicit_seq.seq = first.seq;
  EXPECT_EQ(kb->recordExperiment(explicit_seq).id, first.id);
  EXPECT_EQ(kb->experimentCount(run.id), 1);
  // Another push at other times is another experiment, and one that only shares the seq is refused.
  ExperimentRecord later = experimentNumber(run.id, 1);
  later.started += 10;
  later.finished += 10;
  EXPECT_EQ(kb->recordExperiment(later).seq, first.seq + 1);
  later.started += 10;
  later.seq = first.seq;
  EXPECT_THROW(kb->recordExperiment(later), ValidationError);
  EXPECT_EQ(kb->experimentCount(run.id), 2);
}

TEST(KnowledgeBase, ResumeContinuesTheLatestUnfinishedRunOfThatName) {
  auto kb = KnowledgeBase::open(":memory:");
  EXPECT_FALSE(kb->resumeRun("campaign").has_value());
  const RunInfo first = kb->createRun("campaign", "{}", 3, "random");
  ExperimentRecord e = experimentNumber(first.id, 1);
  e.design = "random";
  kb->recordExperiment(e);
  kb->finishRun(first.id, "stopped");
  const RunInfo other = kb->createRun("other", "{}", 3, "random");
  kb->finishRun(other.id, "finished");
  const auto resumed = kb->resumeRun("campaign");  // stopped: resumable, and running again
  ASSERT_TRUE(resumed.has_value());
  EXPECT_EQ(resumed->id, first.id);
  EXPECT_EQ(resumed->status, "running");
  EXPECT_TRUE(resumed->finished.empty());
  EXPECT_EQ(kb->experiments(first.id).at(0).design, "random");
  EXPECT_FALSE(kb->resumeRun("other").has_value());  // finished runs are not resumed
  kb->finishRun(first.id, "finished");
  EXPECT_FALSE(kb->resumeRun("campaign").has_value());
}

namespace {
/// What schema 3 added; dropping it turns a database back into schema 2's layout.
const char* const kDropSchemaThree = "DROP TABLE world_states; DROP TABLE facts; DROP TABLE effects; DROP TABLE calls; ";

CallRecord call(std::int64_t run_id, double time, const std::string& component, const std::string& kind,
                const std::string& name, std::vector<std::string> effects = {}) {
  CallRecord c;
  c.run_id = run_id;
  c.time = time;
  c.component = component;
  c.kind = kind;
  c.name = name;
  c.outcome = kind == "command" ? "succeeded" : "ok";
  if (kind == "operation") c.code = 0;
  c.effects = std::move(effects);
  c.duration = 0.25;
  return c;
}

std::vector<std::string> factLiterals(KnowledgeBase& kb, std::int64_t run_id) {
  std::vector<std::string> literals;
  for (const auto& f : kb.facts(run_id)) literals.push_back(f.literal);
  return literals;
}
}  // namespace

TEST(KnowledgeBase, WorldStatesAreStoredPerStepReplacedWhenTakenAgainAndBadOnesRefused) {
  auto kb = KnowledgeBase::open(":memory:");
  const RunInfo run = kb->createRun("states", "{}", 1, "random");
  EXPECT_FALSE(kb->worldState(run.id, 0).has_value());
  kb->recordWorldState(run.id, 0, R"({"time": 0.5})");
  kb->recordWorldState(run.id, 1, R"({"time": 1.5})");
  kb->recordWorldState(run.id, 1, R"({"time": 2.5})");  // step 1 redone: the world as it began the second time
  EXPECT_EQ(kb->worldState(run.id, 0).value_or(""), R"({"time": 0.5})");
  EXPECT_EQ(kb->worldState(run.id, 1).value_or(""), R"({"time": 2.5})");
  EXPECT_FALSE(kb->worldState(run.id, 2).has_value());
  const auto refused = [&](std::int64_t id, std::int64_t step, const std::string& state, const std::string& words) {
    try {
      kb->recordWorldState(id, step, state);
      ADD_FAILURE() << "accepted step " << step << " of run " << id;
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  refused(run.id + 7, 0, "{}", "run");
  refused(run.id, -1, "{}", "step is -1");
  refused(run.id, 2, "", "state is empty");
  refused(run.id, 2, "{not json", "not JSON");
  refused(run.id, 2, std::string(KnowledgeBase::kMaxWorldStateBytes + 1, ' '), "at most");
  EXPECT_FALSE(kb->worldState(run.id, 2).has_value()) << "a refused state writes nothing";
}

TEST(KnowledgeBase, ASchemaTwoDatabaseIsMigratedToThreeAndKeepsItsExperiments) {
  TempDir dir;
  const std::string path = dir.file("kb.sqlite");
  {
    auto kb = KnowledgeBase::open(path);
    const RunInfo run = kb->createRun("old", "{}", 1, "grid");
    ExperimentRecord e = experimentNumber(run.id, 1);
    e.design = "grid";
    kb->recordExperiment(e);
  }
  execRaw(path, std::string(kDropSchemaThree) + "PRAGMA user_version=2;");  // as schema 2 wrote it
  auto kb = KnowledgeBase::open(path);
  EXPECT_EQ(countRows(path, "PRAGMA user_version"), KnowledgeBase::kSchemaVersion);
  EXPECT_FALSE(kb->worldState(1, 0).has_value());
  const auto all = kb->experiments(1);
  ASSERT_EQ(all.size(), 1u);
  expectIsExperimentNumber(all[0], 1);
  EXPECT_EQ(all[0].design, "grid");
  EXPECT_TRUE(kb->facts(1).empty());
  kb->recordCalls({call(1, 2.0, "manipulation", "command", "push", {"pushed(box, -x)"})});
  EXPECT_EQ(factLiterals(*kb, 1), std::vector<std::string>{"pushed(box, -x)"});
}

TEST(KnowledgeBase, CallsAreStoredWithOutcomeCodeAndEffectsAndFilteredOnQuery) {
  auto kb = KnowledgeBase::open(":memory:");
  const RunInfo run = kb->createRun("r", "{}", 1, "random");
  CallRecord refused = call(run.id, 1.0, "planner", "operation", "make_plan");
  refused.outcome = "refused";
  refused.code = 2;
  refused.reason = "invalid request: the goal is empty";
  const auto stored = kb->recordCalls({call(run.id, 0.5, "observation", "operation", "get_features", {"observed(scene)"}),
                                       refused,
                                       call(run.id, 2.0, "manipulation", "command", "push",
                                            {"pushed(box, -x, 0.01, 0.05)", "not observed(scene)"}),
                                       call(0, 0.1, "relocation", "operation", "stop", {"stopped(robot)"})});
  ASSERT_EQ(stored.size(), 4u);
  EXPECT_LT(stored[0].id, stored[1].id);

  CallFilter all;
  all.run_id = run.id;
  bool more = true;
  const auto calls = kb->calls(all, &more);
  EXPECT_FALSE(more);
  ASSERT_EQ(calls.size(), 3u);  // the call outside the run is not the run's
  EXPECT_EQ(calls[0].name, "get_features");
  EXPECT_EQ(calls[1].outcome, "refused");
  ASSERT_TRUE(calls[1].code.has_value());
  EXPECT_EQ(*calls[1].code, 2);
  EXPECT_EQ(calls[1].reason, "invalid request: the goal is empty");
  EXPECT_FALSE(calls[2].code.has_value());  // commands carry no ResultCode
  EXPECT_EQ(calls[2].effects, (std::vector<std::string>{"pushed(box, -x, 0.01, 0.05)", "not observed(scene)"}));
  EXPECT_EQ(calls[2].duration, 0.25);

  CallFilter commands = all;
  commands.kind = "command";
  ASSERT_EQ(kb->calls(commands).size(), 1u);
  CallFilter planner = all;
  planner.component = "planner";
  ASSERT_EQ(kb->calls(planner).size(), 1u);
  EXPECT_EQ(kb->calls(planner)[0].name, "make_plan");
  CallFilter late = all;
  late.since = 1.0;
  EXPECT_EQ(kb->calls(late).size(), 2u);  // at or after
  CallFilter first = all;
  first.limit = 2;
  const auto page = kb->calls(first, &more);
  EXPECT_TRUE(more);
  ASSERT_EQ(page.size(), 2u);
  EXPECT_EQ(page[1].name, "make_plan");
  CallFilter outside;
  ASSERT_EQ(kb->calls(outside).size(), 1u);
  EXPECT_EQ(kb->calls(outside)[0].name, "stop");

  auto refuses = [&](const std::function<void(CallFilter&)>& spoil, const std::string& field) {
    CallFilter bad = all;
    spoil(bad);
    try {
      kb->calls(bad);
      ADD_FAILURE() << "accepted a bad " << field;
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  refuses([](CallFilter& f) { f.kind = "lifecycle"; }, "kind");
  refuses([](CallFilter& f) { f.limit = 0; }, "limit");
  refuses([](CallFilter& f) { f.limit = KnowledgeBase::kMaxCallsPerQuery + 1; }, "limit");
  refuses([](CallFilter& f) { f.since = std::nan(""); }, "since");
  refuses([](CallFilter& f) { f.run_id = -1; }, "run_id");
  refuses([](CallFilter& f) { f.component = std::string(200, 'c'); }, "component");
}

TEST(KnowledgeBase, FactsFollowTheLatestEffectPerPredicateAndSubject) {
  auto kb = KnowledgeBase::open(":memory:");
  const RunInfo run = kb->createRun("r", "{}", 1, "random");
  const RunInfo other = kb->createRun("other", "{}", 1, "random");
  kb->recordCalls({call(run.id, 1.0, "observation", "operation", "get_features", {"observed(scene)"}),
                   call(run.id, 2.0, "relocation", "command", "go_to_pose", {"robot_at(robot, (0.1, 0.2, 0))"}),
                   call(run.id, 3.0, "manipulation", "command", "push", {"pushed(box, -x, 0.01, 0.05)", "not observed(scene)"}),
                   call(other.id, 3.0, "manipulation", "command", "push", {"pushed(ball, +y, 0, 0.05)"})});
  EXPECT_EQ(factLiterals(*kb, run.id),
            (std::vector<std::string>{"pushed(box, -x, 0.01, 0.05)", "robot_at(robot, (0.1, 0.2, 0))"}));
  // The same subject again: the later effect replaces the earlier one; another subject adds a fact.
  kb->recordCalls({call(run.id, 4.0, "relocation", "command", "go_to_pose", {"robot_at(robot, (0.3, 0.2, 1))"}),
                   call(run.id, 5.0, "manipulation", "command", "push", {"pushed(cup, +x, 0, 0.1)", "not observed(scene)"}),
                   call(run.id, 6.0, "observation", "operation", "get_features", {"observed(scene)"})});
  const auto facts = kb->facts(run.id);
  EXPECT_EQ(factLiterals(*kb, run.id),
            (std::vector<std::string>{"observed(scene)", "pushed(box, -x, 0.01, 0.05)", "pushed(cup, +x, 0, 0.1)",
                                      "robot_at(robot, (0.3, 0.2, 1))"}));
  ASSERT_EQ(facts.size(), 4u);
  EXPECT_EQ(facts[3].component, "relocation");
  EXPECT_EQ(facts[3].time, 4.0);
  EXPECT_EQ(factLiterals(*kb, other.id), std::vector<std::string>{"pushed(ball, +y, 0, 0.05)"});
}

TEST(KnowledgeBase, ABadCallInABatchIsRefusedAndNothingOfTheBatchIsStored) {
  TempDir dir;
  const std::string path = dir.file("kb.sqlite");
  auto kb = KnowledgeBase::open(path);
  const RunInfo run = kb->createRun("r", "{}", 1, "random");
  const CallRecord good = call(run.id, 1.0, "observation", "operation", "get_features", {"observed(scene)"});
  auto expectRefused = [&](CallRecord bad, const std::string& words) {
    try {
      kb->recordCalls({good, bad});
      ADD_FAILURE() << "accepted a bad call, expected: " << words;
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  CallRecord c = good;
  c.time = std::nan("");
  expectRefused(c, "calls[1].time");
  c = good;
  c.kind = "lifecycle";
  expectRefused(c, "calls[1].kind");
  c = good;
  c.component = "";
  expectRefused(c, "calls[1].component is empty");
  c = good;
  c.effects = {"pushed(box"};
  expectRefused(c, "calls[1].effects[0] 'pushed(box' is malformed");
  c = good;
  c.effects = {"pushed(?object)"};
  expectRefused(c, "has the parameter ?object");
  c = good;
  c.effects.assign(KnowledgeBase::kMaxEffectsPerCall + 1, "observed(scene)");
  expectRefused(c, "calls[1].effects");
  c = good;
  c.code = 255;
  expectRefused(c, "calls[1].code");
  c = good;
  c.duration = -1.0;
  expectRefused(c, "calls[1].duration");
  c = good;
  c.run_id = 99;
  expectRefused(c, "calls[1].run_id 99 is not a run");  // found inside the transaction: rolled back
  EXPECT_EQ(countRows(path, "SELECT count(*) FROM calls"), 0);
  EXPECT_EQ(countRows(path, "SELECT count(*) FROM effects"), 0);
  EXPECT_TRUE(kb->facts(run.id).empty());
}

TEST(KnowledgeBase, ASchemaOneDatabaseIsMigratedAndKeepsItsExperiments) {
  TempDir dir;
  const std::string path = dir.file("kb.sqlite");
  {
    auto kb = KnowledgeBase::open(path);
    const RunInfo run = kb->createRun("old", "{}", 1, "grid");
    kb->recordExperiment(experimentNumber(run.id, 1));
  }
  // As schema 1 wrote it: no design, no calls.
  execRaw(path, std::string(kDropSchemaThree) + "ALTER TABLE experiments DROP COLUMN design; PRAGMA user_version=1;");
  auto kb = KnowledgeBase::open(path);
  EXPECT_EQ(countRows(path, "PRAGMA user_version"), KnowledgeBase::kSchemaVersion);
  EXPECT_EQ(countRows(path, "SELECT count(*) FROM calls"), 0);  // migrated through 2 to 3
  const auto all = kb->experiments(1);
  ASSERT_EQ(all.size(), 1u);
  expectIsExperimentNumber(all[0], 1);
  EXPECT_EQ(all[0].design, "");
  ExperimentRecord e = experimentNumber(1, 2);
  e.design = "grid";
  kb->recordExperiment(e);
  EXPECT_EQ(kb->experiments(1).at(1).design, "grid");
}
