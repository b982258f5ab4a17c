/**
 * @file footprint.h
 * @brief An object's footprint on the floor, seen from above, and the push geometry that follows from it:
 *        how far a pushed face lies from the centre and how wide it is. Boxes stand on a rectangle; upright
 *        cylinders and spheres on a disc. ROS-free.
 *
 * Sides are named in the object's frame ("-x", "+x", "-y", "+y": the face whose outward normal is that axis);
 * a disc has no faces, so for it a side only names a push direction (the line through its centre along that
 * axis), and an object frame whose yaw nobody can observe is taken as the world's.
 */
#pragma once

#include <string>

#include "xpersif/core/common/scene.h"

namespace xpersif::core {

struct Footprint {
  enum class Kind { Rectangle, Disc };
  Kind kind = Kind::Rectangle;
  double size_x = 0.04, size_y = 0.04;  ///< rectangle: full extents along the object's x and y, m
  double radius = 0.02;                 ///< disc, m

  /// A box's rectangle; a cylinder's or a sphere's disc (a cylinder stands on its end, axis along z).
  static Footprint ofShape(const Shape& shape);
  static Footprint rectangle(double size_x, double size_y);
  static Footprint disc(double radius);

  bool isDisc() const { return kind == Kind::Disc; }
  /// From the centre to the pushed face (or the disc's rim) along the side's axis, m.
  double depth(const std::string& side) const;
  /// Half the width of the pushed face, across the push, m (a disc: its radius).
  double halfWidth(const std::string& side) const;
  /// Radius of the smallest disc around the centre that holds the footprint, m.
  double circumradius() const;
  /// Signed distance from a point (in the object's frame) to the footprint: negative inside, m.
  double signedDistance(double local_x, double local_y) const;
  /// "" when every extent is finite and > 0, else a sentence naming @p field.
  std::string check(const std::string& field) const;
  /// e.g. "a 0.08 x 0.03 m rectangle", "a disc of radius 0.025 m".
  std::string describe() const;
};

/**
 * @brief The largest |offset| of a push on @p side: where the contact may lie across the push, m. A rectangle:
 *        half the pushed face's width. A disc: half its radius, so the contact stays on the disc's front and the
 *        push still drives it forward rather than glancing off.
 */
double maxPushOffset(const Footprint& footprint, const std::string& side);

/// Half the footprint's extent along world x and y when the object is turned by @p yaw (its bounding box).
void worldHalfExtents(const Footprint& footprint, double yaw, double& half_x, double& half_y);

}  // namespace xpersif::core
