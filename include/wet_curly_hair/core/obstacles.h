// External obstacles in the world frame, each with a signed distance: analytic shapes (sphere,
// box, plane) and a dense grid field (an OctoMap turned into a DenseSdf, placed by its pose).
// Obstacle collision (docs/physics.md §6) and adhesion (eqs. 11-12) read them through one
// interface.
#pragma once

#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "wet_curly_hair/core/dense_sdf.h"
#include "wet_curly_hair/core/lane_math.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Signed distance of x to a sphere about `center` (negative inside) and the unit outward normal
/// (+z at the centre), on lanes; AnalyticObstacle::distance is the same law with S = double.
template <typename S>
WCH_INLINE S sphereDistance(const V3<S>& center, double radius_m, const V3<S>& x, V3<S>* normal) {
  const V3<S> d = x - center;
  const S r = vsqrt(dot(d, d));
  *normal = select(r > splat<S>(1e-12), d / r, splat3<S>(Vec3::UnitZ()));
  return r - splat<S>(radius_m);
}

/// Signed distance of x to the plane through `point` with unit normal `normal` (into free space).
template <typename S>
WCH_INLINE S planeDistance(const V3<S>& point, const V3<S>& normal, const V3<S>& x,
                           V3<S>* unit_normal) {
  *unit_normal = normal;
  return dot(normal, x - point);
}

/// Lanes whose cached distance must be evaluated at x: where the particle has moved the slack or
/// more from the anchor, the point of the last evaluation (or the slack is not positive). The
/// slack is (distance - reach) / L for a distance that changes by at most L |dx| when the point
/// moves by dx: while |x - anchor| stays below it, the distance is still beyond the stage's
/// reach, so nothing can act and the evaluation is skipped: the same result, less work. The
/// solver's obstacle and head stages and the follower projections use it.
template <typename S>
WCH_INLINE LaneMask<S> distanceNeeded(const V3<S>& x, const V3<S>& anchor, const S& slack) {
  const V3<S> dx = x - anchor;
  return !((slack > splat<S>(0.0)) && (dot(dx, dx) < slack * slack));
}

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
  /// The same on lanes, at the world points x + origin (x relative to origin keeps float lanes
  /// precise far from the world's origin), for the lanes of `lanes`: spheres and planes on every
  /// lane at once, boxes, the field and (in float lanes) spheres reaching more than 2 m from the
  /// origin lane by lane in double. Other lanes' values are unspecified.
  template <typename S>
  S distance(const V3<S>& x, const Vec3& origin, const LaneMask<S>& lanes,
             V3<S>* unit_normal) const;
};

template <typename S>
S Obstacles::distance(const V3<S>& x, const Vec3& origin, const LaneMask<S>& lanes,
                      V3<S>* unit_normal) const {
  S best = splat<S>(std::numeric_limits<double>::infinity());
  *unit_normal = splat3<S>(Vec3::UnitZ());
  // The nearest obstacle wins; on a tie the earlier one, the field last (as the scalar form).
  const auto take = [&](const S& d, const V3<S>& n) {
    const auto closer = d < best;
    best = select(closer, d, best);
    *unit_normal = select(closer, n, *unit_normal);
  };
  const auto lane_by_lane = [&](auto&& scalar_distance) {
    S d = splat<S>(std::numeric_limits<double>::infinity());
    V3<S> n = splat3<S>(Vec3::UnitZ());
    patchLanes(lanes, [&](int l) {
      Vec3 nl;
      setLaneValue(&d, l, scalar_distance(lane(x, l) + origin, &nl));
      setLane(&n, l, nl);
    });
    take(d, n);
  };
  // Float lanes hold a sphere's centre relative to the origin to a few ulps of its distance:
  // near spheres are read on every lane (2.4e-7 m at this reach), far or large ones lane by lane
  // in double, as precisely as the particles themselves.
  constexpr bool kFloatLanes = std::is_same<typename LaneTraits<S>::Elem, float>::value;
  constexpr double kFloatLaneSphereReach_m = 2.0;
  for (const AnalyticObstacle& o : analytic) {
    V3<S> n;
    const bool lanes_hold_sphere =
        !kFloatLanes || (o.center_m - origin).norm() + o.radius_m <= kFloatLaneSphereReach_m;
    if (o.shape == AnalyticObstacle::Shape::kSphere && lanes_hold_sphere) {
      take(sphereDistance(splat3<S>(Vec3(o.center_m - origin)), o.radius_m, x, &n), n);
    } else if (o.shape == AnalyticObstacle::Shape::kPlane) {
      // The plane's point nearest the origin: relative to the origin it is as long as the
      // origin's distance from the plane, so float lanes hold it as precisely as the particles
      // (divided by |n|^2, n . (x - point) is n . (x - center) for a normal unit only to 1e-6).
      const Vec3 point = (o.normal.dot(o.center_m - origin) / o.normal.squaredNorm()) * o.normal;
      take(planeDistance(splat3<S>(point), splat3<S>(o.normal), x, &n), n);
    } else {
      lane_by_lane([&](const Vec3& w, Vec3* nl) { return o.distance(w, nl); });
    }
  }
  if (field.sdf) {
    lane_by_lane([&](const Vec3& w, Vec3* nl) {
      Vec3 g;
      const double d = field.sdf->distanceAndGradient(field.field_in_world.applyInverse(w), &g);
      *nl = field.field_in_world.rotate(g);
      return d;
    });
  }
  return best;
}

}  // namespace wet_curly_hair
