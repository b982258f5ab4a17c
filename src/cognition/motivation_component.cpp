#include "xpersif/cognition/motivation_component.h"

#include "xpersif/component/parameter_reader.h"

#include "xpersif/ros/experiment_conversions.h"
#include "xpersif/ros/setup_loader.h"

namespace xpersif {

// ---- surprise -------------------------------------------------------------------------------------------

const core::ParameterTable& SurprisePart::parameters() {
  static const core::ParameterTable table(
      "surprise part",
      {core::derivedParameter(core::ParameterSpec::Type::Double, "yaw_length", "the objects' mean half-size", 1e-4, 1.0,
                              "part surprise: m of travel a turn of one radian counts as in the prediction error")});
  return table;
}

void SurprisePart::configure(const ros::NodeHandle& parameters) {
  yaw_length_ = ParameterReader(parameters, SurprisePart::parameters(), "~" + name() + "/")
                    .get<double>("yaw_length", default_yaw_length_);
}

std::optional<core::Surprise> SurprisePart::score(const ExperimentRecord& record) const {
  if (record.status != "done" || record.predicted_mean.size() != 3 || record.predicted_std.size() != 3) {
    return std::nullopt;
  }
  const core::Prediction prediction{{record.predicted_mean[0], record.predicted_mean[1], record.predicted_mean[2]},
                                    {record.predicted_std[0], record.predicted_std[1], record.predicted_std[2]}};
  return core::surprise(prediction, {record.dx, record.dy, record.dyaw}, yaw_length_);
}

// ---- curiosity ------------------------------------------------------------------------------------------

const core::ParameterTable& CuriosityPart::parameters() {
  static const core::ParameterTable table = [] {
    const core::CuriosityConfig d;
    return core::ParameterTable(
        "curiosity part",
        {core::intParameter("offset_bins", d.offset_bins, 1, 100, "part curiosity: offset bins per face of a region"),
         core::intParameter("window", static_cast<int>(d.window), 1, 1000,
                            "part curiosity: errors per window (older against newer) of the learning progress"),
         core::intParameter("min_visits", static_cast<int>(d.min_visits), 0, 1000,
                            "part curiosity: below this many experiments a region is unexplored"),
         core::textParameter("measure", "error", "part curiosity: which prediction error the regions keep",
                             {"error", "normalized"})});
  }();
  return table;
}

void CuriosityPart::configure(const ros::NodeHandle& parameters) {
  const ParameterReader reader(parameters, CuriosityPart::parameters(), "~" + name() + "/");
  core::CuriosityConfig config;
  config.objects = objects_;
  config.footprints = footprints_;
  config.offset_bins = reader.get<int>("offset_bins");
  config.window = static_cast<std::size_t>(reader.get<int>("window"));
  config.min_visits = static_cast<std::size_t>(reader.get<int>("min_visits"));
  const std::string measure = reader.get<std::string>("measure");
  auto map = std::make_unique<core::CuriosityMap>(config);  // throws with the reason (e.g. no objects)
  config_ = config;
  normalized_ = measure == "normalized";
  map_ = std::move(map);
}

void CuriosityPart::reset() {
  if (map_) map_ = std::make_unique<core::CuriosityMap>(config_);
}

bool CuriosityPart::record(const Experiment& experiment, const core::Surprise& surprise, std::string* why) {
  if (!map_) {
    *why = "the curiosity map is not configured";
    return false;
  }
  try {
    map_->record(fromMsg(experiment), normalized_ ? surprise.normalized : surprise.error);
    return true;
  } catch (const std::exception& e) {
    *why = e.what();
    return false;
  }
}

void CuriosityPart::fill(Motivation& message) const {
  if (!map_) return;
  for (const auto& region : map_->regions()) {
    message.regions.push_back(region.key.toString());
    message.curiosity.push_back(region.curiosity);
    message.learning_progress.push_back(region.progress);
    message.visits.push_back(static_cast<std::uint32_t>(region.count));
  }
  message.most_curious = map_->mostCurious().toString();
}

// ---- the aggregate --------------------------------------------------------------------------------------

MotivationComponent::MotivationComponent(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : AggregateComponent(std::move(nh), std::move(private_nh), "xpersif/MotivationNodelet"),
      surprise_(addPart<SurprisePart>()),
      curiosity_(addPart<CuriosityPart>()) {}

MotivationComponent::~MotivationComponent() {
  if (follower_) follower_->stop();
}

const core::ParameterTable& MotivationComponent::parameters() {
  static const core::ParameterTable table = [] {
    core::ParameterTable own("motivation", {});
    own.include(SurprisePart::parameters(), "surprise/")
        .include(CuriosityPart::parameters(), "curiosity/")
        .include(ExperimentFollower::Options::parameters())
        .include(setupCatalogueParameters());
    return own;
  }();
  return table;
}

void MotivationComponent::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  // The objects and their sizes come from XPERSim's scene (~objects may leave some out).
  const core::SetupCatalogue catalogue = loadSetupCatalogue(nodeHandle(), pnh);
  core::requireMaxSize("~objects", catalogue.objects.size(), 64);
  std::map<std::string, core::Footprint> footprints;
  double half_sizes = 0;  // a turn of an object counts as the travel of a point at its half size
  for (const auto& o : catalogue.objects) {
    footprints[o.name] = o.footprint;
    half_sizes += o.footprint.isDisc() ? o.footprint.radius : 0.5 * std::max(o.footprint.size_x, o.footprint.size_y);
  }
  const ExperimentFollower::Options follow = ExperimentFollower::Options::fromParameters(pnh, name());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    curiosity_.setObjects(catalogue.names(), footprints);
    surprise_.setDefaultYawLength(half_sizes / catalogue.objects.size());
    follow_ = follow;
    run_id_ = 0;
    done_heard_ = 0;
    last_ = core::Surprise();
    // One message per experiment (DESIGNOFEXPERIMENTS and recorders count on each): no dropping under load.
    if (!motivation_pub_) motivation_pub_ = pnh.advertise<Motivation>("motivation", 100, true);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  AggregateComponent::onConfigure();
}

void MotivationComponent::onActivate() {
  AggregateComponent::onActivate();
  if (follower_) follower_->stop();
  follower_ = std::make_unique<ExperimentFollower>(
      nodeHandle(), follow_, [this](std::uint64_t run, const std::vector<ExperimentRecord>& records) { reset(run, records); },
      [this](const ExperimentRecord& record) { add(record); });
  follower_->start();
}

void MotivationComponent::onDeactivate() {
  if (follower_) follower_->stop();
  AggregateComponent::onDeactivate();
}

void MotivationComponent::onShutdown() {
  if (follower_) follower_->stop();
  follower_.reset();
  std::lock_guard<std::mutex> lock(mutex_);
  AggregateComponent::onShutdown();
}

bool MotivationComponent::take(const ExperimentRecord& record) {
  const bool done = record.status == "done";
  if (done) ++done_heard_;
  std::optional<core::Surprise> s;
  try {
    s = surprise_.score(record);
  } catch (const std::exception& e) {
    ROS_WARN("%s: experiment %u of run %lu has no valid prediction: %s", name().c_str(), record.seq,
             static_cast<unsigned long>(record.run_id), e.what());
    return done;
  }
  if (!s) return done;
  std::string why;
  if (!curiosity_.record(record.experiment, *s, &why)) {
    ROS_WARN("%s: experiment %u of run %lu is outside the curiosity map: %s", name().c_str(), record.seq,
             static_cast<unsigned long>(record.run_id), why.c_str());
    return done;
  }
  last_ = *s;
  return true;
}

void MotivationComponent::reset(std::uint64_t run_id, const std::vector<ExperimentRecord>& records) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    curiosity_.reset();
    run_id_ = run_id;
    done_heard_ = 0;
    last_ = core::Surprise();
    for (const auto& record : records) take(record);
  }
  publish();
}

void MotivationComponent::add(const ExperimentRecord& record) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    run_id_ = record.run_id;
    if (!take(record)) return;
  }
  publish();
}

void MotivationComponent::publish() {
  auto message = boost::make_shared<Motivation>();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    message->header.stamp = ros::Time::now();
    message->run_id = run_id_;
    message->experiments = done_heard_;
    message->surprise = last_.error;
    message->normalized_surprise = last_.normalized;
    curiosity_.fill(*message);
  }
  motivation_pub_.publish(message);
}

}  // namespace xpersif
