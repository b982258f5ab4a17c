/**
 * @file loop_model_arena.cpp
 * @brief LOOPMODEL's arena: the scene as VISION sees it now, the arena tidied between steps as an experimenter
 *        would (cubes against a wall, against each other or out of sight put back at free spots), and a new
 *        run's objects and robot put where the world file has them.
 */
#include "xpersif/loop/loop_model.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "xpersif/GetFeatures.h"
#include "xpersif/SetPose.h"
#include "xpersif/core/common/validation.h"
#include "xpersif/ros/experiment_conversions.h"
#include "xpersif/ros/setup_loader.h"
#include "loop_text.h"
#include "service_call.h"

namespace xpersif {

using loop::call;
using loop::literalNumber;

namespace {

/// The catalogue's objects that are out of sight, closer than @p hx / @p hy to a wall's inside, or the later one
/// (by name) of a pair closer than @p spacing: cubes pushed together leave no room for the robot at their faces.
std::vector<std::string> misplacedObjects(const core::SetupCatalogue& catalogue, const FeatureVector& scene, double hx,
                                          double hy, double spacing) {
  std::vector<std::string> misplaced;
  for (const auto& name : catalogue.names()) {
    const ObjectFeatures* o = findObject(scene, name);
    if (!o || std::abs(o->position.x) > hx || std::abs(o->position.y) > hy) {
      misplaced.push_back(name);
      continue;
    }
    for (const auto& other : scene.objects) {
      if (other.name >= name || !catalogue.find(other.name)) continue;
      if (std::hypot(other.position.x - o->position.x, other.position.y - o->position.y) < spacing) {
        misplaced.push_back(name);
        break;
      }
    }
  }
  return misplaced;
}

}  // namespace

bool LoopModel::getScene(FeatureVector* scene, std::string* why) {
  Spending spending(wall_spent_, "scene");
  // The scene as it is now: VISION works behind the camera, so its latest vector may show an older world (in
  // lockstep the next idle tick brings a frame of the standing world).
  double newer_than = ros::Time::now().toSec();
  // 10 s of wall time while simulated time moves: a paused XPERSim (someone watching a frame) stops the clock,
  // and a wait for a new frame then waits as long as the pause (it once aborted the run after 10 s).
  // In lockstep, simulated time that moves while LOOPMODEL asks for none is another participant's (a user's
  // controller, a test) and no frame comes until the world stands: that wait counts no more than a pause.
  ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
  ros::WallTime last_wall = ros::WallTime::now();
  ros::Time last_sim = ros::Time::now();
  const ros::Time first_sim = last_sim;
  ros::WallTime last_moved = last_wall;  // when simulated time last went on
  const ros::WallTime give_up = last_wall + ros::WallDuration(600.0);  // a clock that never moves again
  const bool lockstep = lockstep_->enabled();
  while (ros::ok()) {
    const ros::WallTime wall_now = ros::WallTime::now();
    const ros::Time sim_now = ros::Time::now();  // read once: the clock may tick between two reads
    if (sim_now == last_sim || lockstep) deadline += wall_now - last_wall;
    if (sim_now != last_sim) last_moved = wall_now;
    last_wall = wall_now;
    last_sim = sim_now;
    // Simulated time that went backwards means XPERSim was restarted (its manager died and was respawned): its
    // clock began again, and the world standing now is the restarted one; a frame newer than that is the scene.
    newer_than = std::min(newer_than, sim_now.toSec());
    GetFeatures features;
    features.request.max_age = 2.0;
    *why = call(nodeHandle(), "vision/get_features", features);
    if (why->empty() && features.response.features.header.stamp.toSec() > newer_than) {
      *scene = features.response.features;
      return true;
    }
    if (ros::WallTime::now() > deadline || ros::WallTime::now() > give_up) {
      const double moved = (ros::Time::now() - first_sim).toSec();
      const bool still_moving = (ros::WallTime::now() - last_moved).toSec() < 1.0;
      if (lockstep && still_moving && moved > 0) {  // the cause is the moving world, not VISION's answer
        *why = "no new observation of the scene came within 600 s: another lockstep participant kept the world moving "
               "(simulated time went on by " + core::describeNumber(moved) + " s), and a frame comes only when it "
               "stands" + (why->empty() ? std::string() : " (vision/get_features: " + *why + ")");
      } else if (why->empty()) {
        *why = ros::WallTime::now() > give_up
                   ? "no new observation of the scene came within 600 s: the simulator's clock stood still"
                   : "no new observation of the scene came within 10 s while simulated time went on";
      }
      return false;
    }
    // (In lockstep the clock's idle ticks bring new frames of the standing world: no physics time is asked for.)
    ros::WallDuration(0.01).sleep();
  }
  *why = "shutting down";
  return false;
}

const core::SetupCatalogue& LoopModel::catalogue() {
  std::lock_guard<std::mutex> lock(catalogue_mutex_);
  if (!catalogue_) catalogue_ = loadSetupCatalogue(nodeHandle(), privateNodeHandle());
  return *catalogue_;
}

int LoopModel::tidyArena(const FeatureVector& scene, std::uint64_t stream) {
  Spending spending(wall_spent_, "tidy");
  std::mt19937_64 rng(stream);
  int moved = 0;
  try {
    catalogue();
  } catch (const std::exception& e) {
    ROS_WARN("%s: cannot tidy the arena: %s", name().c_str(), e.what());
    return 0;
  }
  const double margin = tidy_margin_ >= 0 ? tidy_margin_ : catalogue_->wallMargin();
  const double spacing = tidy_spacing_ >= 0 ? tidy_spacing_ : catalogue_->objectSpacing();
  const double hx = catalogue_->arena_size_x / 2 - margin, hy = catalogue_->arena_size_y / 2 - margin;
  if (hx <= 0 || hy <= 0) {
    ROS_WARN("%s: cannot tidy the arena: a margin of %.3f m from the walls leaves no room", name().c_str(), margin);
    return 0;
  }
  const std::vector<std::string> misplaced = misplacedObjects(*catalogue_, scene, hx, hy, spacing);
  core::ArenaTidy tidy(hx, hy, spacing);
  for (const auto& o : scene.objects) tidy.stands(o.name, o.position.x, o.position.y);
  if (scene.robot_found) tidy.stands("(the robot)", scene.robot.x, scene.robot.y);
  for (const auto& name : misplaced) {
    const auto spot = tidy.spotFor(name, rng);
    if (!spot) {
      ROS_WARN_THROTTLE(60.0, "%s: cannot tidy %s: no spot in the arena is ~tidy_spacing %.3f m from every other "
                        "object (a smaller ~tidy_spacing makes room)", this->name().c_str(), name.c_str(), spacing);
      continue;
    }
    const auto [x, y] = *spot;
    SetPose place;
    place.request.name = name;
    place.request.pose.position.x = x;
    place.request.pose.position.y = y;
    place.request.pose.orientation.w = 1.0;
    place.request.on_floor = true;
    const std::string why = call(nodeHandle(), "xpersim/set_pose", place);
    if (!why.empty()) {
      ROS_WARN("%s: could not tidy %s away: %s", this->name().c_str(), name.c_str(), why.c_str());
      continue;
    }
    events().publish(events().make(ComponentEvent::SUPERVISION, "tidy", "ok",
                                   "put " + name + " back at (" + literalNumber(x) + ", " + literalNumber(y) + ")"));
    tidy.stands(name, x, y);
    ++moved;
  }
  return moved;
}

std::string LoopModel::arrangeInitialScene() {
  // XPERSim refuses a place another body occupies (PRECONDITION_FAILED). A body whose start is taken (by a body
  // that has yet to go to its own) is parked 1 m above its start, where nothing is, and set down once every
  // body has its place: the world file's start poses never overlap, so that always succeeds. Parked bodies do
  // not fall meanwhile: no physics step runs between these calls (an idle tick does not step).
  std::vector<std::string> parked;
  auto place = [&](const std::string& name, const core::Pose2D& pose, bool parking) {
    SetPose request;
    request.request.name = name;
    request.request.pose.position.x = pose.x;
    request.request.pose.position.y = pose.y;
    request.request.pose.position.z = parking ? 1.0 : 0.0;
    request.request.pose.orientation.z = std::sin(pose.yaw / 2);
    request.request.pose.orientation.w = std::cos(pose.yaw / 2);
    request.request.on_floor = !parking;
    std::uint8_t code = ResultCode::OK;
    const std::string why = call(nodeHandle(), "xpersim/set_pose", request, &code);
    return std::make_pair(why, code);
  };
  for (const auto& [name, pose] : setup_.initial_poses) {
    auto [why, code] = place(name, pose, false);
    if (!why.empty() && code == ResultCode::PRECONDITION_FAILED) {
      std::tie(why, code) = place(name, pose, true);
      if (why.empty()) parked.push_back(name);
    }
    if (!why.empty()) return why;
  }
  for (const auto& name : parked) {
    const auto [why, code] = place(name, setup_.initial_poses.at(name), false);
    if (!why.empty()) return why;
  }
  return "";
}

}  // namespace xpersif
