#include "xpersif/core/common/footprint.h"

#include <algorithm>
#include <cmath>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {
bool alongX(const std::string& side) { return side == "-x" || side == "+x"; }
}  // namespace

Footprint Footprint::rectangle(double size_x, double size_y) {
  Footprint f;
  f.kind = Kind::Rectangle;
  f.size_x = size_x;
  f.size_y = size_y;
  return f;
}

Footprint Footprint::disc(double radius) {
  Footprint f;
  f.kind = Kind::Disc;
  f.radius = radius;
  return f;
}

Footprint Footprint::ofShape(const Shape& shape) {
  if (shape.type == Shape::Type::Box) return rectangle(shape.box_size.x(), shape.box_size.y());
  return disc(shape.radius);
}

double Footprint::depth(const std::string& side) const {
  if (isDisc()) return radius;
  return 0.5 * (alongX(side) ? size_x : size_y);
}

double Footprint::halfWidth(const std::string& side) const {
  if (isDisc()) return radius;
  return 0.5 * (alongX(side) ? size_y : size_x);
}

double Footprint::circumradius() const { return isDisc() ? radius : 0.5 * std::hypot(size_x, size_y); }

double Footprint::signedDistance(double lx, double ly) const {
  if (isDisc()) return std::hypot(lx, ly) - radius;
  const double qx = std::fabs(lx) - 0.5 * size_x, qy = std::fabs(ly) - 0.5 * size_y;
  return std::hypot(std::max(qx, 0.0), std::max(qy, 0.0)) + std::min(std::max(qx, qy), 0.0);
}

std::string Footprint::check(const std::string& field) const {
  if (isDisc()) return checkPositive(field + ".radius", radius);
  std::string p = checkPositive(field + ".size_x", size_x);
  return p.empty() ? checkPositive(field + ".size_y", size_y) : p;
}

std::string Footprint::describe() const {
  if (isDisc()) return "a disc of radius " + describeNumber(radius) + " m";
  return "a " + describeNumber(size_x) + " x " + describeNumber(size_y) + " m rectangle";
}

double maxPushOffset(const Footprint& footprint, const std::string& side) {
  return footprint.isDisc() ? 0.5 * footprint.radius : footprint.halfWidth(side);
}

void worldHalfExtents(const Footprint& footprint, double yaw, double& half_x, double& half_y) {
  if (footprint.isDisc()) {
    half_x = half_y = footprint.radius;
    return;
  }
  const double c = std::fabs(std::cos(yaw)), s = std::fabs(std::sin(yaw));
  half_x = 0.5 * (footprint.size_x * c + footprint.size_y * s);
  half_y = 0.5 * (footprint.size_x * s + footprint.size_y * c);
}

}  // namespace xpersif::core
