// Stateless kernels of the wet model of Kim 2023: the helix of eq. (6), the alignment rotation of
// eqs. (7)-(8) (A6-A8), the curl force of eq. (9) (A10), the adhesion kernel of eq. (12) (A15),
// the stiffness factor of eq. (13) (A17), and the SPH kernels of the cohesion (docs/physics.md §7).
#pragma once

#include <algorithm>
#include <cmath>

#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/lane_math.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Eq. (6): helix point x = r cos t, y = r sin t, z = (pitch / 2 pi) t, about +z (pitch = rise
/// per turn, m). A9: t_k = k dt with dt chosen so the chord equals the strand's mean edge.
WCH_INLINE Vec3 helixPoint(double radius_m, double pitch_m, double t) {
  return Vec3(radius_m * std::cos(t), radius_m * std::sin(t), pitch_m / (2.0 * M_PI) * t);
}

/// Eqs. (7)-(8) with A6 (Psi^2 for the undefined 2P) and A7 (helix -> hair direction): the
/// rotation M with M h = p for unit vectors h (helix root-to-tip) and p (hair root-to-tip),
/// M = I + [g]_x + [g]_x^2 / (1 + c), g = h x p, c = h . p; a half turn about an axis
/// perpendicular to h when they are opposite (A8). Same formula as the frames' minimal rotation.
WCH_INLINE Mat3 helixToHairRotation(const Vec3& h_unit, const Vec3& p_unit) {
  return minimalRotation(h_unit, p_unit);
}

/// helixToHairRotation as a unit quaternion, for the time-constant filter that slerps M
/// (CurlConfig::rotation_time_constant_s): (1 + c, h x p) normalised is (cos(t/2), sin(t/2) n) of
/// the same minimal rotation by t about n; nearly opposite vectors take the matrix's half turn.
/// Its regular branch component by component, (1 + c, h x p) normalised into q = (w, x, y, z),
/// so that the curl filter's SIMD loop runs it on every lane; returns c = h . p (the branch holds
/// for c >= kOppositeCosine).
WCH_INLINE double helixToHairQuaternionRegular(double hx, double hy, double hz, double px,
                                               double py, double pz, double* q) {
  const double c = hx * px + hy * py + hz * pz;
  const double gx = hy * pz - hz * py, gy = hz * px - hx * pz, gz = hx * py - hy * px;
  const double s = 1.0 + c;
  const double inv_norm = 1.0 / std::sqrt(s * s + gx * gx + gy * gy + gz * gz);
  q[0] = s * inv_norm, q[1] = gx * inv_norm, q[2] = gy * inv_norm, q[3] = gz * inv_norm;
  return c;
}
WCH_INLINE Quat helixToHairQuaternion(const Vec3& h_unit, const Vec3& p_unit) {
  if (h_unit.dot(p_unit) < kOppositeCosine) return Quat(helixToHairRotation(h_unit, p_unit));
  double q[4];
  helixToHairQuaternionRegular(h_unit.x(), h_unit.y(), h_unit.z(), p_unit.x(), p_unit.y(),
                               p_unit.z(), q);
  return Quat(q[0], q[1], q[2], q[3]);
}

/// The paper's literal eq. (7) direction (A7): rotates the hair direction onto the helix
/// direction, M_literal p = h. Kept for the test that shows it is the transpose of the above.
WCH_INLINE Mat3 literalEq7Rotation(const Vec3& h_unit, const Vec3& p_unit) {
  return minimalRotation(p_unit, h_unit);
}

/// Eq. (9), the curl force on edge i as a couple (A10): the returned u is added to the tip-side
/// particle and subtracted from the root-side one; `weight` is w_h times the edge's saturation.
/// `spring` (restoring target-edge variant): u = w sigma (M h_e - e); literal: u = w sigma M h_e
/// (a constant field aligning the edge).
template <typename S>
WCH_INLINE V3<S> curlForce(const V3<S>& rotated_helix_edge, const V3<S>& edge, const S& weight,
                           bool spring) {
  return spring ? weight * (rotated_helix_edge - edge) : weight * rotated_helix_edge;
}
WCH_INLINE Vec3 curlForce(const Vec3& rotated_helix_edge, const Vec3& edge, double weight,
                          double saturation, bool spring) {
  return toEigen(curlForce(toV3(rotated_helix_edge), toV3(edge), weight * saturation, spring));
}

/// Eq. (12) with Akinci's 1/4 power and domain (A15): A(r) = 0.007 h^-3.25
/// (-4 r^2 / h + 6 r - 2 h)^(1/4) for h/2 < r <= h, else 0. `literal`: the paper's polynomial
/// without the power, same domain. Finite for every input; peaks at r = 3h/4.
/// `norm` is adhesionNorm(h), formed once by a caller that evaluates many r (a pow per particle
/// was 1.8 % of a one-thread step at 10,000 strands).
WCH_INLINE double adhesionNorm(double h) { return 0.007 / std::pow(h, 3.25); }
template <typename S>
WCH_INLINE S adhesionKernel(const S& r, double h, double norm, bool literal) {
  if (!(h > 0.0)) return splat<S>(0.0);
  const auto in_domain = (r > splat<S>(0.5 * h)) && (r <= splat<S>(h));
  const S poly =
      vmax(splat<S>(0.0), (splat<S>(-4.0 / h) * r + splat<S>(6.0)) * r - splat<S>(2.0 * h));
  const S k = splat<S>(norm);
  const S value = literal ? k * poly : k * vsqrt(vsqrt(poly));  // poly^(1/4)
  return select(in_domain, value, splat<S>(0.0));
}
template <typename S>
WCH_INLINE S adhesionKernel(const S& r, double h, bool literal) {
  return adhesionKernel(r, h, adhesionNorm(h), literal);
}
WCH_INLINE double adhesionKernel(double r, double h, bool literal) {
  return adhesionKernel<double>(r, h, literal);
}

/// Peak value of adhesionKernel, at r = 3h/4 where the polynomial equals h/4.
WCH_INLINE double adhesionKernelPeak(double h, bool literal) {
  return adhesionKernel(0.75 * h, h, literal);
}

/// Eq. (13) in the substep-independent form of A17: the velocity factor (xi zeta)^(h / h_ref),
/// zeta = sigma gamma0 + (1 - sigma) gamma1. Computed as exp(ratio * ln(...)) in double (§10.14).
WCH_INLINE double stiffnessFactor(double xi, double gamma0, double gamma1, double saturation,
                                  double substep_s, double reference_step_s) {
  const double zeta = saturation * gamma0 + (1.0 - saturation) * gamma1;
  return std::exp((substep_s / reference_step_s) * std::log(xi * zeta));
}

/// Eq. (13) applied: the velocity v scaled by `factor` (stiffnessFactor) relative to `carried`,
/// the velocity the particle would have moving rigidly with the head (StiffnessConfig::
/// relative_to_head; zero for the literal absolute form).
template <typename S>
WCH_INLINE V3<S> stiffenVelocity(const V3<S>& v, const S& factor, const V3<S>& carried) {
  return carried + factor * (v - carried);
}

/// Poly6 kernel shape (h^2 - r^2)^3 for r < h, without its normalisation (it cancels in the
/// Shepard weights of eq. (10), A11).
WCH_INLINE double poly6Shape(double r2, double h2) {
  if (r2 >= h2) return 0.0;
  const double x = h2 - r2;
  return x * x * x;
}

/// Eq. (10): the display offset p^w - p = lambda pull / W of a particle from its Shepard sums,
/// pull = sum_j w_j (p_j - p) over the other strands' particles and W = sum_j w_j (plus the
/// particle's own weight with include_self, A13).
WCH_INLINE Vec3 clumpOffset(const Vec3& pull, double weight, double tightness) {
  return (tightness / weight) * pull;
}

/// Akinci et al. 2013 cohesion kernel C(r) (docs/physics.md §7.2), support h.
WCH_INLINE double akinciCohesionKernel(double r, double h) {
  if (!(r > 0.0) || r > h) return 0.0;
  const double k = 32.0 / (M_PI * std::pow(h, 9));
  const double a = (h - r) * (h - r) * (h - r) * r * r * r;
  if (2.0 * r > h) return k * a;
  return k * (2.0 * a - std::pow(h, 6) / 64.0);
}

}  // namespace wet_curly_hair
