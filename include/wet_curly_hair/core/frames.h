// Frames parallel-transported along the smoothed curve (Iben et al. 2013; docs/physics.md §2.4,
// §10.5), generic over the lane scalar S (lane_math.h) with Eigen forms for callers that speak
// Eigen.
#pragma once

#include <cmath>

#include "wet_curly_hair/core/lane_math.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Length below which a direction is treated as undefined (m or m/s).
constexpr double kDirectionEpsilon = 1e-12;

/// Any unit vector perpendicular to unit vector a.
WCH_INLINE Vec3 anyPerpendicular(const Vec3& a) {
  const Vec3 helper = std::abs(a.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return a.cross(helper).normalized();
}

/// The terms of I + [v]_x + [v]_x^2 / (1 + c), v = from x to, c = from . to: the rotation
/// taking unit `from` onto unit `to` in the 1/(1+c) form, which has no cancellation at small
/// angles (physics.md §10.5); loses all precision as the two become opposite (minimalRotation).
/// With [v]_x^2 = v v^T - |v|^2 I and w = v / (1 + c) it is diagonal I + [v]_x + v w^T,
/// diagonal = 1 - v . w: one reciprocal, no cancellation. The matrix (rodrigues) and its action
/// on a vector (rodriguesApplied) are both formed from these terms.
template <typename S>
struct RodriguesTerms {
  V3<S> v, w;
  S diagonal;
  WCH_INLINE RodriguesTerms(const V3<S>& from, const V3<S>& to, const S& c) {
    v = cross(from, to);
    w = (splat<S>(1.0) / (splat<S>(1.0) + c)) * v;
    diagonal = splat<S>(1.0) - dot(v, w);
  }
};
template <typename S>
WCH_INLINE M33<S> rodrigues(const V3<S>& from, const V3<S>& to, const S& c) {
  const RodriguesTerms<S> t(from, to, c);
  const V3<S>& v = t.v;
  const V3<S>& w = t.w;
  M33<S> r;
  r.m[0][0] = t.diagonal + v.x * w.x, r.m[0][1] = v.x * w.y - v.z, r.m[0][2] = v.x * w.z + v.y;
  r.m[1][0] = v.y * w.x + v.z, r.m[1][1] = t.diagonal + v.y * w.y, r.m[1][2] = v.y * w.z - v.x;
  r.m[2][0] = v.z * w.x - v.y, r.m[2][1] = v.z * w.y + v.x, r.m[2][2] = t.diagonal + v.z * w.z;
  return r;
}
/// rodrigues(from, to, c) x without the matrix: diagonal x + v x x + (w . x) v. The frame
/// transport turns one vector per edge this way (a matrix and a matrix product cost twice as
/// much, on every edge of every strand on every substep).
template <typename S>
WCH_INLINE V3<S> rodriguesApplied(const V3<S>& from, const V3<S>& to, const S& c, const V3<S>& x) {
  const RodriguesTerms<S> t(from, to, c);
  return t.diagonal * x + cross(t.v, x) + dot(t.w, x) * t.v;
}

/// Below this cosine two unit vectors count as opposite for minimalRotation.
constexpr double kOppositeCosine = -0.99;

/// minimalRotation's rare branch, for nearly opposite unit vectors: a half turn about an axis
/// perpendicular to a, then the small minimal rotation from -a to b (exact, where 1 / (1 + c)
/// alone would lose all precision).
WCH_INLINE Mat3 minimalRotationNearlyOpposite(const Vec3& a, const Vec3& b) {
  const Vec3 n = anyPerpendicular(a);
  const Mat3 half_turn = 2.0 * n * n.transpose() - Mat3::Identity();
  return toEigen(rodrigues(toV3(-a), toV3(b), -a.dot(b))) * half_turn;
}

/// The minimal rotation taking unit vector a onto unit vector b (rodrigues), and a rotation by
/// pi about a perpendicular axis composed with a small one where b is nearly opposite to a.
template <typename S>
WCH_INLINE M33<S> minimalRotation(const V3<S>& a, const V3<S>& b) {
  const S c = dot(a, b);
  M33<S> r = rodrigues(a, b, c);
  patchLanes(c < splat<S>(kOppositeCosine),
             [&](int l) { setLane(&r, l, minimalRotationNearlyOpposite(lane(a, l), lane(b, l))); });
  return r;
}
WCH_INLINE Mat3 minimalRotation(const Vec3& a, const Vec3& b) {
  return toEigen(minimalRotation(toV3(a), toV3(b)));
}
/// minimalRotation(a, b) x, the matrix not formed (rodriguesApplied), the same rare branch.
template <typename S>
WCH_INLINE V3<S> minimalRotationApplied(const V3<S>& a, const V3<S>& b, const V3<S>& x) {
  const S c = dot(a, b);
  V3<S> r = rodriguesApplied(a, b, c, x);
  patchLanes(c < splat<S>(kOppositeCosine), [&](int l) {
    setLane(&r, l, Vec3(minimalRotationNearlyOpposite(lane(a, l), lane(b, l)) * lane(x, l)));
  });
  return r;
}

/// An edge's frame from its tangent t and normal n (both unit, perpendicular): the columns t, n
/// and the binormal t x n (right-handed).
template <typename S>
WCH_INLINE M33<S> frameOf(const V3<S>& t, const V3<S>& n) {
  const V3<S> b = cross(t, n);
  M33<S> f;
  f.m[0][0] = t.x, f.m[1][0] = t.y, f.m[2][0] = t.z;
  f.m[0][1] = n.x, f.m[1][1] = n.y, f.m[2][1] = n.z;
  f.m[0][2] = b.x, f.m[1][2] = b.y, f.m[2][2] = b.z;
  return f;
}

/// A right-handed orthonormal frame whose first column is `tangent` normalised and whose second
/// column is `hint` made perpendicular to it (any perpendicular when hint is parallel to it).
template <typename S>
WCH_INLINE M33<S> frameFromTangent(const V3<S>& tangent, const V3<S>& hint) {
  const V3<S> t = tangent / vsqrt(dot(tangent, tangent));
  V3<S> n = hint - dot(hint, t) * t;
  const S n_len = vsqrt(dot(n, n));
  n = n / n_len;
  patchLanes(n_len < splat<S>(1e-9), [&](int l) { setLane(&n, l, anyPerpendicular(lane(t, l))); });
  return frameOf(t, n);
}
WCH_INLINE Mat3 frameFromTangent(const Vec3& tangent, const Vec3& hint) {
  return toEigen(frameFromTangent(toV3(tangent), toV3(hint)));
}

/// frameOf(t, n) x: x's coordinates in the frame back into the world (a bend target F e^loc).
template <typename S>
WCH_INLINE V3<S> inFrame(const V3<S>& t, const V3<S>& n, const V3<S>& x) {
  return x.x * t + x.y * n + x.z * cross(t, n);
}

/// One edge of the parallel transport of the root frame along the smoothed differences d
/// (physics.md §2.4): frame_i = R_min(T_{i-1} -> T_i) frame_{i-1}, T_i = d_{i-1} / |d_{i-1}|, so
/// edge e_i gets a frame that depends on upstream geometry only. A frame is carried as its
/// tangent and normal (frameOf): the rotation takes the tangent onto T_i exactly, so only the
/// normal is turned. Where |d_{i-1}| vanishes (a strand folding back on itself) the frame is
/// kept. On entry *tangent and *normal are edge i-1's; on return edge i's.
template <typename S>
WCH_INLINE void transportFrame(const V3<S>& d_before, int i, V3<S>* tangent, V3<S>* normal) {
  const S len = vsqrt(dot(d_before, d_before));
  const auto keep = len < splat<S>(kDirectionEpsilon);
  const V3<S> t = (splat<S>(1.0) / len) * d_before;
  V3<S> n = minimalRotationApplied(*tangent, t, *normal);
  if ((i & 15) == 0) {
    // Round-off drift is removed every 16 edges; in double it stays below 1e-14 in between.
    n = n - dot(n, t) * t;
    n = (splat<S>(1.0) / vsqrt(dot(n, n))) * n;
  }
  *normal = select(keep, *normal, n);
  *tangent = select(keep, *tangent, t);
}

/// The frames of all `edge_count` edges: frames[0] = root, then transportFrame edge by edge.
WCH_INLINE void transportFrames(const Mat3& root, const Vec3* d, int edge_count, Mat3* frames) {
  if (edge_count < 1) return;
  frames[0] = root;
  V3<double> tangent = toV3(Vec3(root.col(0))), normal = toV3(Vec3(root.col(1)));
  for (int i = 1; i < edge_count; ++i) {
    transportFrame(toV3(d[i - 1]), i, &tangent, &normal);
    frames[i] = toEigen(frameOf(tangent, normal));
  }
}

}  // namespace wet_curly_hair
