// External obstacles in the world frame, each with a signed distance: analytic shapes (sphere,
// box, plane) and a dense grid field (an OctoMap turned into a DenseSdf, placed by its pose).
// Obstacle collision (docs/physics.md §6) and adhesion (eqs. 11-12) read them through one
// interface.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "wet_curly_hair/core/dense_sdf.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// An analytic obstacle, world frame.
struct AnalyticObstacle {
  enum class Shape { kSphere, kBox, kPlane };
  Shape shape = Shape::kSphere;
  Vec3 center_m = Vec3::Zero();               ///< sphere and box centre; a point on the plane.
  double radius_m = 0.1;                      ///< sphere radius.
  Vec3 half_extents_m = Vec3(0.1, 0.1, 0.1);  ///< box half sizes along its axes.
  Quat orientation = Quat::Identity();        ///< box axes in the world.
  Vec3 normal = Vec3::UnitZ();                ///< plane: unit normal pointing into free space.

  /// Signed distance of world point x (negative inside) and the unit outward normal.
  double distance(const Vec3& x, Vec3* unit_normal) const;
  /// Checks sizes and finiteness; names the field with the given prefix.
  bool validate(const std::string& prefix, std::string* why) const;
  /// Parses "sphere:x=..,y=..,z=..,r=..", "box:x=..,y=..,z=..,hx=..,hy=..,hz=.." or
  /// "plane:x=..,y=..,z=..,nx=..,ny=..,nz=.." (world frame, metres).
  static bool parse(const std::string& spec, AnalyticObstacle* out, std::string* why);
};

/// A grid field and where it sits in the world. Shared and immutable once built, so a new field
/// can be built on another thread and swapped in between steps.
struct ObstacleField {
  std::shared_ptr<const DenseSdf> sdf;  ///< null: no field.
  Pose field_in_world;                  ///< world <- field frame.
};

/// Every obstacle of a scene.
struct Obstacles {
  std::vector<AnalyticObstacle> analytic;
  ObstacleField field;

  bool empty() const { return analytic.empty() && !field.sdf; }
  /// Signed distance (m) of world point x to the nearest obstacle and its unit outward normal.
  /// +infinity when there is none.
  double distance(const Vec3& x, Vec3* unit_normal) const;
};

}  // namespace wet_curly_hair
