#include "xpersif/core/learning/goal_choice.h"

#include <algorithm>
#include <cmath>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

Pose2D predictedEnd(const ObjectFeatures& object, const std::string& side, const Outcome& outcome) {
  const double direction = object.yaw + pushAngleInObject(side);
  const double c = std::cos(direction), s = std::sin(direction);
  return {object.x + c * outcome.dx - s * outcome.dy, object.y + s * outcome.dx + c * outcome.dy,
          wrapAngle(object.yaw + outcome.dyaw)};
}

PushChoice bestPush(const PushModel& model, const ObjectFeatures& object, double tx, double ty,
                    const std::vector<Experiment>& candidates, double uncertainty_weight) {
  if (candidates.empty()) throw ValidationError("there is no candidate push to choose from");
  requireInRange("uncertainty_weight", uncertainty_weight, 0.0, 1e6);
  PushChoice best;
  double best_cost = INFINITY;
  for (const auto& c : candidates) {
    const Prediction p = model.predict(PushInput{c, object});
    const Pose2D end = predictedEnd(object, c.side, p.mean);
    const double error = std::hypot(end.x - tx, end.y - ty);
    const double variance = p.std.dx * p.std.dx + p.std.dy * p.std.dy;
    const double cost = error * error + uncertainty_weight * variance;
    if (cost < best_cost) {
      best_cost = cost;
      best = {c, error, std::sqrt(variance)};
    }
  }
  return best;
}

double predictedSpread(const PushModel& model, const ObjectFeatures& object, const std::vector<Experiment>& pushes) {
  std::vector<double> spreads;
  for (const auto& push : pushes) {
    const Prediction p = model.predict(PushInput{push, object});
    spreads.push_back(std::hypot(p.std.dx, p.std.dy));
  }
  if (spreads.empty()) return INFINITY;
  std::nth_element(spreads.begin(), spreads.begin() + spreads.size() / 2, spreads.end());
  return spreads[spreads.size() / 2];
}

}  // namespace xpersif::core
