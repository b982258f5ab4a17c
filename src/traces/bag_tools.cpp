#include "xpersif/traces/bag_tools.h"

#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <tf2_msgs/TFMessage.h>
#include <topic_tools/shape_shifter.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string.h>  // strsignal
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <set>
#include <sstream>

#include "xpersif/FeatureVector.h"

namespace fs = std::filesystem;

namespace xpersif::traces {

const std::vector<std::string>& defaultFeatureTopics() {
  static const std::vector<std::string> topics{"/xpersif/vision/features", "/xpersif/observation/features"};
  return topics;
}

namespace {

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string activeAdvice(const std::string& path) {
  return "bag '" + path + "' is still '.active': its recorder was killed before it closed the bag; recover it first " +
         "with `xpersif_recover_bag " + path + "`";
}

/// Open @p path for reading or throw a BagError that names it and says what was wrong.
void openBag(rosbag::Bag& bag, const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw BagError("bag '" + path + "' does not exist");
  if (fs::is_directory(path, ec)) throw BagError("'" + path + "' is a directory, not a bag");
  if (fs::file_size(path, ec) == 0) throw BagError("bag '" + path + "' is empty (0 bytes)");
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagUnindexedException&) {
    throw BagError("bag '" + path + "' is unindexed (its recorder did not close it; truncated or killed); recover it " +
                   "with `xpersif_recover_bag " + path + "`");
  } catch (const std::exception& e) {
    throw BagError("bag '" + path + "' cannot be read: " + e.what() + " (not a bag, truncated or corrupt)");
  }
}

/**
 * Run @p fn on @p path in a child process and return what it returns, or throw a BagError with its sentence.
 * Why: rosbag's C++ reader trusts the offsets and lengths inside a bag, and some corruptions make it read out of
 * bounds (SIGSEGV in Bag::readHeaderFromBuffer) rather than throw; a crash in the child becomes a sentence
 * naming the file, and the parent then reads only bags a child read through without harm (reading is
 * deterministic).
 */
std::string isolated(const std::string& path, const std::function<std::string()>& fn) {
  int fds[2];
  if (::pipe(fds) != 0) throw BagError("cannot check bag '" + path + "': pipe: " + std::strerror(errno));
  std::fflush(nullptr);
  const pid_t child = ::fork();
  if (child < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw BagError("cannot check bag '" + path + "': fork: " + std::strerror(errno));
  }
  if (child == 0) {
    ::close(fds[0]);
    std::string reply;
    try {
      reply = "O" + fn();
    } catch (const std::exception& e) {
      reply = std::string("E") + e.what();
    } catch (...) {
      reply = "Eunknown error";
    }
    for (std::size_t done = 0; done < reply.size();) {
      const ssize_t n = ::write(fds[1], reply.data() + done, reply.size() - done);
      if (n <= 0) break;
      done += static_cast<std::size_t>(n);
    }
    ::_exit(0);  // no atexit handlers, no destructors of the parent's objects
  }
  ::close(fds[1]);
  std::string reply;
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    reply.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status)) {
    throw BagError("bag '" + path + "' is corrupt: reading it crashed rosbag's reader (" + strsignal(WTERMSIG(status)) +
                   "); its chunks or index hold impossible offsets or lengths");
  }
  if (reply.empty()) throw BagError("bag '" + path + "' could not be checked (the checking process said nothing)");
  if (reply[0] == 'E') {
    const std::string what = reply.substr(1);
    throw BagError(what.rfind("bag '", 0) == 0 ? what : "bag '" + path + "': " + what);
  }
  return reply.substr(1);
}

double startTime(const std::string& path) {
  return std::stod(isolated(path, [&path]() -> std::string {
    rosbag::Bag bag;
    openBag(bag, path);
    try {
      rosbag::View view(bag);
      const double t = view.size() == 0 ? 0.0 : view.getBeginTime().toSec();
      char text[64];
      std::snprintf(text, sizeof text, "%.9f", t);
      return text;
    } catch (const std::exception& e) {
      throw BagError("bag '" + path + "' has a corrupt index: " + e.what());
    }
  }));
}

/// Read (and deserialize, for the types the tools know) every message on @p topics, in a child process.
void checkReadable(const std::string& path, const std::vector<std::string>& topics) {
  isolated(path, [&]() -> std::string {
    rosbag::Bag bag;
    openBag(bag, path);
    std::size_t read = 0;
    try {
      rosbag::View view(bag, rosbag::TopicQuery(topics));
      for (const rosbag::MessageInstance& m : view) {
        const std::string& type = m.getDataType();
        if (type == "tf2_msgs/TFMessage") m.instantiate<tf2_msgs::TFMessage>();
        else if (type == "xpersif/ExperimentRecord") m.instantiate<xpersif::ExperimentRecord>();
        else if (type == "xpersif/FeatureVector") m.instantiate<xpersif::FeatureVector>();
        else m.instantiate<topic_tools::ShapeShifter>();  // reads the bytes
        ++read;
      }
    } catch (const std::exception& e) {
      throw BagError("bag '" + path + "' is corrupt after " + std::to_string(read) + " messages read: " + e.what());
    }
    return "";
  });
}

/// Call @p fn for every message on @p topics of every bag in order; errors name the bag.
void forEachMessage(const std::vector<std::string>& files, const std::vector<std::string>& topics,
                    const std::function<void(const std::string&, const rosbag::MessageInstance&)>& fn) {
  for (const auto& path : files) {
    checkReadable(path, topics);
    rosbag::Bag bag;
    openBag(bag, path);
    std::size_t read = 0;
    try {
      rosbag::View view(bag, rosbag::TopicQuery(topics));
      for (const rosbag::MessageInstance& m : view) {
        fn(path, m);
        ++read;
      }
    } catch (const BagError&) {
      throw;
    } catch (const OutputError&) {
      throw;
    } catch (const std::exception& e) {
      throw BagError("bag '" + path + "' is corrupt after " + std::to_string(read) + " messages read: " + e.what());
    }
    bag.close();
  }
}

template <class M>
boost::shared_ptr<M> instantiate(const rosbag::MessageInstance& m, const std::string& path) {
  auto msg = m.instantiate<M>();
  if (!msg) {
    throw BagError("bag '" + path + "': topic '" + m.getTopic() + "' carries " + m.getDataType() + " (md5 " +
                   m.getMD5Sum() + "), not " + ros::message_traits::DataType<M>::value() + " (md5 " +
                   ros::message_traits::MD5Sum<M>::value() + ")");
  }
  return msg;
}

// ---- CSV --------------------------------------------------------------------------------------------

std::string num(double v) {
  if (!std::isfinite(v)) return std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf");
  char buf[64];
  auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest text that reads back as the same double
  return std::string(buf, r.ptr);
}

std::string field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

class CsvFile {
 public:
  CsvFile(const std::string& dir, const std::string& name) : final_(dir + "/" + name), tmp_(final_ + ".tmp") {
    out_.open(tmp_, std::ios::out | std::ios::trunc);
    if (!out_) throw OutputError("cannot write '" + tmp_ + "': " + std::strerror(errno));
  }
  ~CsvFile() {
    if (!committed_) {
      out_.close();
      std::remove(tmp_.c_str());
    }
  }
  void row(const std::vector<std::string>& cells) {
    for (std::size_t i = 0; i < cells.size(); ++i) out_ << (i ? "," : "") << cells[i];
    out_ << '\n';
    if (!out_) throw OutputError("cannot write '" + tmp_ + "' (disk full?)");
  }
  std::string commit() {
    out_.close();
    if (!out_ || std::rename(tmp_.c_str(), final_.c_str()) != 0) throw OutputError("cannot write '" + final_ + "'");
    committed_ = true;
    return final_;
  }

 private:
  std::string final_, tmp_;
  std::ofstream out_;
  bool committed_ = false;
};

double yawOf(double x, double y, double z, double w) {
  return std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
}

const xpersif::ObjectFeatures* findObject(const xpersif::FeatureVector& v, const std::string& name) {
  for (const auto& o : v.objects)
    if (o.name == name) return &o;
  return nullptr;
}

std::string extraOf(const xpersif::ObjectFeatures* o, const std::string& name) {
  if (!o) return "";
  for (std::size_t i = 0; i < o->feature_names.size() && i < o->feature_values.size(); ++i)
    if (o->feature_names[i] == name) return num(o->feature_values[i]);
  return "";
}

}  // namespace

std::vector<std::string> bagFiles(const std::vector<std::string>& inputs) {
  std::vector<std::string> files;
  for (const auto& input : inputs) {
    std::error_code ec;
    if (fs::is_directory(input, ec)) {
      std::vector<std::string> found, active;
      for (const auto& entry : fs::directory_iterator(input, ec)) {
        const std::string p = entry.path().string();
        if (!entry.is_regular_file()) continue;
        if (endsWith(p, ".bag")) found.push_back(p);
        if (endsWith(p, ".bag.active")) active.push_back(p);
      }
      if (ec) throw BagError("cannot list directory '" + input + "': " + ec.message());
      if (!active.empty()) throw BagError(activeAdvice(active.front()));
      if (found.empty()) throw BagError("directory '" + input + "' holds no .bag file");
      std::sort(found.begin(), found.end());
      files.insert(files.end(), found.begin(), found.end());
    } else {
      if (endsWith(input, ".bag.active")) throw BagError(activeAdvice(input));
      files.push_back(input);
    }
  }
  std::vector<std::pair<double, std::string>> timed;
  for (const auto& f : files) timed.emplace_back(startTime(f), f);
  std::stable_sort(timed.begin(), timed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  files.clear();
  for (auto& [t, f] : timed) files.push_back(f);
  return files;
}

std::vector<RecordedExperiment> readExperimentRecords(const std::vector<std::string>& files, const std::string& topic) {
  std::vector<RecordedExperiment> out;
  forEachMessage(files, {topic}, [&](const std::string& path, const rosbag::MessageInstance& m) {
    auto msg = instantiate<xpersif::ExperimentRecord>(m, path);
    out.push_back({path, m.getTime().toSec(), *msg});
  });
  return out;
}

namespace {

// ---- experiments.csv: records are few; they are read first to know every extra feature name ----

/// The extra feature names of the pushed object, before and after, over every record: a column each.
std::set<std::string> pushedObjectFeatureNames(const std::vector<RecordedExperiment>& records) {
  std::set<std::string> names;
  for (const auto& r : records) {
    for (const auto* v : {&r.record.before, &r.record.after}) {
      if (const auto* o = findObject(*v, r.record.experiment.object))
        names.insert(o->feature_names.begin(), o->feature_names.end());
    }
  }
  return names;
}

std::vector<std::string> experimentsHeader(const std::set<std::string>& extra_names) {
  std::vector<std::string> header{"bag", "time", "run_id", "seq", "id", "design", "object", "side", "offset",
                                  "distance", "status", "reason", "before_stamp", "before_x", "before_y",
                                  "before_yaw"};
  for (const auto& n : extra_names) header.push_back("before_feature_" + n);
  for (const char* c : {"after_stamp", "after_x", "after_y", "after_yaw"}) header.push_back(c);
  for (const auto& n : extra_names) header.push_back("after_feature_" + n);
  for (const char* c : {"dx", "dy", "dyaw", "predicted_dx", "predicted_dy", "predicted_dyaw", "predicted_std_dx",
                        "predicted_std_dy", "predicted_std_dyaw", "surprise", "started", "finished"})
    header.push_back(c);
  return header;
}

std::vector<std::string> experimentRow(const RecordedExperiment& e, const std::set<std::string>& extra_names) {
  const auto& r = e.record;
  std::vector<std::string> row{field(fs::path(e.bag).filename().string()), num(e.time), std::to_string(r.run_id),
                               std::to_string(r.seq), std::to_string(r.id), field(r.design),
                               field(r.experiment.object), field(r.experiment.side), num(r.experiment.offset),
                               num(r.experiment.distance), field(r.status), field(r.reason)};
  for (const auto* v : {&r.before, &r.after}) {
    const auto* o = findObject(*v, r.experiment.object);
    row.push_back(num(v->header.stamp.toSec()));
    row.push_back(o ? num(o->position.x) : "");
    row.push_back(o ? num(o->position.y) : "");
    row.push_back(o ? num(o->yaw) : "");
    for (const auto& n : extra_names) row.push_back(extraOf(o, n));
  }
  const bool done = r.status == "done";
  for (double v : {r.dx, r.dy, r.dyaw}) row.push_back(done ? num(v) : "");
  const bool predicted = r.predicted_mean.size() == 3 && r.predicted_std.size() == 3;
  for (int i = 0; i < 3; ++i) row.push_back(predicted ? num(r.predicted_mean[i]) : "");
  for (int i = 0; i < 3; ++i) row.push_back(predicted ? num(r.predicted_std[i]) : "");
  row.push_back(predicted && done ? num(r.surprise) : "");
  row.push_back(num(r.started));
  row.push_back(num(r.finished));
  return row;
}

// ---- poses.csv: streamed ----

/// The transforms of /tf and /tf_static whose child frame matches @p frames, at most one per frame per
/// pose_period; the number of rows.
std::size_t writePoses(const std::vector<std::string>& files, const ExportOptions& options, const std::regex& frames,
                       CsvFile& poses) {
  std::size_t rows = 0;
  poses.row({"time", "frame", "parent", "x", "y", "z", "yaw", "static"});
  std::map<std::string, double> last;
  forEachMessage(files, {"/tf", "/tf_static"}, [&](const std::string& path, const rosbag::MessageInstance& m) {
    auto msg = instantiate<tf2_msgs::TFMessage>(m, path);
    const bool is_static = m.getTopic() == "/tf_static";
    for (const auto& t : msg->transforms) {
      if (!std::regex_match(t.child_frame_id, frames)) continue;
      const double time = t.header.stamp.toSec();
      if (options.pose_period > 0 && !is_static) {
        auto it = last.find(t.child_frame_id);
        if (it != last.end() && time - it->second < options.pose_period - 1e-6 && time >= it->second) continue;
        last[t.child_frame_id] = time;
      }
      const auto& p = t.transform.translation;
      const auto& q = t.transform.rotation;
      poses.row({num(time), field(t.child_frame_id), field(t.header.frame_id), num(p.x), num(p.y), num(p.z),
                 num(yawOf(q.x, q.y, q.z, q.w)), is_static ? "1" : "0"});
      ++rows;
    }
  });
  return rows;
}

// ---- features.csv: one row per object per feature vector; extra features as columns ----

struct FeatureRow {
  std::vector<std::string> fixed;
  std::map<std::string, double> extra;
};

struct FeatureTable {
  std::vector<FeatureRow> rows;
  std::set<std::string> names;  ///< every extra feature's name
};

/// Every object (and the robot, when found) of every feature vector on @p topics; read whole before writing,
/// since the columns are known only at the end.
FeatureTable readFeatureTable(const std::vector<std::string>& files, const std::vector<std::string>& topics) {
  FeatureTable table;
  forEachMessage(files, topics, [&](const std::string& path, const rosbag::MessageInstance& m) {
    auto v = instantiate<xpersif::FeatureVector>(m, path);
    const std::string stamp = num(v->header.stamp.toSec()), time = num(m.getTime().toSec());
    for (const auto& o : v->objects) {
      FeatureRow row;
      row.fixed = {time, field(m.getTopic()), stamp, field(v->source), field(o.name), num(o.position.x),
                   num(o.position.y), num(o.position.z), num(o.yaw), o.orientation_known ? "1" : "0",
                   num(o.confidence), num(o.pixel_area)};
      for (std::size_t i = 0; i < o.feature_names.size() && i < o.feature_values.size(); ++i) {
        row.extra[o.feature_names[i]] = o.feature_values[i];
        table.names.insert(o.feature_names[i]);
      }
      table.rows.push_back(std::move(row));
    }
    if (v->robot_found) {
      table.rows.push_back({{time, field(m.getTopic()), stamp, field(v->source), "robot", num(v->robot.x),
                             num(v->robot.y), "", num(v->robot.theta), "1", "", ""},
                            {}});
    }
  });
  return table;
}

void writeFeatures(FeatureTable& table, CsvFile& features) {
  std::vector<std::string> h{"time", "topic", "stamp", "source", "object", "x", "y", "z", "yaw",
                             "orientation_known", "confidence", "pixel_area"};
  for (const auto& n : table.names) h.push_back("feature_" + n);  // VISION's own x, y would collide with the pose
  features.row(h);
  for (auto& r : table.rows) {
    for (const auto& n : table.names) {
      auto it = r.extra.find(n);
      r.fixed.push_back(it == r.extra.end() ? "" : num(it->second));
    }
    features.row(r.fixed);
  }
}

}  // namespace

ExportSummary exportCsv(const std::vector<std::string>& files, const ExportOptions& options) {
  ExportSummary summary;
  summary.bags = files.size();
  std::error_code ec;
  fs::create_directories(options.out_dir, ec);  // as xpersif_report does: a new directory is made, not refused
  if (!fs::is_directory(options.out_dir, ec)) {
    throw OutputError("output directory '" + options.out_dir + "' cannot be made" + (ec ? ": " + ec.message() : ""));
  }
  const std::regex frames(options.frames_regex);  // throws std::regex_error

  const auto records = readExperimentRecords(files, options.experiments_topic);
  const std::set<std::string> extra_names = pushedObjectFeatureNames(records);
  CsvFile experiments(options.out_dir, "experiments.csv");
  experiments.row(experimentsHeader(extra_names));
  for (const auto& e : records) experiments.row(experimentRow(e, extra_names));
  summary.experiments = records.size();

  std::unique_ptr<CsvFile> poses;
  if (options.poses) {
    poses = std::make_unique<CsvFile>(options.out_dir, "poses.csv");
    summary.poses = writePoses(files, options, frames, *poses);
  }

  std::unique_ptr<CsvFile> features;
  if (options.features) {
    FeatureTable table = readFeatureTable(files, options.feature_topics);
    features = std::make_unique<CsvFile>(options.out_dir, "features.csv");
    writeFeatures(table, *features);
    summary.features = table.rows.size();
  }

  // Renamed only now: a failure above leaves no half table behind.
  summary.files_written.push_back(experiments.commit());
  if (poses) summary.files_written.push_back(poses->commit());
  if (features) summary.files_written.push_back(features->commit());
  return summary;
}

std::map<std::string, std::size_t> countMessages(const std::string& path) {
  std::map<std::string, std::size_t> counts;
  isolated(path, [&path]() -> std::string {  // every message read once without harm first
    rosbag::Bag bag;
    openBag(bag, path);
    rosbag::View view(bag);
    for (const rosbag::MessageInstance& m : view) m.instantiate<topic_tools::ShapeShifter>();
    return "";
  });
  rosbag::Bag bag;
  openBag(bag, path);
  try {
    rosbag::View view(bag);
    for (const auto* c : view.getConnections()) counts[c->topic];  // topics with no message show 0
    for (const rosbag::MessageInstance& m : view) ++counts[m.getTopic()];
  } catch (const std::exception& e) {
    throw BagError("bag '" + path + "' cannot be read back: " + e.what());
  }
  return counts;
}

RecoverResult recoverBag(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw BagError("bag '" + path + "' does not exist");
  RecoverResult result;
  result.original_bytes = fs::file_size(path, ec);
  const fs::path in(path);
  std::string base = in.filename().string();
  if (endsWith(base, ".active")) base.resize(base.size() - 7);
  if (!endsWith(base, ".bag")) base += ".bag";
  const fs::path target = in.parent_path() / base;
  if (fs::exists(target, ec) && fs::equivalent(target, in, ec) == false) {
    throw BagError("cannot recover '" + path + "': '" + target.string() + "' exists already");
  }
  // rosbag reindex (Python, part of Debian's python3-rosbag) into a private directory next to the bag.
  const fs::path work = in.parent_path() / (".recover-" + std::to_string(::getpid()));
  fs::create_directories(work, ec);
  if (ec) throw BagError("cannot recover '" + path + "': cannot create '" + work.string() + "': " + ec.message());
  const fs::path log = work / "reindex.log";
  const pid_t child = ::fork();
  if (child == 0) {
    FILE* f = std::freopen(log.c_str(), "w", stdout);
    (void)f;
    ::dup2(::fileno(stdout), 2);
    const std::string out_opt = "--output-dir=" + work.string();
    ::execlp("rosbag", "rosbag", "reindex", "-q", out_opt.c_str(), path.c_str(), static_cast<char*>(nullptr));
    std::_Exit(127);
  }
  int status = 0;
  if (child < 0 || ::waitpid(child, &status, 0) < 0) throw BagError("cannot run `rosbag reindex` for '" + path + "'");
  std::string log_text;
  {
    std::ifstream l(log);
    std::stringstream s;
    s << l.rdbuf();
    log_text = s.str();
    while (!log_text.empty() && std::isspace(static_cast<unsigned char>(log_text.back()))) log_text.pop_back();
  }
  const fs::path produced = work / in.filename();
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || !fs::exists(produced, ec)) {
    fs::remove_all(work, ec);
    throw BagError("`rosbag reindex` could not recover '" + path + "'" +
                   (WIFEXITED(status) && WEXITSTATUS(status) == 127 ? std::string(": rosbag is not installed")
                                                                    : (log_text.empty() ? "" : ": " + log_text)));
  }
  result.backup = path + ".orig";
  fs::rename(in, result.backup, ec);
  if (!ec) fs::rename(produced, target, ec);
  fs::remove_all(work);
  if (ec) throw BagError("cannot move the recovered bag to '" + target.string() + "': " + ec.message());
  result.recovered = target.string();
  result.recovered_bytes = fs::file_size(target, ec);
  result.per_topic = countMessages(result.recovered);
  for (const auto& [t, n] : result.per_topic) result.messages += n;
  rosbag::Bag bag;
  openBag(bag, result.recovered);
  rosbag::View view(bag);
  if (view.size() > 0) {
    result.start = view.getBeginTime().toSec();
    result.end = view.getEndTime().toSec();
  }
  return result;
}

}  // namespace xpersif::traces
