#include "xpersif/core/common/pose_estimate.h"

#include <cmath>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

Pose2D compose(const Pose2D& a, const Pose2D& b) {
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, wrapAngle(a.yaw + b.yaw)};
}

Pose2D inverse(const Pose2D& a) {
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  return {-c * a.x - s * a.y, s * a.x - c * a.y, wrapAngle(-a.yaw)};
}

namespace {
void requirePose(const std::string& what, double t, const Pose2D& p) {
  requireAllFinite(what + " (t, x, y, yaw)", {t, p.x, p.y, p.yaw});
}
}  // namespace

OdometryCorrection::OdometryCorrection(double history_seconds) : history_seconds_(history_seconds) {
  requirePositive("history_seconds", history_seconds);
}

void OdometryCorrection::addOdometry(double t, const Pose2D& odometry) {
  requirePose("odometry", t, odometry);
  // Time going backwards (a simulator reset, a bag played again) starts a new history.
  if (!history_.empty() && t < history_.back().first) history_.clear();
  history_.emplace_back(t, odometry);
  while (history_.size() > 2 && history_.front().first < t - history_seconds_) history_.pop_front();
}

bool OdometryCorrection::odometryAt(double t, double max_lead, Pose2D* pose) const {
  if (history_.empty() || t < history_.front().first) return false;
  if (t >= history_.back().first) {
    if (t - history_.back().first > max_lead) return false;
    *pose = history_.back().second;
    return true;
  }
  for (std::size_t i = 1; i < history_.size(); ++i) {
    if (history_[i].first < t) continue;
    const auto& [t0, p0] = history_[i - 1];
    const auto& [t1, p1] = history_[i];
    const double f = t1 > t0 ? (t - t0) / (t1 - t0) : 1.0;
    *pose = {p0.x + f * (p1.x - p0.x), p0.y + f * (p1.y - p0.y), wrapAngle(p0.yaw + f * wrapAngle(p1.yaw - p0.yaw))};
    return true;
  }
  return false;
}

std::string OdometryCorrection::addFix(double t, const Pose2D& fix, double max_lead) {
  requirePose("fix", t, fix);
  Pose2D odometry;
  if (!odometryAt(t, max_lead, &odometry)) {
    return history_.empty() ? "no odometry yet" : "no odometry around the fix's time (history covers " +
                                                      std::to_string(history_.front().first) + " .. " +
                                                      std::to_string(history_.back().first) + " s)";
  }
  correction_ = compose(fix, inverse(odometry));
  corrected_ = true;
  return "";
}

void OdometryCorrection::reset() {
  history_.clear();
  correction_ = Pose2D();
  corrected_ = false;
}

Pose2D OdometryCorrection::odometry() const { return history_.empty() ? Pose2D() : history_.back().second; }

Pose2D OdometryCorrection::estimate() const { return compose(correction_, odometry()); }

}  // namespace xpersif::core
