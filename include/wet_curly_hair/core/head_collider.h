// The head as analytic shapes in the head frame (an ellipsoid plus optional capsules for neck
// and ears), and the particle-vs-signed-distance collision response of Bridson et al.
// (method.md §6): projection to the offset surface, inelastic normal response, Coulomb friction.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// A capsule: the points within radius_m of the segment a_m - b_m (head frame).
struct CapsuleShape {
  std::string name;
  Vec3 a_m = Vec3::Zero();
  Vec3 b_m = Vec3::Zero();
  double radius_m = 0.0;
};

/// Signed distance to an ellipsoid, negative inside. There is no closed form; this is the
/// first-order estimate k0 (k0 - 1) / k1 with k0 = |x/r|, k1 = |x/r^2|, exact on the surface and
/// on a sphere, within a few per cent near the surface of a head-like ellipsoid (tested). The
/// gradient direction is the exact surface normal direction x/r^2 of the level set through x.
inline double ellipsoidDistance(const EllipsoidShape& e, const Vec3& x_head, Vec3* normal) {
  const Vec3 x = x_head - e.center_m;
  const Vec3 q = x.cwiseQuotient(e.radii_m);
  const Vec3 g = q.cwiseQuotient(e.radii_m);
  const double k0 = q.norm();
  const double k1 = g.norm();
  if (k1 < 1e-12) {  // at the centre: leave along the shortest axis
    int axis = 0;
    e.radii_m.minCoeff(&axis);
    *normal = Vec3::Unit(axis);
    return -e.radii_m.minCoeff();
  }
  *normal = g / k1;
  return k0 * (k0 - 1.0) / k1;
}

/// Exact signed distance to a capsule, negative inside.
inline double capsuleDistance(const CapsuleShape& c, const Vec3& x, Vec3* normal) {
  const Vec3 ab = c.b_m - c.a_m;
  const double len2 = ab.squaredNorm();
  const double s = len2 > 0.0 ? std::clamp((x - c.a_m).dot(ab) / len2, 0.0, 1.0) : 0.0;
  const Vec3 d = x - (c.a_m + s * ab);
  const double n = d.norm();
  if (n < 1e-12) {
    *normal = len2 > 0.0 ? Vec3(ab.cross(Vec3::UnitZ()).norm() > 1e-9 ? ab.cross(Vec3::UnitZ())
                                                                       : ab.cross(Vec3::UnitX()))
                               .normalized()
                         : Vec3::UnitZ();
    return -c.radius_m;
  }
  *normal = d / n;
  return n - c.radius_m;
}

/// The head's collision shapes, in the head frame.
struct HeadShape {
  EllipsoidShape ellipsoid;
  std::vector<CapsuleShape> capsules;

  /// Signed distance (m) of head-frame point x to the union of the shapes, with the unit outward
  /// normal of the closest shape.
  double distance(const Vec3& x, Vec3* normal) const {
    double best = ellipsoidDistance(ellipsoid, x, normal);
    for (const CapsuleShape& c : capsules) {
      Vec3 n;
      const double d = capsuleDistance(c, x, &n);
      if (d < best) {
        best = d;
        *normal = n;
      }
    }
    return best;
  }
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Bridson-style response of one particle to a collider (method.md §6): if the signed distance d
/// of position x is below the offset delta, x is moved out along the unit normal n to the offset
/// surface, the approaching normal relative velocity is removed (inelastic) and the tangential
/// relative velocity is reduced by mu times the removed normal speed (Coulomb; it stops when the
/// friction would reverse it). The projection adds no velocity, so deep starts do not explode.
/// v_obstacle is the collider's velocity at x. Returns true when the particle was in contact.
inline bool collideParticle(double d, const Vec3& n, double delta, double mu,
                            const Vec3& v_obstacle, Vec3* x, Vec3* v) {
  if (d >= delta) return false;
  *x += (delta - d) * n;
  const Vec3 vrel = *v - v_obstacle;
  const double vn = vrel.dot(n);
  if (vn < 0.0) {
    Vec3 vt = vrel - vn * n;
    const double vt_len = vt.norm();
    const double scale = vt_len > 1e-15 ? std::max(0.0, 1.0 - mu * (-vn) / vt_len) : 0.0;
    vt *= scale;
    *v = v_obstacle + vt;
  }
  return true;
}

}  // namespace wet_curly_hair
