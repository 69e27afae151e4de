// The three curly-hair springs of Iben et al. 2013, eqs. (1), (4), (5) of Kim 2023, their
// damping terms, the velocity clamp and the strain limit, and the Jacobian the implicit
// integrators solve with, as stateless kernels over one segment. Each is written once, generic
// over the lane scalar S (lane_math.h): the solver calls them on one strand (S = double) and on
// blocks of strands in SIMD lanes; the Eigen overloads at the end are the same kernels for
// callers that speak Eigen. Each force kernel returns the segment force f; the caller applies
// the segment convention of docs/physics.md §0 / A1: F_i += f, F_{i+1} -= f (restoring for a
// stretched edge).
#pragma once

#include <algorithm>

#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/lane_math.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Below this length a smoothed difference b has no direction (the core spring is off).
constexpr double kCoreDirectionEpsilon = 1e-9;

/// The length of an axial spring's vector x and its reciprocal. Formed once per edge and substep
/// for the stretch and core springs (elasticForces) and reused by their Jacobians
/// (edgeImplicitTerms), which would otherwise take the same square root and division again.
template <typename S>
struct AxialLength {
  S len;
  S inv_len;  ///< 1 / len (infinite for x = 0, where every user selects zero)
};

template <typename S>
WCH_INLINE AxialLength<S> axialLength(const V3<S>& x) {
  AxialLength<S> l;
  l.len = vsqrt(dot(x, x));
  l.inv_len = splat<S>(1.0) / l.len;
  return l;
}

/// The axial spring shared by eqs. (1) and (5): k (|x| - L) x^, zero where |x| is below
/// `degenerate_length` (no direction); `length` is axialLength(x).
template <typename S>
WCH_INLINE V3<S> axialSpringForce(const V3<S>& x, const AxialLength<S>& length,
                                  const S& rest_length, const S& k, double degenerate_length) {
  return select(length.len < splat<S>(degenerate_length), zero3<S>(),
                (k * (length.len - rest_length) * length.inv_len) * x);
}

/// The axial damper shared by eqs. (1) and (5): c (w . x^) x^ = c (w . x) x / |x|^2, given
/// inv_len2 = 1 / |x|^2; zero where |x| is below `degenerate_length`.
template <typename S>
WCH_INLINE V3<S> axialDampingForce(const V3<S>& x, const V3<S>& w, const S& c, const S& inv_len2,
                                   double degenerate_length) {
  return select(dot(x, x) < splat<S>(degenerate_length * degenerate_length), zero3<S>(),
                (c * dot(w, x) * inv_len2) * x);
}

template <typename S>
WCH_INLINE V3<S> axialDampingForce(const V3<S>& x, const V3<S>& w, const S& c,
                                   double degenerate_length) {
  return axialDampingForce(x, w, c, splat<S>(1.0) / dot(x, x), degenerate_length);
}

/// Eq. (1), elastic part: k_s (|e| - |e0|) e^. Zero for a degenerate edge. `length` is
/// axialLength(edge).
template <typename S>
WCH_INLINE V3<S> stretchForce(const V3<S>& edge, const AxialLength<S>& length, const S& rest_length,
                              const S& k_s) {
  return axialSpringForce(edge, length, rest_length, k_s, kDirectionEpsilon);
}

template <typename S>
WCH_INLINE V3<S> stretchForce(const V3<S>& edge, const S& rest_length, const S& k_s) {
  return stretchForce(edge, axialLength(edge), rest_length, k_s);
}

/// Eq. (1), damping part: c_s (dv . e^) e^, with dv = v_{i+1} - v_i.
template <typename S>
WCH_INLINE V3<S> stretchDampingForce(const V3<S>& edge, const V3<S>& dv, const S& c_s) {
  return axialDampingForce(edge, dv, c_s, kDirectionEpsilon);
}

/// Eq. (4), elastic part: k_b (e_i - t_i), with the target t_i = F_i e_i^loc (physics.md §2.5).
template <typename S>
WCH_INLINE V3<S> bendForce(const V3<S>& edge, const V3<S>& target, const S& k_b) {
  return k_b * (edge - target);
}

/// Eq. (4), damping part: c_b (dv - (dv . e^) e^), the relative velocity across the edge.
template <typename S>
WCH_INLINE V3<S> bendDampingForce(const V3<S>& edge, const V3<S>& dv, const S& c_b) {
  const S len2 = dot(edge, edge);
  return select(len2 < splat<S>(kDirectionEpsilon * kDirectionEpsilon), c_b * dv,
                c_b * (dv - (dot(dv, edge) / len2) * edge));
}

/// Eq. (5), elastic part: k_c (|b| - |b0|) b^, b the i-th difference of the alpha_c-smoothed
/// curve. Zero when |b| vanishes (flat curls, folded strands; physics.md §10.3). `length` is
/// axialLength(b).
template <typename S>
WCH_INLINE V3<S> coreForce(const V3<S>& b, const AxialLength<S>& length, const S& rest_length,
                           const S& k_c) {
  return axialSpringForce(b, length, rest_length, k_c, kCoreDirectionEpsilon);
}

template <typename S>
WCH_INLINE V3<S> coreForce(const V3<S>& b, const S& rest_length, const S& k_c) {
  return coreForce(b, axialLength(b), rest_length, k_c);
}

/// Eq. (5), damping part: c_c (nu . b^) b^, nu the smoothed relative velocity zeta(V, alpha_c)_i
/// (A5). `length` is axialLength(b).
template <typename S>
WCH_INLINE V3<S> coreDampingForce(const V3<S>& b, const AxialLength<S>& length, const V3<S>& nu,
                                  const S& c_c) {
  return axialDampingForce(b, nu, c_c, length.inv_len * length.inv_len, kCoreDirectionEpsilon);
}

template <typename S>
WCH_INLINE V3<S> coreDampingForce(const V3<S>& b, const V3<S>& nu, const S& c_c) {
  return axialDampingForce(b, nu, c_c, kCoreDirectionEpsilon);
}

/// Iben §2.2a, inside the damping pass: clamps the axial relative velocity of an edge so that
/// its length changes by at most `max_axial_speed` (m/s) either way. Returns the new tip-side
/// velocity (the root side is already final: the sweep runs root -> tip).
template <typename S>
WCH_INLINE V3<S> clampAxialRelativeVelocity(const V3<S>& edge, const V3<S>& v_root_side,
                                            const V3<S>& v_tip_side, const S& max_axial_speed) {
  const S len = vsqrt(dot(edge, edge));
  const V3<S> e = edge / len;
  const S a = dot(v_tip_side - v_root_side, e);
  const auto short_edge = len < splat<S>(kDirectionEpsilon);
  const auto above = !short_edge && (a > max_axial_speed);
  const auto below = !short_edge && !above && (a < -max_axial_speed);
  const V3<S> r = select(above, v_tip_side - (a - max_axial_speed) * e, v_tip_side);
  return select(below, v_tip_side - (a + max_axial_speed) * e, r);
}

/// Selle et al. 2008 biased strain limit (physics.md §2.2b, §3) for one edge, two-sided: if
/// |p_tip - p_root| lies outside [min_length, max_length], the tip-side particle is moved along
/// the edge to the nearer bound. Returns the displacement of the tip-side particle (zero within
/// the limits, and for an edge too short to have a direction).
template <typename S>
WCH_INLINE V3<S> clampEdgeLength(const V3<S>& p_root_side, const V3<S>& p_tip_side,
                                 const S& min_length, const S& max_length) {
  const V3<S> e = p_tip_side - p_root_side;
  const S len = vsqrt(dot(e, e));
  const auto within =
      (len <= max_length && len >= min_length) || (len < splat<S>(kDirectionEpsilon));
  return select(within, zero3<S>(), (vmin(vmax(len, min_length), max_length) / len) * e - e);
}

/// The strain limit of the simulated strands: stretching only (clampEdgeLength without a lower
/// bound).
template <typename S>
WCH_INLINE V3<S> limitEdgeLength(const V3<S>& p_root_side, const V3<S>& p_tip_side,
                                 const S& max_length) {
  return clampEdgeLength(p_root_side, p_tip_side, splat<S>(0.0), max_length);
}

/// The axial spring f = k (|e| - L) e / |e| (stretch, eq. 1; core, eq. 5 with b) linearised:
/// d f / d e = k [u u^T + (1 - L / |e|) (I - u u^T)], u = e / |e|, written as
/// isotropic I + axial u u^T. The transverse term is clamped at zero under compression so that
/// the implicit system stays positive definite (the usual definiteness fix; the exact force is
/// still applied). All zero for a degenerate edge.
template <typename S>
struct AxialJacobian {
  V3<S> u;  ///< unit direction (zero when degenerate)
  S isotropic;
  S axial;  ///< added along u u^T
};
/// `length` is axialLength(e): the force's square root and reciprocal, shared.
template <typename S>
WCH_INLINE AxialJacobian<S> axialSpringJacobian(const V3<S>& e, const AxialLength<S>& length,
                                                const S& rest, const S& k,
                                                double degenerate_length) {
  const auto degenerate = length.len < splat<S>(degenerate_length);
  const S zero = splat<S>(0.0);
  AxialJacobian<S> j;
  j.u = select(degenerate, zero3<S>(), length.inv_len * e);
  j.isotropic = select(degenerate, zero, k * vmax(zero, splat<S>(1.0) - rest * length.inv_len));
  j.axial = select(degenerate, zero, k - j.isotropic);
  return j;
}

template <typename S>
WCH_INLINE AxialJacobian<S> axialSpringJacobian(const V3<S>& e, const S& rest, const S& k,
                                                double degenerate_length) {
  return axialSpringJacobian(e, axialLength(e), rest, k, degenerate_length);
}

/// What the implicit integrators need of one edge (physics.md §9.2, steps 4-5): the coupling
/// block G = theta h (C + theta h J) of the block-tridiagonal system, with J = d f_e / d e the
/// elastic Jacobian and C = d f_damp / d dv the damping one, and the explicit remainder of the
/// segment force that the block does not carry.
///  - stretch: k_s (axialSpringJacobian), c_s along the edge;
///  - bend: k_b I (frames held at the start of the substep), c_b across the edge; the
///    co-rotation part of the bend damping, -c_b omega x e, is constant in u: explicit;
///  - core: b_i depends on every edge up to i through the IIR filter; the block carries
///    core_local_gain times its axial Jacobian along b^ (and the same share of its damping),
///    the rest of the core damping stays explicit (see coreLocalGain);
///  - curl spring (A10): k_w sigma I.
template <typename S>
struct EdgeImplicitTerms {
  M33<S> block;          ///< G, added to the pivots of both particles and coupling them.
  V3<S> explicit_force;  ///< segment force applied explicitly (F_i += f, F_{i+1} -= f).
};
template <typename S>
struct EdgeImplicitParams {
  S k_s, k_b, k_c, c_s, c_b, c_c;  ///< stiffness (N/m) and damping (N s/m) of the edge's springs.
  S theta_h;                       ///< theta times the substep, s.
  bool core_damping = true;        ///< false when c_c is 0 on every lane (skips its terms).
};
/// e_length and b_length are axialLength(e) and axialLength(b), as the forces formed them.
template <typename S>
WCH_INLINE EdgeImplicitTerms<S> edgeImplicitTerms(
    const EdgeImplicitParams<S>& q, const V3<S>& e, const AxialLength<S>& e_length, const V3<S>& dv,
    const S& rest, const V3<S>& b, const AxialLength<S>& b_length, const S& core_rest,
    const V3<S>& nu, const S& core_local_gain, const S& curl_stiffness, const V3<S>& omega) {
  const AxialJacobian<S> stretch = axialSpringJacobian(e, e_length, rest, q.k_s, kDirectionEpsilon);
  const AxialJacobian<S> core =
      axialSpringJacobian(b, b_length, core_rest, q.k_c * core_local_gain, kDirectionEpsilon);
  const S th = q.theta_h;
  const S has_axis =
      select(dot(stretch.u, stretch.u) > splat<S>(0.0), splat<S>(1.0), splat<S>(0.0));
  const S alpha = th * (q.c_b + th * (stretch.isotropic + core.isotropic + q.k_b + curl_stiffness));
  const S beta = th * (has_axis * (q.c_s - q.c_b) + th * stretch.axial);
  const S gamma = th * (q.c_c * core_local_gain + th * core.axial);
  EdgeImplicitTerms<S> t;
  t.block = isotropicPlusDyads(alpha, beta, stretch.u, gamma, core.u);
  t.explicit_force = -q.c_b * cross(omega, e);
  if (q.core_damping)
    t.explicit_force += coreDampingForce(b, b_length, nu, q.c_c) -
                        (q.c_c * core_local_gain * dot(core.u, dv)) * core.u;
  return t;
}

/// The share of the core spring's Jacobian that the implicit block carries. The exact
/// d b_i / d e_j of the IIR filter (eq. 2) is beta^2 for j = i and a tail over j < i that sums
/// with it to 1 (unit DC gain): a block-tridiagonal system cannot hold the tail. (1 - beta)^2
/// sits between the local beta^2 and the smooth-mode 1; it is what the implicit integrators
/// were measured with (docs/performance.md), and test_springs checks both limits against
/// finite differences of the filter.
WCH_INLINE double coreLocalGain(double beta) { return (1.0 - beta) * (1.0 - beta); }

// ------------------------------------------------------------------ Eigen forms

WCH_INLINE Vec3 stretchForce(const Vec3& edge, double rest_length, double k_s) {
  return toEigen(stretchForce(toV3(edge), rest_length, k_s));
}
WCH_INLINE Vec3 stretchDampingForce(const Vec3& edge, const Vec3& dv, double c_s) {
  return toEigen(stretchDampingForce(toV3(edge), toV3(dv), c_s));
}
WCH_INLINE Vec3 bendForce(const Vec3& edge, const Vec3& target, double k_b) {
  return toEigen(bendForce(toV3(edge), toV3(target), k_b));
}
WCH_INLINE Vec3 bendDampingForce(const Vec3& edge, const Vec3& dv, double c_b) {
  return toEigen(bendDampingForce(toV3(edge), toV3(dv), c_b));
}
WCH_INLINE Vec3 coreForce(const Vec3& b, double rest_length, double k_c) {
  return toEigen(coreForce(toV3(b), rest_length, k_c));
}
WCH_INLINE Vec3 coreDampingForce(const Vec3& b, const Vec3& nu, double c_c) {
  return toEigen(coreDampingForce(toV3(b), toV3(nu), c_c));
}
WCH_INLINE Vec3 clampAxialRelativeVelocity(const Vec3& edge, const Vec3& v_root_side,
                                           const Vec3& v_tip_side, double max_axial_speed) {
  return toEigen(
      clampAxialRelativeVelocity(toV3(edge), toV3(v_root_side), toV3(v_tip_side), max_axial_speed));
}
/// The same, with the edges well within the limit (nearly all of them, at the float lanes'
/// scatter) let through on their squared length: no square root or division is waited on
/// for them. The margin of 1e-12 is far above the round-off of either squared length, so an
/// edge let through here is one the full form leaves unmoved too (zero, to the bit).
WCH_INLINE Vec3 limitEdgeLength(const Vec3& p_root_side, const Vec3& p_tip_side,
                                double max_length) {
  if ((p_tip_side - p_root_side).squaredNorm() < (1.0 - 1e-12) * (max_length * max_length))
    return Vec3::Zero();
  return toEigen(limitEdgeLength(toV3(p_root_side), toV3(p_tip_side), max_length));
}
WCH_INLINE Vec3 clampEdgeLength(const Vec3& p_root_side, const Vec3& p_tip_side, double min_length,
                                double max_length) {
  return toEigen(clampEdgeLength(toV3(p_root_side), toV3(p_tip_side), min_length, max_length));
}

/// Energy of the stretch spring, 1/2 k_s (|e| - |e0|)^2 (J).
WCH_INLINE double stretchEnergy(const Vec3& edge, double rest_length, double k_s) {
  const double x = edge.norm() - rest_length;
  return 0.5 * k_s * x * x;
}

/// Energy of the bending spring with frames held fixed, 1/2 k_b |e - t|^2 (J).
WCH_INLINE double bendEnergy(const Vec3& edge, const Vec3& target, double k_b) {
  return 0.5 * k_b * (edge - target).squaredNorm();
}

/// Energy of the core spring, 1/2 k_c (|b| - |b0|)^2 (J).
WCH_INLINE double coreEnergy(const Vec3& b, double rest_length, double k_c) {
  const double x = b.norm() - rest_length;
  return 0.5 * k_c * x * x;
}

}  // namespace wet_curly_hair
