// The three curly-hair springs of Iben et al. 2013, eqs. (1), (4), (5) of Kim 2023, as stateless
// kernels over one segment. Each returns the segment force f; the caller applies the segment
// convention of method.md §0 / A1: F_i += f, F_{i+1} -= f (restoring for a stretched edge).
#pragma once

#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Eq. (1), elastic part: k_s (|e| - |e0|) e^. Zero for a degenerate edge.
inline Vec3 stretchForce(const Vec3& edge, double rest_length, double k_s) {
  const double len = edge.norm();
  if (len < kDirectionEpsilon) return Vec3::Zero();
  return (k_s * (len - rest_length) / len) * edge;
}

/// Eq. (1), damping part: c_s (dv . e^) e^, with dv = v_{i+1} - v_i.
inline Vec3 stretchDampingForce(const Vec3& edge, const Vec3& dv, double c_s) {
  const double len2 = edge.squaredNorm();
  if (len2 < kDirectionEpsilon * kDirectionEpsilon) return Vec3::Zero();
  return (c_s * dv.dot(edge) / len2) * edge;
}

/// Eq. (4), elastic part: k_b (e_i - t_i), with the target t_i = F_i e_i^loc (method.md §2.5).
inline Vec3 bendForce(const Vec3& edge, const Vec3& target, double k_b) {
  return k_b * (edge - target);
}

/// Eq. (4), damping part: c_b (dv - (dv . e^) e^), the relative velocity perpendicular to the edge.
inline Vec3 bendDampingForce(const Vec3& edge, const Vec3& dv, double c_b) {
  const double len2 = edge.squaredNorm();
  if (len2 < kDirectionEpsilon * kDirectionEpsilon) return c_b * dv;
  return c_b * (dv - (dv.dot(edge) / len2) * edge);
}

/// Eq. (5), elastic part: k_c (|b| - |b0|) b^, b the i-th difference of the alpha_c-smoothed curve.
/// Guarded: zero when |b| vanishes (flat curls, folded strands; method.md §10.3).
inline Vec3 coreForce(const Vec3& b, double rest_length, double k_c) {
  const double len = b.norm();
  if (len < 1e-9) return Vec3::Zero();
  return (k_c * (len - rest_length) / len) * b;
}

/// Eq. (5), damping part: c_c (nu . b^) b^, nu the smoothed relative velocity zeta(V, alpha_c)_i (A5).
inline Vec3 coreDampingForce(const Vec3& b, const Vec3& nu, double c_c) {
  const double len2 = b.squaredNorm();
  if (len2 < 1e-18) return Vec3::Zero();
  return (c_c * nu.dot(b) / len2) * b;
}

/// Energy of the stretch spring, 1/2 k_s (|e| - |e0|)^2 (J).
inline double stretchEnergy(const Vec3& edge, double rest_length, double k_s) {
  const double x = edge.norm() - rest_length;
  return 0.5 * k_s * x * x;
}

/// Energy of the bending spring with frames held fixed, 1/2 k_b |e - t|^2 (J).
inline double bendEnergy(const Vec3& edge, const Vec3& target, double k_b) {
  return 0.5 * k_b * (edge - target).squaredNorm();
}

/// Energy of the core spring, 1/2 k_c (|b| - |b0|)^2 (J).
inline double coreEnergy(const Vec3& b, double rest_length, double k_c) {
  const double x = b.norm() - rest_length;
  return 0.5 * k_c * x * x;
}

/// Iben §2.2a, inside the damping pass: clamp the axial relative velocity of edge i so that the
/// edge length changes by at most `max_axial_speed` (m/s) in either direction. Returns the new
/// tip-side velocity v_{i+1} (the root side is already final: the sweep runs root -> tip).
inline Vec3 clampAxialRelativeVelocity(const Vec3& edge, const Vec3& v_root_side,
                                       const Vec3& v_tip_side, double max_axial_speed) {
  const double len = edge.norm();
  if (len < kDirectionEpsilon) return v_tip_side;
  const Vec3 e = edge / len;
  const Vec3 dv = v_tip_side - v_root_side;
  const double a = dv.dot(e);
  if (a > max_axial_speed) return v_tip_side - (a - max_axial_speed) * e;
  if (a < -max_axial_speed) return v_tip_side - (a + max_axial_speed) * e;
  return v_tip_side;
}

/// Selle et al. 2008 biased strain limit (method.md §2.2b, §3) for one edge, after the position
/// update: if |p_tip - p_root| exceeds max_length the tip-side particle is pulled back along the
/// edge. Returns the displacement applied to the tip-side particle (zero when within the limit);
/// the caller adds displacement / dt to its velocity so positions and velocities stay consistent.
inline Vec3 limitEdgeLength(const Vec3& p_root_side, const Vec3& p_tip_side, double max_length) {
  const Vec3 e = p_tip_side - p_root_side;
  const double len = e.norm();
  if (len <= max_length || len < kDirectionEpsilon) return Vec3::Zero();
  return e * (max_length / len) - e;
}

}  // namespace wet_curly_hair
