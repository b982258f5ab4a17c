// Grid A* path planning around the walls and the objects (path_planner.h).
#include "xpersif/core/motion/path_planner.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <sstream>

#include "xpersif/core/common/validation.h"
#include "motion_internal.h"

namespace xpersif::core {

using namespace motion_detail;

// ---- PathPlanner ------------------------------------------------------------------------------------------

PathPlanner::PathPlanner(ArenaGeometry arena, double robot_radius, double margin, double resolution)
    : arena_(arena), robot_radius_(robot_radius), margin_(margin), resolution_(resolution) {
  throwIfInvalid(arena_.check());
  throwIfInvalid(checkPositive("robot_radius", robot_radius));
  throwIfInvalid(checkInRange("margin", margin, 0.0, 1.0));
  throwIfInvalid(checkInRange("resolution", resolution, 0.001, 0.1));
}

void PathPlanner::setObstacles(std::vector<Obstacle> obstacles) {
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    const std::string field = "obstacles[" + std::to_string(i) + "]";
    throwIfInvalid(checkPose(field, Pose2D{obstacles[i].x, obstacles[i].y, obstacles[i].yaw}));
    throwIfInvalid(obstacles[i].footprint.check(field + ".footprint"));
  }
  obstacles_ = std::move(obstacles);
}

double PathPlanner::clearance(double x, double y) const {
  double c = std::min({arena_.size_x / 2.0 - std::fabs(x), arena_.size_y / 2.0 - std::fabs(y)});
  for (const auto& o : obstacles_) c = std::min(c, distanceToObstacle(o, x, y));
  return c;
}

std::string PathPlanner::nearestThing(double x, double y) const {
  std::string name = "the wall";
  double best = std::min(arena_.size_x / 2.0 - std::fabs(x), arena_.size_y / 2.0 - std::fabs(y));
  for (const auto& o : obstacles_) {
    const double d = distanceToObstacle(o, x, y);
    if (d < best) {
      best = d;
      name = o.name.empty() ? std::string("an obstacle") : o.name;
    }
  }
  return name;
}

std::string PathPlanner::checkFree(double x, double y) const {
  std::string outside = checkTargetInArena(arena_, x, y, robot_radius_, margin_);
  if (!outside.empty()) return outside;
  const double c = clearance(x, y);
  if (c >= robot_radius_ + margin_) return "";
  std::ostringstream out;
  out.precision(3);
  out << "the spot " << point(x, y) << " is too close to " << nearestThing(x, y) << ": the robot's centre would be "
      << c << " m from it, less than its radius " << robot_radius_ << " m plus the margin " << margin_ << " m";
  return out.str();
}

PathResult PathPlanner::plan(const Pose2D& start, const Pose2D& goal) const {
  PathResult result;
  if (std::string p = checkPose("start", start); !p.empty()) return result.reason = p, result;
  if (std::string p = checkPose("goal", goal); !p.empty()) return result.reason = p, result;
  if (std::string p = checkFree(goal.x, goal.y); !p.empty()) return result.reason = "goal: " + p, result;
  // The start may be inside the margin (e.g. right after a push) but must not overlap anything.
  constexpr double kSlack = 0.002;  // touching within 2 mm counts as touching, not overlapping
  const double start_clearance = clearance(start.x, start.y);
  if (start_clearance < robot_radius_ - kSlack) {
    std::ostringstream out;
    out.precision(3);
    out << "the start " << point(start.x, start.y) << " is blocked: the robot there overlaps "
        << nearestThing(start.x, start.y) << " (its centre is " << start_clearance << " m from it, radius "
        << robot_radius_ << " m)";
    result.reason = out.str();
    return result;
  }

  const int nx = std::max(1, static_cast<int>(std::floor(arena_.size_x / resolution_)));
  const int ny = std::max(1, static_cast<int>(std::floor(arena_.size_y / resolution_)));
  const double cell_x = arena_.size_x / nx, cell_y = arena_.size_y / ny;
  auto centreX = [&](int i) { return -arena_.size_x / 2.0 + (i + 0.5) * cell_x; };
  auto centreY = [&](int j) { return -arena_.size_y / 2.0 + (j + 0.5) * cell_y; };
  auto cellOf = [&](double x, double y) {
    const int i = std::clamp(static_cast<int>(std::floor((x + arena_.size_x / 2.0) / cell_x)), 0, nx - 1);
    const int j = std::clamp(static_cast<int>(std::floor((y + arena_.size_y / 2.0) / cell_y)), 0, ny - 1);
    return j * nx + i;
  };
  const int n = nx * ny;
  // 0 blocked, 1 free (keeps the margin), 2 "soft" (inside the margin, not overlapping).
  std::vector<double> clear(n);
  std::vector<char> state(n, 0);
  for (int k = 0; k < n; ++k) {
    clear[k] = clearance(centreX(k % nx), centreY(k / nx));
    state[k] = clear[k] >= robot_radius_ + margin_ ? 1 : (clear[k] >= robot_radius_ ? 2 : 0);
  }
  const int start_cell = cellOf(start.x, start.y), goal_cell = cellOf(goal.x, goal.y);
  // Soft cells are usable only to get out of the margin from the start: the soft region around it.
  std::vector<char> usable(n, 0);
  for (int k = 0; k < n; ++k) usable[k] = state[k] == 1;
  {
    std::vector<int> stack{start_cell};
    usable[start_cell] = 1;
    while (!stack.empty()) {
      const int k = stack.back();
      stack.pop_back();
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di) {
          const int i = k % nx + di, j = k / nx + dj;
          if (i < 0 || j < 0 || i >= nx || j >= ny) continue;
          const int m = j * nx + i;
          if (state[m] == 2 && !usable[m]) {
            usable[m] = 1;
            stack.push_back(m);
          }
        }
    }
  }
  usable[goal_cell] = 1;  // the goal itself was checked exactly above

  // A* (8-connected, octile heuristic); soft cells cost more so that the path leaves the margin quickly.
  std::vector<double> g(n, std::numeric_limits<double>::infinity());
  std::vector<int> parent(n, -1);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  auto heuristic = [&](int k) {
    const double ax = std::fabs(centreX(k % nx) - centreX(goal_cell % nx));
    const double ay = std::fabs(centreY(k / nx) - centreY(goal_cell / nx));
    return std::max(ax, ay) + (std::sqrt(2.0) - 1.0) * std::min(ax, ay);
  };
  g[start_cell] = 0;
  open.push({heuristic(start_cell), start_cell});
  while (!open.empty()) {
    const auto [f, k] = open.top();
    open.pop();
    if (k == goal_cell) break;
    if (f > g[k] + heuristic(k) + 1e-12) continue;  // stale entry
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        if (!di && !dj) continue;
        const int i = k % nx + di, j = k / nx + dj;
        if (i < 0 || j < 0 || i >= nx || j >= ny) continue;
        const int m = j * nx + i;
        if (!usable[m]) continue;
        const double step = std::hypot(di * cell_x, dj * cell_y) * (state[m] == 2 ? 5.0 : 1.0);
        if (g[k] + step < g[m]) {
          g[m] = g[k] + step;
          parent[m] = k;
          open.push({g[m] + heuristic(m), m});
        }
      }
  }
  if (!std::isfinite(g[goal_cell])) {
    std::ostringstream out;
    out.precision(3);
    out << "no path from " << point(start.x, start.y) << " to " << point(goal.x, goal.y)
        << ": the obstacles close the way for a robot of radius " << robot_radius_ << " m kept " << margin_
        << " m from everything";
    result.reason = out.str();
    return result;
  }

  // Cell chain start..goal, with the exact start and goal at its ends.
  std::vector<int> cells;
  for (int k = goal_cell; k != -1; k = parent[k]) cells.push_back(k);
  std::reverse(cells.begin(), cells.end());
  struct P {
    double x, y, clear;
  };
  std::vector<P> pts;
  for (int k : cells) pts.push_back({centreX(k % nx), centreY(k / nx), clear[k]});
  pts.front() = {start.x, start.y, start_clearance};
  if (pts.size() == 1) pts.push_back({goal.x, goal.y, clearance(goal.x, goal.y)});
  else pts.back() = {goal.x, goal.y, clearance(goal.x, goal.y)};

  // Line-of-sight simplification: a shortcut must keep as much clearance as the cells it replaces
  // (at least the margin, or what the start region had).
  const double wanted = robot_radius_ + margin_;
  auto segmentOk = [&](std::size_t a, std::size_t b) {
    double need = wanted;
    for (std::size_t k = a; k <= b; ++k) need = std::min(need, pts[k].clear);
    need -= 1e-9;
    const double len = std::hypot(pts[b].x - pts[a].x, pts[b].y - pts[a].y);
    const int samples = std::max(1, static_cast<int>(std::ceil(len / (resolution_ / 4.0))));
    for (int s = 0; s <= samples; ++s) {
      const double t = static_cast<double>(s) / samples;
      if (clearance(pts[a].x + t * (pts[b].x - pts[a].x), pts[a].y + t * (pts[b].y - pts[a].y)) < need) return false;
    }
    return true;
  };
  std::vector<std::size_t> keep{0};
  std::size_t anchor = 0;
  while (anchor + 1 < pts.size()) {
    std::size_t next = anchor + 1;
    for (std::size_t b = pts.size() - 1; b > anchor + 1; --b) {
      if (segmentOk(anchor, b)) {
        next = b;
        break;
      }
    }
    keep.push_back(next);
    anchor = next;
  }
  double px = start.x, py = start.y;
  for (std::size_t idx = 1; idx < keep.size(); ++idx) {
    const P& p = pts[keep[idx]];
    Pose2D w{p.x, p.y, std::atan2(p.y - py, p.x - px)};
    result.length += std::hypot(p.x - px, p.y - py);
    if (idx + 1 == keep.size()) w.yaw = normalizeAngle(goal.yaw);
    result.waypoints.push_back(w);
    px = p.x;
    py = p.y;
  }
  result.ok = true;
  return result;
}

}  // namespace xpersif::core
