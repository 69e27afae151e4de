// The head as analytic shapes in the head frame (an ellipsoid plus optional capsules for neck
// and ears), and the particle-vs-signed-distance collision response of Bridson et al.
// (docs/physics.md §6): projection to the offset surface, inelastic normal response, Coulomb
// friction.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/lane_math.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// A capsule: the points within radius_m of the segment a_m - b_m (head frame).
struct CapsuleShape {
  std::string name;
  Vec3 a_m = Vec3::Zero();
  Vec3 b_m = Vec3::Zero();
  double radius_m = 0.0;
};

/// ellipsoidDistance's rare branch, a point at the centre: leave along the shortest axis.
WCH_INLINE double ellipsoidCentreDistance(const EllipsoidShape& e, Vec3* normal) {
  int axis = 0;
  e.radii_m.minCoeff(&axis);
  *normal = Vec3::Unit(axis);
  return -e.radii_m.minCoeff();
}

/// r_min (k0 - 1), k0 = |x / r| of a head-frame point x relative to the centre: at most
/// ellipsoidDistance's estimate outside the ellipsoid (k1 <= k0 / r_min there) and 1-Lipschitz in
/// x (k0 is), so it bounds the estimate near x too.
template <typename S>
WCH_INLINE S ellipsoidDistanceLowerBound(const EllipsoidShape& e, const S& k0) {
  return splat<S>(e.radii_m.minCoeff()) * (k0 - splat<S>(1.0));
}

/// Signed distance to an ellipsoid, negative inside. There is no closed form; this is the
/// first-order estimate k0 (k0 - 1) / k1 with k0 = |x/r|, k1 = |x/r^2|, exact on the surface and
/// on a sphere, within a few per cent near the surface of a head-like ellipsoid (tested). The
/// gradient direction is the exact surface normal direction x/r^2 of the level set through x.
/// lower_bound (optional) receives ellipsoidDistanceLowerBound.
template <typename S>
WCH_INLINE S ellipsoidDistance(const EllipsoidShape& e, const V3<S>& x_head, V3<S>* normal,
                               S* lower_bound = nullptr) {
  // Products with the inverse radii and one reciprocal of k1: divisions are the costly lane
  // operation here, and this runs for every particle on every substep.
  const V3<S> x = x_head - splat3<S>(e.center_m);
  const V3<S> inv_r = splat3<S>(e.radii_m.cwiseInverse());
  const V3<S> q = {x.x * inv_r.x, x.y * inv_r.y, x.z * inv_r.z};
  const V3<S> g = {q.x * inv_r.x, q.y * inv_r.y, q.z * inv_r.z};
  const S k0 = vsqrt(dot(q, q));
  if (lower_bound) *lower_bound = ellipsoidDistanceLowerBound(e, k0);
  const S inv_k1 = splat<S>(1.0) / vsqrt(dot(g, g));
  *normal = inv_k1 * g;
  S dist = k0 * (k0 - splat<S>(1.0)) * inv_k1;
  patchLanes(inv_k1 > splat<S>(1e12), [&](int l) {
    Vec3 n;
    setLaneValue(&dist, l, ellipsoidCentreDistance(e, &n));
    setLane(normal, l, n);
  });
  return dist;
}

/// capsuleDistance's rare branch, a point on the axis: leave across the axis.
WCH_INLINE double capsuleAxisDistance(const CapsuleShape& c, Vec3* normal) {
  const Vec3 ab = c.b_m - c.a_m;
  if (ab.squaredNorm() > 0.0) {
    const Vec3 across =
        ab.cross(Vec3::UnitZ()).norm() > 1e-9 ? ab.cross(Vec3::UnitZ()) : ab.cross(Vec3::UnitX());
    *normal = across.normalized();
  } else {
    *normal = Vec3::UnitZ();
  }
  return -c.radius_m;
}

/// Exact signed distance to a capsule, negative inside.
template <typename S>
WCH_INLINE S capsuleDistance(const CapsuleShape& c, const V3<S>& x, V3<S>* normal) {
  const Vec3 ab = c.b_m - c.a_m;
  const double len2 = ab.squaredNorm();
  const V3<S> a = splat3<S>(c.a_m);
  S s = splat<S>(0.0);
  if (len2 > 0.0)
    s = vmin(vmax(dot(x - a, splat3<S>(ab)) * splat<S>(1.0 / len2), splat<S>(0.0)), splat<S>(1.0));
  const V3<S> d = x - (a + s * splat3<S>(ab));
  const S len = vsqrt(dot(d, d));
  *normal = (splat<S>(1.0) / len) * d;
  S dist = len - splat<S>(c.radius_m);
  patchLanes(len < splat<S>(1e-12), [&](int l) {
    Vec3 n;
    setLaneValue(&dist, l, capsuleAxisDistance(c, &n));
    setLane(normal, l, n);
  });
  return dist;
}

WCH_INLINE double ellipsoidDistance(const EllipsoidShape& e, const Vec3& x_head, Vec3* normal) {
  V3<double> n;
  const double d = ellipsoidDistance(e, toV3(x_head), &n);
  *normal = toEigen(n);
  return d;
}
WCH_INLINE double capsuleDistance(const CapsuleShape& c, const Vec3& x, Vec3* normal) {
  V3<double> n;
  const double d = capsuleDistance(c, toV3(x), &n);
  *normal = toEigen(n);
  return d;
}

/// The head's collision shapes, in the head frame.
struct HeadShape {
  EllipsoidShape ellipsoid;
  std::vector<CapsuleShape> capsules;

  /// Signed distance (m) of head-frame point x to the union of the shapes, with the unit outward
  /// normal of the closest shape. lower_bound (optional) receives a 1-Lipschitz lower bound of
  /// the distance where it is positive: the ellipsoid's (ellipsoidDistance) and the capsules'
  /// exact distances, the smallest. So the distance at y is at least lower_bound - |y - x|.
  template <typename S>
  WCH_INLINE S distance(const V3<S>& x, V3<S>* normal, S* lower_bound = nullptr) const {
    S best = ellipsoidDistance(ellipsoid, x, normal, lower_bound);
    for (const CapsuleShape& c : capsules) {
      V3<S> n;
      const S d = capsuleDistance(c, x, &n);
      const auto closer = d < best;
      *normal = select(closer, n, *normal);
      best = select(closer, d, best);
      if (lower_bound) *lower_bound = vmin(*lower_bound, d);
    }
    return best;
  }
  double distance(const Vec3& x, Vec3* normal) const {
    V3<double> n;
    const double d = distance(toV3(x), &n);
    *normal = toEigen(n);
    return d;
  }
  /// The lower bound of distance() at x (its lower_bound), without the ellipsoid's divisions.
  template <typename S>
  WCH_INLINE S lowerBound(const V3<S>& x) const {
    const V3<S> d = x - splat3<S>(ellipsoid.center_m);
    const V3<S> inv_r = splat3<S>(ellipsoid.radii_m.cwiseInverse());
    const V3<S> q = {d.x * inv_r.x, d.y * inv_r.y, d.z * inv_r.z};
    S bound = ellipsoidDistanceLowerBound(ellipsoid, vsqrt(dot(q, q)));
    for (const CapsuleShape& c : capsules) {
      V3<S> n;
      bound = vmin(bound, capsuleDistance(c, x, &n));
    }
    return bound;
  }
  double lowerBound(const Vec3& x) const { return lowerBound(toV3(x)); }
  /// Whether distance(x) >= d for sure: lowerBound. 1 nm of margin covers the round-off of the
  /// bound, so a true answer never hides a contact; false says nothing.
  bool surelyFartherThan(const Vec3& x, double d) const {
    return lowerBound(x) >= d + kSurelyMargin_m;
  }
  static constexpr double kSurelyMargin_m = 1e-9;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Bridson-style response of particles to a collider (physics.md §6), on the lanes of `contact`
/// (signed distance d below the offset delta): x is moved out along the unit normal n to the
/// offset surface, the approaching normal relative velocity is removed (inelastic) and the
/// tangential relative velocity is reduced by mu times the removed normal speed (Coulomb; it
/// stops when the friction would reverse it). The projection adds no velocity, so deep starts
/// do not explode. v_obstacle is the collider's velocity at x.
template <typename S>
WCH_INLINE void collideParticle(const LaneMask<S>& contact, const S& d, const V3<S>& n,
                                const S& delta, double mu, const V3<S>& v_obstacle, V3<S>* x,
                                V3<S>* v) {
  *x = select(contact, *x + (delta - d) * n, *x);
  const V3<S> vrel = *v - v_obstacle;
  const S vn = dot(vrel, n);
  const auto approaching = contact && (vn < splat<S>(0.0));
  V3<S> vt = vrel - vn * n;
  const S vt_len = vsqrt(dot(vt, vt));
  const S scale =
      select(vt_len > splat<S>(1e-15),
             vmax(splat<S>(0.0), splat<S>(1.0) - splat<S>(mu) * (-vn) / vt_len), splat<S>(0.0));
  vt = scale * vt;
  *v = select(approaching, v_obstacle + vt, *v);
}

/// The same for one particle; returns true when it was in contact (d < delta).
WCH_INLINE bool collideParticle(double d, const Vec3& n, double delta, double mu,
                                const Vec3& v_obstacle, Vec3* x, Vec3* v) {
  if (!(d < delta)) return false;
  V3<double> xs = toV3(*x), vs = toV3(*v);
  collideParticle<double>(true, d, toV3(n), delta, mu, toV3(v_obstacle), &xs, &vs);
  *x = toEigen(xs);
  *v = toEigen(vs);
  return true;
}

}  // namespace wet_curly_hair
