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

namespace {

// What a grid cell is to a robot centred on it.
enum CellState : char {
  kBlocked = 0,  // the robot would overlap something
  kFree = 1,     // the robot keeps the margin
  kSoft = 2,     // inside the margin, not overlapping
};

// The planning grid over the arena: about resolution-sized cells, each with the clearance at its centre.
struct Grid {
  double size_x, size_y;
  int nx, ny;
  double cell_x, cell_y;
  std::vector<double> clear;
  std::vector<char> state;  // CellState

  Grid(const ArenaGeometry& arena, double resolution)
      : size_x(arena.size_x),
        size_y(arena.size_y),
        nx(std::max(1, static_cast<int>(std::floor(arena.size_x / resolution)))),
        ny(std::max(1, static_cast<int>(std::floor(arena.size_y / resolution)))),
        cell_x(arena.size_x / nx),
        cell_y(arena.size_y / ny) {}

  int count() const { return nx * ny; }
  double centreX(int i) const { return -size_x / 2.0 + (i + 0.5) * cell_x; }
  double centreY(int j) const { return -size_y / 2.0 + (j + 0.5) * cell_y; }
  int cellOf(double x, double y) const {
    const int i = std::clamp(static_cast<int>(std::floor((x + size_x / 2.0) / cell_x)), 0, nx - 1);
    const int j = std::clamp(static_cast<int>(std::floor((y + size_y / 2.0) / cell_y)), 0, ny - 1);
    return j * nx + i;
  }
  /// f(m, di, dj) for each of cell k's 8 neighbours m inside the grid, row by row.
  template <typename F>
  void forEachNeighbour(int k, F f) const {
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        if (!di && !dj) continue;
        const int i = k % nx + di, j = k / nx + dj;
        if (i < 0 || j < 0 || i >= nx || j >= ny) continue;
        f(j * nx + i, di, dj);
      }
  }
};

Grid clearanceGrid(const PathPlanner& planner, double resolution) {
  Grid grid(planner.arena(), resolution);
  const int n = grid.count();
  const double radius = planner.robotRadius(), margin = planner.margin();
  grid.clear.resize(n);
  grid.state.assign(n, kBlocked);
  for (int k = 0; k < n; ++k) {
    grid.clear[k] = planner.clearance(grid.centreX(k % grid.nx), grid.centreY(k / grid.nx));
    grid.state[k] = grid.clear[k] >= radius + margin ? kFree : (grid.clear[k] >= radius ? kSoft : kBlocked);
  }
  return grid;
}

// The cells a path may use: the free ones, the goal (checked exactly before), and the soft region around the
// start, so that a robot inside the margin can get out of it.
std::vector<char> usableCells(const Grid& grid, int start_cell, int goal_cell) {
  std::vector<char> usable(grid.count(), 0);
  for (int k = 0; k < grid.count(); ++k) usable[k] = grid.state[k] == kFree;
  std::vector<int> stack{start_cell};
  usable[start_cell] = 1;
  while (!stack.empty()) {
    const int k = stack.back();
    stack.pop_back();
    grid.forEachNeighbour(k, [&](int m, int, int) {
      if (grid.state[m] == kSoft && !usable[m]) {
        usable[m] = 1;
        stack.push_back(m);
      }
    });
  }
  usable[goal_cell] = 1;
  return usable;
}

// A* (8-connected, octile heuristic) over the usable cells; soft cells cost more so that the path leaves the
// margin quickly. The chain of cells from start to goal, empty when the goal cannot be reached.
std::vector<int> searchCells(const Grid& grid, const std::vector<char>& usable, int start_cell, int goal_cell) {
  const int n = grid.count(), nx = grid.nx;
  std::vector<double> g(n, std::numeric_limits<double>::infinity());
  std::vector<int> parent(n, -1);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  auto heuristic = [&](int k) {
    const double ax = std::fabs(grid.centreX(k % nx) - grid.centreX(goal_cell % nx));
    const double ay = std::fabs(grid.centreY(k / nx) - grid.centreY(goal_cell / nx));
    return std::max(ax, ay) + (std::sqrt(2.0) - 1.0) * std::min(ax, ay);
  };
  g[start_cell] = 0;
  open.push({heuristic(start_cell), start_cell});
  while (!open.empty()) {
    const auto [f, k] = open.top();
    open.pop();
    if (k == goal_cell) break;
    if (f > g[k] + heuristic(k) + 1e-12) continue;  // stale entry
    grid.forEachNeighbour(k, [&](int m, int di, int dj) {
      if (!usable[m]) return;
      const double step = std::hypot(di * grid.cell_x, dj * grid.cell_y) * (grid.state[m] == kSoft ? 5.0 : 1.0);
      if (g[k] + step < g[m]) {
        g[m] = g[k] + step;
        parent[m] = k;
        open.push({g[m] + heuristic(m), m});
      }
    });
  }
  std::vector<int> cells;
  if (!std::isfinite(g[goal_cell])) return cells;
  for (int k = goal_cell; k != -1; k = parent[k]) cells.push_back(k);
  std::reverse(cells.begin(), cells.end());
  return cells;
}

struct PathPoint {
  double x, y, clear;
};

// The cell chain's centres, with the exact start and goal at its ends.
std::vector<PathPoint> pathPoints(const PathPlanner& planner, const Grid& grid, const std::vector<int>& cells,
                                  const Pose2D& start, const Pose2D& goal) {
  std::vector<PathPoint> pts;
  for (int k : cells) pts.push_back({grid.centreX(k % grid.nx), grid.centreY(k / grid.nx), grid.clear[k]});
  pts.front() = {start.x, start.y, planner.clearance(start.x, start.y)};
  if (pts.size() == 1) pts.push_back({goal.x, goal.y, planner.clearance(goal.x, goal.y)});
  else pts.back() = {goal.x, goal.y, planner.clearance(goal.x, goal.y)};
  return pts;
}

// Line-of-sight simplification: the indices of the points kept. A shortcut must keep as much clearance as the
// cells it replaces (at least the margin, or what the start region had).
std::vector<std::size_t> lineOfSight(const PathPlanner& planner, const std::vector<PathPoint>& pts, double resolution) {
  const double wanted = planner.robotRadius() + planner.margin();
  auto segmentOk = [&](std::size_t a, std::size_t b) {
    double need = wanted;
    for (std::size_t k = a; k <= b; ++k) need = std::min(need, pts[k].clear);
    need -= 1e-9;
    const double len = std::hypot(pts[b].x - pts[a].x, pts[b].y - pts[a].y);
    const int samples = std::max(1, static_cast<int>(std::ceil(len / (resolution / 4.0))));
    for (int s = 0; s <= samples; ++s) {
      const double t = static_cast<double>(s) / samples;
      const double x = pts[a].x + t * (pts[b].x - pts[a].x), y = pts[a].y + t * (pts[b].y - pts[a].y);
      if (planner.clearance(x, y) < need) return false;
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
  return keep;
}

// The kept points as waypoints: each faces the way it is reached from the one before, the last the goal's yaw.
void addWaypoints(const std::vector<PathPoint>& pts, const std::vector<std::size_t>& keep, const Pose2D& start,
                  const Pose2D& goal, PathResult& result) {
  double px = start.x, py = start.y;
  for (std::size_t idx = 1; idx < keep.size(); ++idx) {
    const PathPoint& p = pts[keep[idx]];
    Pose2D w{p.x, p.y, std::atan2(p.y - py, p.x - px)};
    result.length += std::hypot(p.x - px, p.y - py);
    if (idx + 1 == keep.size()) w.yaw = normalizeAngle(goal.yaw);
    result.waypoints.push_back(w);
    px = p.x;
    py = p.y;
  }
}

}  // namespace

std::string PathPlanner::checkEnds(const Pose2D& start, const Pose2D& goal) const {
  if (std::string p = checkPose("start", start); !p.empty()) return p;
  if (std::string p = checkPose("goal", goal); !p.empty()) return p;
  if (std::string p = checkFree(goal.x, goal.y); !p.empty()) return "goal: " + p;
  // The start may be inside the margin (e.g. right after a push) but must not overlap anything.
  constexpr double kSlack = 0.002;  // touching within 2 mm counts as touching, not overlapping
  const double start_clearance = clearance(start.x, start.y);
  if (!(start_clearance < robot_radius_ - kSlack)) return "";
  std::ostringstream out;
  out.precision(3);
  out << "the start " << point(start.x, start.y) << " is blocked: the robot there overlaps "
      << nearestThing(start.x, start.y) << " (its centre is " << start_clearance << " m from it, radius "
      << robot_radius_ << " m)";
  return out.str();
}

PathResult PathPlanner::plan(const Pose2D& start, const Pose2D& goal) const {
  PathResult result;
  result.reason = checkEnds(start, goal);
  if (!result.reason.empty()) return result;
  const Grid grid = clearanceGrid(*this, resolution_);
  const int start_cell = grid.cellOf(start.x, start.y), goal_cell = grid.cellOf(goal.x, goal.y);
  const std::vector<int> cells = searchCells(grid, usableCells(grid, start_cell, goal_cell), start_cell, goal_cell);
  if (cells.empty()) {
    std::ostringstream out;
    out.precision(3);
    out << "no path from " << point(start.x, start.y) << " to " << point(goal.x, goal.y)
        << ": the obstacles close the way for a robot of radius " << robot_radius_ << " m kept " << margin_
        << " m from everything";
    result.reason = out.str();
    return result;
  }
  const std::vector<PathPoint> pts = pathPoints(*this, grid, cells, start, goal);
  addWaypoints(pts, lineOfSight(*this, pts, resolution_), start, goal, result);
  result.ok = true;
  return result;
}

}  // namespace xpersif::core
