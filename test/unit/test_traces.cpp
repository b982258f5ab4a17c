// Traces: the record -> sample rule, offline learning from bags equal to live learning, the CSV export, and
// what the tools do with truncated, garbage and killed (unindexed) bags. No roscore: rosbag files only.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <signal.h>
#include <sys/wait.h>
#include <tf2_msgs/TFMessage.h>
#include <unistd.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "xpersif/core/evaluation/experiment_samples.h"
#include "xpersif/core/common/validation.h"
#include "xpersif/traces/bag_tools.h"
#include "xpersif/traces/offline_learning.h"
#include "xpersif/ros/experiment_conversions.h"

namespace fs = std::filesystem;
namespace traces = xpersif::traces;
using namespace xpersif::core;

namespace {

struct Cube {
  const char* name;
  double hue, k;
};
const Cube kCubes[] = {{"red_cube", 0, 0.9}, {"green_cube", 120, 0.8}, {"yellow_cube", 60, 1.3}, {"blue_cube", 240, 0.0}};

/// Synthetic records as the loop would store them: mostly done, some failed, one without the pushed object's
/// hue (the learner refuses it), seeded.
std::vector<ExperimentRecord> syntheticRecords(int n, std::uint64_t seed) {
  cv::RNG rng(seed);
  std::vector<ExperimentRecord> out;
  for (int i = 0; i < n; ++i) {
    const Cube& cube = kCubes[rng.uniform(0, 4)];
    ExperimentRecord r;
    r.id = i + 1;
    r.run_id = 7;
    r.seq = i + 1;
    r.experiment = {cube.name, pushSides()[rng.uniform(0, 4)], rng.uniform(-0.02, 0.02),
                    rng.uniform(0.01, 0.15)};  // a 4 cm cube's offsets, pushes up to 15 cm
    r.before.stamp = 2.0 * i + 0.5;
    for (const auto& c : kCubes) {
      ObjectFeatures o;
      o.name = c.name;
      o.x = rng.uniform(-0.3, 0.3);
      o.y = rng.uniform(-0.2, 0.2);
      o.yaw = rng.uniform(-0.7, 0.7);
      o.extra = {{"hue", c.hue + rng.gaussian(2.0)}, {"size", 0.04 + rng.gaussian(0.001)}, {"saturation", 0.8}};
      r.before.objects.push_back(o);
    }
    r.after = r.before;
    r.after.stamp += 1.5;
    const double d = cube.k * r.experiment.distance;
    r.after.objects[0].x += 0.01;
    r.status = (i % 9 == 4) ? "failed" : "done";
    if (r.status == "done") {
      r.outcome = Outcome{d + rng.gaussian(0.002), rng.gaussian(0.002), -100 * r.experiment.offset * d};
    } else {
      r.failure_reason = "push aborted: lost contact, \"retry\"";
    }
    if (i == 11) {  // VISION did not compute the hue of the pushed object this time
      for (auto& o : r.before.objects)
        if (o.name == cube.name) o.extra.erase("hue");
    }
    r.prediction = Prediction{{0.05, 0.0, 0.0}, {0.1, 0.05, 0.5}};
    r.surprise = 0.01 * i;
    r.started = 2.0 * i;
    r.finished = 2.0 * i + 1.9;
    out.push_back(r);
  }
  return out;
}

PushLearnerConfig learnerConfig() {
  PushLearnerConfig c;
  c.one_hot_identity = true;
  c.identities = {"red_cube", "green_cube", "yellow_cube", "blue_cube"};
  c.ensemble_size = 4;
  c.trees_per_member = 8;
  c.seed = 42;
  return c;
}

class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/xpersif-traces-XXXXXX";
    path_ = ::mkdtemp(tmpl);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// The records on the experiments topic, split over two bags (as `rosbag record --split` would), with /tf
/// at 100 Hz of simulated time between them.
void writeRun(const std::vector<ExperimentRecord>& records, const std::string& dir) {
  const std::size_t half = records.size() / 2;
  for (int part = 0; part < 2; ++part) {
    rosbag::Bag bag(dir + "/xpersif_" + std::to_string(part) + ".bag", rosbag::bagmode::Write);
    bag.setCompression(part == 0 ? rosbag::compression::LZ4 : rosbag::compression::Uncompressed);
    const std::size_t begin = part == 0 ? 0 : half, end = part == 0 ? half : records.size();
    for (std::size_t i = begin; i < end; ++i) {
      const double t0 = records[i].started;
      for (int k = 0; k < 200; ++k) {  // 2 s of /tf
        tf2_msgs::TFMessage tf;
        geometry_msgs::TransformStamped t;
        t.header.stamp.fromSec(t0 + 0.01 * k + 0.001);
        t.header.frame_id = "world";
        t.child_frame_id = "red_cube";
        t.transform.translation.x = 0.001 * k;
        const double yaw = 0.3;
        t.transform.rotation.z = std::sin(yaw / 2);
        t.transform.rotation.w = std::cos(yaw / 2);
        tf.transforms.push_back(t);
        t.child_frame_id = "khepera/left_wheel";
        tf.transforms.push_back(t);
        bag.write("/tf", t.header.stamp, tf);
      }
      ros::Time when;
      when.fromSec(records[i].finished + 0.05);
      auto msg = xpersif::toMsg(records[i]);
      msg.design = "random";
      bag.write(traces::kExperimentsTopic, when, msg);
      auto features = xpersif::toMsg(records[i].after);
      features.source = "/xpersif/observation";
      features.robot_found = true;
      features.robot.x = 0.25;
      bag.write("/xpersif/observation/features", when, features);
    }
    bag.close();
  }
}

std::vector<PushInput> queries() {
  std::vector<PushInput> out;
  cv::RNG rng(99);
  for (int i = 0; i < 60; ++i) {
    const Cube& cube = kCubes[i % 4];
    PushInput in;
    in.experiment = {cube.name, pushSides()[rng.uniform(0, 4)], rng.uniform(-0.02, 0.02), rng.uniform(0.01, 0.15)};
    in.object.name = cube.name;
    in.object.extra = {{"hue", cube.hue}, {"size", 0.04}};
    out.push_back(in);
  }
  return out;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

}  // namespace

TEST(ExperimentSamples, OnlyDoneRecordsWithThePushedObjectGiveSamples) {
  const auto records = syntheticRecords(12, 3);
  std::string why;
  auto done = pushSampleOf(records[0], &why);
  ASSERT_TRUE(done) << why;
  EXPECT_EQ(done->input.object.name, records[0].experiment.object);
  EXPECT_EQ(done->input.object.x, records[0].before.find(records[0].experiment.object)->x);
  EXPECT_EQ(done->input.object.extra.at("hue"), records[0].before.find(records[0].experiment.object)->extra.at("hue"));
  EXPECT_EQ(done->outcome.dx, records[0].outcome->dx);

  EXPECT_FALSE(pushSampleOf(records[4], &why));  // failed
  EXPECT_NE(why.find("failed"), std::string::npos) << why;

  ExperimentRecord missing = records[0];
  missing.before.objects.erase(missing.before.objects.begin(), missing.before.objects.end());
  EXPECT_FALSE(pushSampleOf(missing, &why));
  EXPECT_NE(why.find("not in the 'before'"), std::string::npos) << why;

  PushLearner learner(learnerConfig());
  EXPECT_FALSE(learnFromRecord(learner, records[11], &why));  // no hue: the learner refuses, nothing changes
  EXPECT_NE(why.find("hue"), std::string::npos) << why;
  EXPECT_EQ(learner.sampleCount(), 0u);
  EXPECT_TRUE(learnFromRecord(learner, records[0], &why)) << why;
  EXPECT_EQ(learner.sampleCount(), 1u);
}

TEST(OfflineLearning, TrainedFromBagsPredictsExactlyAsTrainedLive) {
  TempDir dir;
  const auto records = syntheticRecords(60, 11);
  writeRun(records, dir.path());

  PushLearner live(learnerConfig());
  std::size_t added = 0;
  for (const auto& r : records) added += learnFromRecord(live, r) ? 1 : 0;

  PushLearner offline(learnerConfig());
  const auto files = traces::bagFiles({dir.path()});
  ASSERT_EQ(files.size(), 2u);
  const auto report = traces::trainFromBags(offline, files);
  EXPECT_EQ(report.records, records.size());
  EXPECT_EQ(report.used, added);
  EXPECT_EQ(report.skipped.size(), records.size() - added);
  ASSERT_GT(added, 40u);

  EXPECT_EQ(offline.save(), live.save());  // same samples, same order, same fingerprint
  for (const auto& q : queries()) {
    const Prediction a = live.predict(q), b = offline.predict(q);
    EXPECT_EQ(a.mean.dx, b.mean.dx);
    EXPECT_EQ(a.mean.dy, b.mean.dy);
    EXPECT_EQ(a.mean.dyaw, b.mean.dyaw);
    EXPECT_EQ(a.std.dx, b.std.dx);
    EXPECT_EQ(a.std.dyaw, b.std.dyaw);
  }
  // A different order is a different model: the comparison above can fail.
  std::vector<ExperimentRecord> reversed(records.rbegin(), records.rend());
  PushLearner shuffled(learnerConfig());
  trainFromRecords(shuffled, reversed);
  bool differs = false;
  for (const auto& q : queries()) differs = differs || shuffled.predict(q).mean.dx != live.predict(q).mean.dx;
  EXPECT_TRUE(differs);
}

TEST(Export, WritesOneRowPerExperimentAndPoses) {
  TempDir dir, out;
  const auto records = syntheticRecords(10, 5);
  writeRun(records, dir.path());
  traces::ExportOptions options;
  options.out_dir = out.path();
  options.features = true;
  options.frames_regex = "red_cube";
  const auto summary = traces::exportCsv(traces::bagFiles({dir.path()}), options);
  EXPECT_EQ(summary.experiments, 10u);
  EXPECT_EQ(summary.poses, 10u * 200u);  // the wheel is filtered out

  const auto rows = lines(readFile(out / "experiments.csv"));
  ASSERT_EQ(rows.size(), 11u);
  EXPECT_EQ(rows[0].rfind("bag,time,run_id,seq,id,design,object,side,offset,distance,status,reason,before_stamp,"
                          "before_x,before_y,before_yaw,before_feature_hue,before_feature_saturation,before_feature_size,after_stamp",
                          0),
            0u)
      << rows[0];
  EXPECT_NE(rows[0].find("dx,dy,dyaw,predicted_dx"), std::string::npos);
  EXPECT_NE(rows[1].find(",7,1,1,random," + records[0].experiment.object + ","), std::string::npos) << rows[1];
  EXPECT_NE(rows[5].find("\"push aborted: lost contact, \"\"retry\"\"\""), std::string::npos) << rows[5];

  const auto poses = lines(readFile(out / "poses.csv"));
  ASSERT_EQ(poses.size(), 2001u);
  EXPECT_EQ(poses[0], "time,frame,parent,x,y,z,yaw,static");
  EXPECT_NE(poses[1].find(",red_cube,world,0,0,0,"), std::string::npos) << poses[1];
  EXPECT_NEAR(std::stod(poses[1].substr(poses[1].rfind(",0,0,0,") + 7)), 0.3, 1e-12) << poses[1];

  const auto features = lines(readFile(out / "features.csv"));
  EXPECT_EQ(features.size(), 1u + 10u * 5u);  // four cubes and the robot per vector

  options.pose_period = 0.1;  // at most one row per frame per 0.1 s
  EXPECT_EQ(traces::exportCsv(traces::bagFiles({dir.path()}), options).poses, 10u * 20u);

  options.out_dir = out / "new/tables";  // a directory not made yet is made, as the guide runs it
  EXPECT_EQ(traces::exportCsv(traces::bagFiles({dir.path()}), options).experiments, 10u);
  EXPECT_TRUE(std::filesystem::is_regular_file(out / "new/tables/experiments.csv"));
}

TEST(Export, TruncatedOrGarbageBagsGiveASentenceNamingTheFile) {
  TempDir dir, out;
  writeRun(syntheticRecords(10, 5), dir.path());
  const std::string good = dir / "xpersif_0.bag";
  const std::string bytes = readFile(good);
  traces::ExportOptions options;
  options.out_dir = out.path();
  int refused = 0;
  auto attempt = [&](const std::string& name, const std::string& content, bool must_fail) {
    const std::string path = out / name;
    std::ofstream(path, std::ios::binary) << content;
    try {
      traces::exportCsv(traces::bagFiles({path}), options);
      EXPECT_FALSE(must_fail) << name << " was exported";
    } catch (const traces::BagError& e) {
      ++refused;
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }  // anything else (or a crash) fails the test
    fs::remove(path);
  };
  for (double f : {0.0005, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.9999})
    attempt("cut_" + std::to_string(f) + ".bag", bytes.substr(0, static_cast<std::size_t>(bytes.size() * f)), true);
  attempt("header_only.bag", bytes.substr(0, 13), true);
  attempt("empty.bag", "", true);
  cv::RNG rng(8);
  std::string garbage(100000, '\0');
  for (auto& c : garbage) c = static_cast<char>(rng.uniform(0, 256));
  attempt("garbage.bag", garbage, true);
  attempt("garbage_with_magic.bag", "#ROSBAG V2.0\n" + garbage, true);
  EXPECT_GE(refused, 13);
  EXPECT_FALSE(fs::exists(out / "experiments.csv"));  // no half table left behind
  EXPECT_FALSE(fs::exists(out / "experiments.csv.tmp"));
  // Corrupt bytes inside the data: the exporter may read garbage values or refuse, but never crash.
  for (int i = 0; i < 40; ++i) {
    std::string damaged = bytes;
    const std::size_t at = 4096 + static_cast<std::size_t>(rng.uniform(0.0, 1.0) * (bytes.size() - 8192));
    for (int k = 0; k < 64; ++k) damaged[at + k] = static_cast<char>(rng.uniform(0, 256));
    attempt("damaged_" + std::to_string(i) + ".bag", damaged, false);
  }
  EXPECT_THROW(traces::bagFiles({dir / "missing.bag"}), traces::BagError);
  EXPECT_THROW(traces::bagFiles({dir / "x.bag.active"}), traces::BagError);
}

TEST(Export, ToolExitsNonZeroWithTheFileNamed) {
  TempDir dir;
  writeRun(syntheticRecords(4, 5), dir.path());
  const std::string bytes = readFile(dir / "xpersif_0.bag");
  std::ofstream(dir / "cut.bag", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  const std::string cmd = std::string(XPERSIF_EXPORT) + " -o " + dir.path() + " " + (dir / "cut.bag") + " 2>" +
                          (dir / "err.txt");
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 3) << "a bad input file (doc/exit-codes.md)";
  EXPECT_NE(readFile(dir / "err.txt").find(dir / "cut.bag"), std::string::npos) << readFile(dir / "err.txt");
  const std::string ok = std::string(XPERSIF_EXPORT) + " -o " + dir.path() + " " + dir / "xpersif_0.bag" + " >/dev/null";
  EXPECT_EQ(std::system(ok.c_str()), 0);
  const std::string usage = std::string(XPERSIF_EXPORT) + " --frames '(' x.bag 2>/dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(usage.c_str())), 2);
}

TEST(Recover, ABagWhoseWriterWasKilledIsReindexedAndCounted) {
  TempDir dir;
  const std::string path = dir / "killed.bag.active";
  const int kMessages = 20000;
  const pid_t child = ::fork();
  if (child == 0) {  // a recorder that dies with SIGKILL in the middle of writing: no index, no closed chunk
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    bag.setChunkThreshold(64 * 1024);
    for (int k = 0; k < kMessages; ++k) {
      tf2_msgs::TFMessage tf;
      geometry_msgs::TransformStamped t;
      t.header.stamp.fromSec(1.0 + 0.001 * k);
      t.child_frame_id = "red_cube";
      t.transform.rotation.w = 1;
      tf.transforms.push_back(t);
      bag.write("/tf", t.header.stamp, tf);
    }
    ::kill(::getpid(), SIGKILL);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_THROW(traces::bagFiles({dir.path()}), traces::BagError);  // refused, with advice

  const auto r = traces::recoverBag(path);
  EXPECT_EQ(r.recovered, dir / "killed.bag");
  EXPECT_EQ(r.backup, path + ".orig");
  EXPECT_GT(r.messages, static_cast<std::size_t>(kMessages) * 9 / 10);  // all but the last, open chunk
  EXPECT_LE(r.messages, static_cast<std::size_t>(kMessages));
  EXPECT_EQ(r.per_topic.at("/tf"), r.messages);
  // Now the run directory exports.
  traces::ExportOptions options;
  options.out_dir = dir.path();
  EXPECT_EQ(traces::exportCsv(traces::bagFiles({dir.path()}), options).poses, r.messages);
  // Garbage cannot be recovered: a sentence, not a crash.
  std::ofstream(dir / "junk.bag.active") << "not a bag at all";
  try {
    traces::recoverBag(dir / "junk.bag.active");
    ADD_FAILURE() << "junk was recovered";
  } catch (const traces::BagError& e) {
    EXPECT_NE(std::string(e.what()).find("junk.bag.active"), std::string::npos) << e.what();
  }
}
