// progress_markers: the loop's progress as text for rviz. It listens to the main job's loop (LOOPMODEL's
// progress, the run's design, MOTIVATION's surprise, MACHINELEARNING's notions) and republishes them as
// TEXT_VIEW_FACING markers above the arena's far wall, on ~markers (latched). Only watches: it calls nothing.
//   ~ns       the main job's namespace [/xpersif]
//   ~frame    the markers' frame [world]
//   ~lines    at most this many notions shown [6]
//   ~height   text height, metres [0.03]
#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include <cstdio>
#include <mutex>
#include <sstream>

#include "xpersif/ExperimentRecord.h"
#include "xpersif/Motivation.h"
#include "xpersif/Notions.h"
#include "xpersif/RunLoopActionGoal.h"
#include "xpersif/RunLoopFeedback.h"
#include "xpersif/Scene.h"

namespace {

class ProgressMarkers {
 public:
  ProgressMarkers(ros::NodeHandle& nh, ros::NodeHandle& pnh) {
    std::string ns = "/xpersif";
    pnh.param("ns", ns, ns);
    pnh.param("frame", frame_, frame_);
    pnh.param("lines", max_notions_, max_notions_);
    pnh.param("height", height_, height_);
    if (!ns.empty() && ns.back() == '/') ns.pop_back();
    pub_ = pnh.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
    subs_.push_back(nh.subscribe(ns + "/xpersim/scene", 1, &ProgressMarkers::onScene, this));
    subs_.push_back(nh.subscribe(ns + "/loop_model/progress", 10, &ProgressMarkers::onProgress, this));
    subs_.push_back(nh.subscribe(ns + "/loop_model/run/goal", 10, &ProgressMarkers::onGoal, this));
    subs_.push_back(nh.subscribe(ns + "/knowledge_base/experiments", 10, &ProgressMarkers::onRecord, this));
    subs_.push_back(nh.subscribe(ns + "/motivation/motivation", 10, &ProgressMarkers::onMotivation, this));
    subs_.push_back(nh.subscribe(ns + "/machine_learning/notions", 10, &ProgressMarkers::onNotions, this));
    publish();
  }

 private:
  void onScene(const xpersif::Scene& s) {
    std::lock_guard<std::mutex> lock(mutex_);
    top_ = s.arena_size_y / 2 + 0.05;
    publishLocked();
  }
  void onProgress(const xpersif::RunLoopFeedback& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    progress_ = p;
    publishLocked();
  }
  void onGoal(const xpersif::RunLoopActionGoal& g) {
    std::lock_guard<std::mutex> lock(mutex_);
    run_ = g.goal.name;
    design_ = g.goal.design;
    publishLocked();
  }
  void onRecord(const xpersif::ExperimentRecord& r) {
    std::lock_guard<std::mutex> lock(mutex_);
    design_ = r.design;
    publishLocked();
  }
  void onMotivation(const xpersif::Motivation& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    motivation_ = m;
    have_motivation_ = true;
    publishLocked();
  }
  void onNotions(const xpersif::Notions& n) {
    std::lock_guard<std::mutex> lock(mutex_);
    notions_ = n;
    publishLocked();
  }
  void publish() {
    std::lock_guard<std::mutex> lock(mutex_);
    publishLocked();
  }

  // One text marker per line, top line highest; ids are stable so rviz replaces them in place.
  void publishLocked() {
    std::vector<std::string> lines;
    std::ostringstream head;
    head << "loop: " << (progress_.state.empty() ? "waiting for LOOPMODEL" : progress_.state);
    if (!run_.empty()) head << "  run " << run_;
    head << "  experiment " << progress_.experiment;
    // A viewer that joins mid-run has missed the run's goal; it learns the design from the next experiment.
    if (!design_.empty()) head << "  design " << design_;
    lines.push_back(head.str());
    char buffer[160];
    // Before the run's first experiment there is no surprise to show, and every region is equally curious.
    const bool no_experiment_yet = have_motivation_ ? motivation_.experiments == 0 : progress_.experiment == 0;
    if (no_experiment_yet) {
      std::snprintf(buffer, sizeof buffer, "no experiment yet: no surprise, no curiosity");
    } else if (have_motivation_) {
      std::snprintf(buffer, sizeof buffer, "last surprise %.3f m (%.1f sd), most curious: %s", motivation_.surprise,
                    motivation_.normalized_surprise,
                    motivation_.most_curious.empty() ? "-" : motivation_.most_curious.c_str());
    } else {
      std::snprintf(buffer, sizeof buffer, "last surprise %.3f m", progress_.surprise);
    }
    lines.push_back(buffer);
    if (!progress_.last.empty()) lines.push_back("last: " + progress_.last);
    lines.push_back("notions (" + std::to_string(notions_.notions.size()) + ", " + std::to_string(notions_.samples) +
                    " samples):");
    for (std::size_t i = 0; i < notions_.notions.size() && static_cast<int>(i) < max_notions_; ++i) {
      const auto& n = notions_.notions[i];
      lines.push_back("  " + (n.text.empty() ? n.subject + " " + n.predicate : n.text));
    }

    visualization_msgs::MarkerArray array;
    visualization_msgs::Marker clear;
    clear.header.frame_id = frame_;
    clear.ns = "progress";
    clear.action = visualization_msgs::Marker::DELETEALL;
    array.markers.push_back(clear);
    for (std::size_t i = 0; i < lines.size(); ++i) {
      visualization_msgs::Marker m;
      m.header.frame_id = frame_;
      m.ns = "progress";
      m.id = static_cast<int>(i);
      m.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
      m.action = visualization_msgs::Marker::ADD;
      m.frame_locked = true;
      m.pose.position.y = top_ + (lines.size() - i) * 1.3 * height_;
      m.pose.position.z = 0.1;
      m.pose.orientation.w = 1;
      m.scale.z = height_;
      m.color.r = 0.55f;  // light cyan: told apart from grey floors and walls
      m.color.g = 0.9f;
      m.color.b = 1.0f;
      m.color.a = 1;
      m.text = lines[i];
      array.markers.push_back(m);
    }
    pub_.publish(array);
  }

  std::mutex mutex_;
  ros::Publisher pub_;
  std::vector<ros::Subscriber> subs_;
  std::string frame_ = "world", run_, design_;
  int max_notions_ = 6;
  double height_ = 0.03, top_ = 0.35;
  xpersif::RunLoopFeedback progress_;
  xpersif::Motivation motivation_;
  bool have_motivation_ = false;
  xpersif::Notions notions_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "progress_markers", ros::init_options::AnonymousName);
  ros::NodeHandle nh, pnh("~");
  ProgressMarkers markers(nh, pnh);
  ros::spin();
  return 0;
}
