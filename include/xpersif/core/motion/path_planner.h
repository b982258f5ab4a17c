/**
 * @file path_planner.h
 * @brief Grid A* path planning for a disc robot around the arena's walls and the objects' footprints. Part of
 *        the motion core (motion.h).
 */
#pragma once

#include <string>
#include <vector>

#include "xpersif/core/motion/motion_control.h"

namespace xpersif::core {

// ---- path planning ------------------------------------------------------------------------------------

struct PathResult {
  bool ok = false;
  std::string reason;               ///< why there is no path (when !ok)
  std::vector<Pose2D> waypoints;    ///< after the start, ending with the goal (its yaw); intermediate
                                    ///< waypoints' yaw is the direction of travel
  double length = 0;                ///< m, along the waypoints
};

/**
 * @brief Grid A* over the arena (8-connected, @p resolution cells) for a disc robot kept @p margin away
 *        from walls and obstacles, simplified to few waypoints by line of sight. A start that is
 *        closer than the margin (but not overlapping anything) may leave its corner: the robot is allowed
 *        to move out of the margin, at a higher cost.
 */
class PathPlanner {
 public:
  /// @throws ValidationError for a bad arena, radius, margin or resolution
  PathPlanner(ArenaGeometry arena, double robot_radius, double margin = 0.01, double resolution = 0.01);

  /// @throws ValidationError for a non-finite pose or a bad footprint (Footprint::check)
  void setObstacles(std::vector<Obstacle> obstacles);
  const std::vector<Obstacle>& obstacles() const { return obstacles_; }

  /// Never throws for geometric reasons: non-finite poses, goals outside the arena, inside or too close to
  /// an obstacle, a blocked start and unreachable goals all come back as !ok with a reason sentence.
  PathResult plan(const Pose2D& start, const Pose2D& goal) const;

  /// Clearance of a robot centred at (x, y): distance from its centre to the nearest wall or obstacle.
  double clearance(double x, double y) const;
  /// "" when a robot at (x, y) keeps the margin to everything, else which thing is too close.
  std::string checkFree(double x, double y) const;

  double robotRadius() const { return robot_radius_; }
  double margin() const { return margin_; }
  const ArenaGeometry& arena() const { return arena_; }

 private:
  std::string nearestThing(double x, double y) const;
  /// "" when a path may be planned between these ends, else why not (plan()'s reason).
  std::string checkEnds(const Pose2D& start, const Pose2D& goal) const;

  ArenaGeometry arena_;
  double robot_radius_, margin_, resolution_;
  std::vector<Obstacle> obstacles_;
};

}  // namespace xpersif::core
