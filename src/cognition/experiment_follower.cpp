#include "xpersif/cognition/experiment_follower.h"

#include "xpersif/GetExperiments.h"
#include "xpersif/component/parameter_reader.h"
#include "xpersif/core/common/validation.h"

namespace xpersif {

ExperimentFollower::Options ExperimentFollower::Options::fromParameters(const ros::NodeHandle& pnh,
                                                                       const std::string& who) {
  Options o;
  o.who = who;
  const ParameterReader parameters(pnh, Options::parameters());
  o.restore = parameters.get<bool>("restore");
  o.restore_timeout = parameters.get<double>("restore_timeout");
  o.experiments_topic = parameters.get<std::string>("experiments_topic");
  o.run_topic = parameters.get<std::string>("run_topic");
  o.knowledge_base = parameters.get<std::string>("knowledge_base");
  core::requireIdentifier("~experiments_topic", o.experiments_topic, 256);
  core::requireIdentifier("~run_topic", o.run_topic, 256);
  core::requireIdentifier("~knowledge_base", o.knowledge_base, 256);
  return o;
}

const core::ParameterTable& ExperimentFollower::Options::parameters() {
  const Options d;
  static const core::ParameterTable table(
      "experiment follower",
      {core::flagParameter("restore", d.restore, "rebuild the state from the knowledge base's current run on activate"),
       core::numberParameter("restore_timeout", d.restore_timeout, 0.1, 3600.0,
                             "s of wall time to wait for the knowledge base when restoring"),
       core::textParameter("experiments_topic", d.experiments_topic, "the stored experiments, as the KB publishes them"),
       core::textParameter("run_topic", d.run_topic, "the KB's current run"),
       core::textParameter("knowledge_base", d.knowledge_base, "namespace of the knowledge base's operations")});
  return table;
}

ExperimentFollower::ExperimentFollower(ros::NodeHandle nh, Options options, Reset reset, Add add)
    : nh_(std::move(nh)), options_(std::move(options)), reset_(std::move(reset)), add_(std::move(add)) {}

ExperimentFollower::~ExperimentFollower() { stop(); }

void ExperimentFollower::start() {
  stop();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = false;
    queue_.clear();
    seqs_.clear();
  }
  abort_restore_ = false;
  // With restore on, forget the run so that the (latched) announcement restores from the KB: records may have
  // been stored while this component was inactive.
  if (options_.restore) run_id_ = 0;
  worker_ = std::thread([this] { work(); });
  experiments_sub_ = nh_.subscribe<ExperimentRecord>(
      options_.experiments_topic, 100, [this](const ExperimentRecord::ConstPtr& record) {
        std::lock_guard<std::mutex> lock(mutex_);
        queue_.push_back({false, record->run_id, record});
        wake_.notify_one();
      });
  run_sub_ = nh_.subscribe<std_msgs::UInt64>(options_.run_topic, 10, [this](const std_msgs::UInt64::ConstPtr& run) {
    if (run->data == 0) return;
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.push_back({true, run->data, nullptr});
    wake_.notify_one();
  });
}

void ExperimentFollower::stop() {
  // Unsubscribe first, without holding the mutex the callbacks take.
  experiments_sub_.shutdown();
  run_sub_.shutdown();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    wake_.notify_all();
  }
  abort_restore_ = true;
  if (worker_.joinable()) worker_.join();
}

std::size_t ExperimentFollower::seen() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return seqs_.size();
}

void ExperimentFollower::work() {
  while (true) {
    Event event;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      event = queue_.front();
      queue_.pop_front();
    }
    try {
      handle(event);
    } catch (const std::exception& e) {
      ROS_ERROR("%s: could not take experiment record in: %s", options_.who.c_str(), e.what());
    }
  }
}

void ExperimentFollower::handle(const Event& event) {
  if (event.is_run) {
    if (event.run_id == run_id_) return;
    if (options_.restore) {
      restore(event.run_id);
    } else {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        seqs_.clear();
      }
      run_id_ = event.run_id;
      reset_(event.run_id, {});
    }
    return;
  }
  const ExperimentRecord& record = *event.record;
  if (record.run_id != run_id_) {
    if (options_.restore) {
      restore(record.run_id);
      std::lock_guard<std::mutex> lock(mutex_);
      if (seqs_.count(record.seq)) return;  // the restore brought it (the usual case)
    } else {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        seqs_.clear();
      }
      run_id_ = record.run_id;
      reset_(record.run_id, {});
    }
  } else {
    bool gap = false;
    std::uint32_t last = 0;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (seqs_.count(record.seq)) return;  // a duplicate
      last = seqs_.empty() ? 0 : *seqs_.rbegin();
      gap = !seqs_.empty() && record.seq != last + 1;
    }
    if (gap && options_.restore) {
      ROS_WARN("%s: experiment seq %u of run %lu follows seq %u; restoring the run from the knowledge base",
               options_.who.c_str(), record.seq, static_cast<unsigned long>(record.run_id), last);
      restore(record.run_id);
      std::lock_guard<std::mutex> lock(mutex_);
      if (seqs_.count(record.seq)) return;
    }
  }
  add_(record);
  std::lock_guard<std::mutex> lock(mutex_);
  seqs_.insert(record.seq);
}

void ExperimentFollower::restore(std::uint64_t run_id) {
  const std::string service = ros::names::resolve(nh_.getNamespace(), options_.knowledge_base + "/get_experiments");
  GetExperiments call;
  call.request.run_id = run_id;
  call.request.status = "";
  bool answered = false;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(options_.restore_timeout);
  while (!abort_restore_ && ros::ok() && ros::WallTime::now() < end) {
    if (!ros::service::waitForService(service, ros::Duration(0.5))) continue;
    if (ros::service::call(service, call)) {
      answered = true;
      break;
    }
    ros::WallDuration(0.2).sleep();
  }
  if (abort_restore_) return;
  std::vector<ExperimentRecord> records;
  if (!answered) {
    ROS_ERROR("%s: the knowledge base (%s) did not answer within %.0f s; starting run %lu empty", options_.who.c_str(),
              service.c_str(), options_.restore_timeout, static_cast<unsigned long>(run_id));
  } else if (!call.response.success) {
    ROS_WARN("%s: the knowledge base has no experiments of run %lu for me: %s; starting it empty",
             options_.who.c_str(), static_cast<unsigned long>(run_id), call.response.message.c_str());
  } else {
    records = std::move(call.response.experiments);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    seqs_.clear();
    for (const auto& r : records) seqs_.insert(r.seq);
  }
  run_id_ = run_id;
  ROS_INFO("%s: restored run %lu from the knowledge base: %zu records", options_.who.c_str(),
           static_cast<unsigned long>(run_id), records.size());
  reset_(run_id, records);
}

}  // namespace xpersif
