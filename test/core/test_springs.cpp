// The spring kernels of eqs. (1), (4), (5) and the strain limiting of Iben/Selle (docs/physics.md
// §2).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/springs.h"

using namespace wet_curly_hair;

TEST(Springs, StretchForceIsHookeAlongTheEdge) {
  const Vec3 e(0.0, 0.0, 0.011);
  const Vec3 f = stretchForce(e, 0.010, 500.0);
  // k_s (|e| - |e0|) e^ = 500 * 0.001 along +z; applied +f to the root side: pulls it toward the
  // tip.
  EXPECT_NEAR(f.z(), 0.5, 1e-12);
  EXPECT_NEAR(f.head<2>().norm(), 0.0, 1e-15);
  EXPECT_EQ(stretchForce(Vec3(0.01, 0, 0), 0.01, 500.0), Vec3::Zero());
  EXPECT_EQ(stretchForce(Vec3::Zero(), 0.01, 500.0), Vec3::Zero());  // degenerate: no NaN
}

TEST(Springs, StretchForceIsTheEnergyGradient) {
  const Vec3 e(0.003, -0.004, 0.012);
  const double h = 1e-7;
  for (int k = 0; k < 3; ++k) {
    Vec3 ep = e, em = e;
    ep[k] += h;
    em[k] -= h;
    const double grad = (stretchEnergy(ep, 0.01, 300.0) - stretchEnergy(em, 0.01, 300.0)) / (2 * h);
    // dE/de = f (the force on the tip-side particle is -f = -dE/dx_tip).
    EXPECT_NEAR(stretchForce(e, 0.01, 300.0)[k], grad, 1e-6);
  }
}

TEST(Springs, StretchDampingActsOnTheAxialRelativeVelocityOnly) {
  const Vec3 e(0, 0, 0.01);
  EXPECT_EQ(stretchDampingForce(e, Vec3(1, 2, 0), 0.1), Vec3::Zero());
  EXPECT_NEAR(stretchDampingForce(e, Vec3(1, 2, 3), 0.1).z(), 0.3, 1e-15);
}

TEST(Springs, BendForceDrivesTheEdgeToItsTarget) {
  const Vec3 e(0.01, 0, 0), t(0, 0.01, 0);
  const Vec3 f = bendForce(e, t, 50.0);
  EXPECT_LT((f - 50.0 * (e - t)).norm(), 1e-15);
  EXPECT_EQ(bendForce(t, t, 50.0), Vec3::Zero());
  // Tip-side particle gets -f = k_b (t - e): toward the target.
  EXPECT_GT((-f).dot(t - e), 0.0);
}

TEST(Springs, BendDampingIsPerpendicular) {
  const Vec3 e(0, 0, 0.01);
  const Vec3 f = bendDampingForce(e, Vec3(1, 2, 3), 0.2);
  EXPECT_NEAR(f.z(), 0.0, 1e-15);
  EXPECT_NEAR(f.x(), 0.2, 1e-15);
  EXPECT_NEAR(f.y(), 0.4, 1e-15);
}

TEST(Springs, CoreForceIsGuardedAndHooke) {
  EXPECT_EQ(coreForce(Vec3::Zero(), 0.01, 50.0), Vec3::Zero());
  EXPECT_NEAR(coreForce(Vec3(0, 0.012, 0), 0.01, 50.0).y(), 0.1, 1e-12);
  EXPECT_NEAR(coreDampingForce(Vec3(0, 0.012, 0), Vec3(5, 2, 0), 0.1).y(), 0.2, 1e-15);
  EXPECT_EQ(coreDampingForce(Vec3::Zero(), Vec3(5, 2, 0), 0.1), Vec3::Zero());
}

TEST(Springs, AxialVelocityClampLimitsBothWays) {
  const Vec3 e(0, 0, 0.01);
  const Vec3 vr(0.1, 0, 0);
  Vec3 v = clampAxialRelativeVelocity(e, vr, vr + Vec3(0.3, 0, 2.0), 0.5);
  EXPECT_NEAR((v - vr).z(), 0.5, 1e-15);
  EXPECT_NEAR((v - vr).x(), 0.3, 1e-15);  // perpendicular part untouched
  v = clampAxialRelativeVelocity(e, vr, vr + Vec3(0, 0, -2.0), 0.5);
  EXPECT_NEAR((v - vr).z(), -0.5, 1e-15);
  const Vec3 inside = vr + Vec3(0, 0.1, 0.2);
  EXPECT_EQ(clampAxialRelativeVelocity(e, vr, inside, 0.5), inside);
}

TEST(Springs, StrainLimitPullsTheTipSideBackAlongTheEdge) {
  const Vec3 a(0, 0, 0), b(0.03, 0.04, 0);  // length 0.05
  const Vec3 disp = limitEdgeLength(a, b, 0.04);
  EXPECT_NEAR((b + disp - a).norm(), 0.04, 1e-15);
  EXPECT_LT((b + disp - a).normalized().cross(b.normalized()).norm(), 1e-15);
  EXPECT_EQ(limitEdgeLength(a, b, 0.06), Vec3::Zero());
}

TEST(Springs, StrainLimitsSquaredLengthShortcutChangesNoBit) {
  // The Eigen form lets edges through on their squared length; against the lane form, which
  // always takes the square root, edges from far inside the limit to 1e-6 past it, densest
  // within 1e-11 of it (the shortcut's margin is 1e-12), must move the same to the bit.
  const double limit = 0.0084;
  const Vec3 root(0.013, -0.27, 0.051);
  int moved = 0, checked = 0;
  for (int k = -400; k <= 400; ++k) {
    const double rel = k < -200 ? 1e-3 * (k + 200) : k > 200 ? 5e-9 * (k - 200) : 5e-14 * k;
    const Vec3 dir = Vec3(0.3 + 1e-3 * k, -0.8, 0.52).normalized();
    const Vec3 tip = root + (limit * (1.0 + rel)) * dir;
    const Vec3 shortcut = limitEdgeLength(root, tip, limit);
    const Vec3 full = toEigen(limitEdgeLength(toV3(root), toV3(tip), limit));
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(std::signbit(shortcut[c]), std::signbit(full[c])) << "rel " << rel;
    EXPECT_EQ(shortcut, full) << "rel " << rel;
    moved += full != Vec3::Zero();
    ++checked;
  }
  EXPECT_GT(moved, 150);  // the edges past the limit were moved, by both
  EXPECT_EQ(checked, 801);
}

namespace {

/// Central finite-difference Jacobian d f / d x (columns = partials) of a Vec3 -> Vec3 map.
template <typename F>
Mat3 finiteDifferenceJacobian(F&& f, const Vec3& x, double step) {
  Mat3 j;
  for (int k = 0; k < 3; ++k) {
    Vec3 xp = x, xm = x;
    xp[k] += step;
    xm[k] -= step;
    j.col(k) = (f(xp) - f(xm)) / (2.0 * step);
  }
  return j;
}

Mat3 toMat(const M33<double>& m) { return toEigen(m); }

}  // namespace

TEST(Springs, AxialSpringJacobianMatchesFiniteDifferencesUnderTension) {
  // Stretched edges (|e| > L), generic, along an axis and nearly straight: the linearisation the
  // implicit integrators solve with is the exact derivative of the stretch force.
  for (const Vec3& e : {Vec3(0.003, -0.004, 0.012), Vec3(0.0, 0.0, 0.0125), Vec3(1e-9, 0, 0.011)}) {
    const AxialJacobian<double> j = axialSpringJacobian(toV3(e), 0.01, 300.0, kDirectionEpsilon);
    const Mat3 analytic = toMat(isotropicPlusDyads(j.isotropic, j.axial, j.u, 0.0, j.u));
    const Mat3 fd = finiteDifferenceJacobian(
        [](const Vec3& x) { return stretchForce(x, 0.01, 300.0); }, e, 1e-8);
    EXPECT_LT((analytic - fd).norm(), 1e-5 * analytic.norm()) << e.transpose();
  }
}

TEST(Springs, AxialSpringJacobianDropsOnlyTheNegativeTransverseTermUnderCompression) {
  // Compressed (|e| < L): the exact transverse stiffness k (1 - L/|e|) is negative; the solver
  // keeps the axial part and clamps the transverse one at zero (positive definite system).
  const Vec3 e(0.002, 0.003, 0.006);  // |e| = 0.007 < 0.01
  const AxialJacobian<double> j = axialSpringJacobian(toV3(e), 0.01, 300.0, kDirectionEpsilon);
  const Mat3 fd =
      finiteDifferenceJacobian([](const Vec3& x) { return stretchForce(x, 0.01, 300.0); }, e, 1e-8);
  const Vec3 u = e.normalized();
  const Mat3 transverse = Mat3::Identity() - u * u.transpose();
  const Mat3 exact_axial = fd - 300.0 * (1.0 - 0.01 / e.norm()) * transverse;
  EXPECT_EQ(j.isotropic, 0.0);
  EXPECT_LT((toMat(isotropicPlusDyads(0.0, j.axial, j.u, 0.0, j.u)) - exact_axial).norm(), 1e-4);
}

TEST(Springs, AxialSpringJacobianIsZeroOnADegenerateEdge) {
  const AxialJacobian<double> j =
      axialSpringJacobian(toV3(Vec3::Zero()), 0.01, 300.0, kDirectionEpsilon);
  EXPECT_EQ(j.isotropic, 0.0);
  EXPECT_EQ(j.axial, 0.0);
  EXPECT_EQ(toEigen(j.u), Vec3::Zero());
}

TEST(Springs, ImplicitEdgeBlockIsThetaHTimesDampingPlusThetaHTimesStiffness) {
  // G = theta h (C + theta h J): J the finite-difference Jacobian of stretch + bend + curl-spring
  // forces with respect to the edge (frames held), plus the core's share (coreLocalGain) of its
  // own Jacobian along b; C that of the damping forces with respect to the relative velocity.
  // Generic edges, a straight one along the core direction, and an edge antiparallel to b.
  EdgeImplicitParams<double> q;
  q.k_s = 500, q.k_b = 10, q.k_c = 10, q.c_s = 0.11, q.c_b = 0.063, q.c_c = 0.035;
  q.theta_h = 0.6 * 2e-3;
  const double gain = coreLocalGain(0.095), curl_k = 25.0 * 0.7;
  const Vec3 t(0.002, 0.001, 0.0075), nu(0.01, -0.02, 0.03), omega(0.3, -0.2, 0.1);
  struct Case {
    Vec3 e, b;
  };
  for (const Case& c : {Case{Vec3(0.003, -0.004, 0.0085), Vec3(0.001, 0.002, 0.0082)},
                        Case{Vec3(0, 0, 0.0084), Vec3(0, 0, 0.0081)},
                        Case{Vec3(0.001, 0, 0.0083), Vec3(-0.001, 0, -0.0085)}}) {
    const Vec3 dv(0.05, -0.01, 0.02);
    const EdgeImplicitTerms<double> terms =
        edgeImplicitTerms(q, toV3(c.e), axialLength(toV3(c.e)), toV3(dv), 0.008, toV3(c.b),
                          axialLength(toV3(c.b)), 0.0080, toV3(nu), gain, curl_k, toV3(omega));
    auto elastic = [&](const Vec3& e) {
      return Vec3(stretchForce(e, 0.008, q.k_s) + bendForce(e, t, q.k_b) + curl_k * e);
    };
    const Mat3 j_core = finiteDifferenceJacobian(
        [&](const Vec3& b) { return coreForce(b, 0.0080, q.k_c); }, c.b, 1e-9);
    const Mat3 j = finiteDifferenceJacobian(elastic, c.e, 1e-9) + gain * j_core;
    auto damping = [&](const Vec3& v) {
      return Vec3(stretchDampingForce(c.e, v, q.c_s) + bendDampingForce(c.e, v, q.c_b));
    };
    const Vec3 w = c.b.normalized();
    const Mat3 damp =
        finiteDifferenceJacobian(damping, dv, 1e-6) + q.c_c * gain * w * w.transpose();
    const Mat3 expected = q.theta_h * (damp + q.theta_h * j);
    EXPECT_LT((toMat(terms.block) - expected).norm(), 1e-6 * expected.norm()) << c.e.transpose();
    // The explicit remainder: the co-rotation part of the bend damping and the core damping
    // beyond the share the block carries.
    const Vec3 remainder =
        -q.c_b * omega.cross(c.e) + coreDampingForce(c.b, nu, q.c_c) - q.c_c * gain * w.dot(dv) * w;
    EXPECT_LT((toEigen(terms.explicit_force) - remainder).norm(), 1e-15);
  }
}

TEST(Springs, CoreLocalGainLiesBetweenTheFiltersLocalAndSmoothModeDerivatives) {
  // b_i = zeta(P, alpha_c)_i (eq. 2): moving p_{i+1} alone changes b_i by beta^2 (the local
  // derivative d b_i / d e_i); stretching every edge alike changes it by exactly the stretch
  // (unit DC gain). The block-tridiagonal solve can hold only a local term; the solver's share
  // lies between the two.
  const double beta = smoothingBeta(0.008, 10 * 0.008);
  std::vector<Vec3> p(12);
  for (int i = 0; i < 12; ++i)
    p[i] = Vec3(0.01 * std::cos(0.7 * i), 0.01 * std::sin(0.7 * i), 0.003 * i);
  auto diff = [&](const std::vector<Vec3>& q, int i) {
    std::vector<Vec3> d(q.size() - 1);
    smoothDifferences(q.data(), static_cast<int>(q.size()), beta, d.data());
    return d[i];
  };
  const int i = 7;
  const double step = 1e-7;
  std::vector<Vec3> moved = p;
  for (int k = i + 1; k < 12; ++k)
    moved[k].x() += step;  // e_i grows by step along x, no other edge
  const double local = (diff(moved, i) - diff(p, i)).x() / step;
  EXPECT_NEAR(local, beta * beta, 1e-6);
  std::vector<Vec3> scaled = p;
  for (int k = 0; k < 12; ++k) scaled[k] = p[k] + step * k * Vec3::UnitX();  // every edge alike
  const double smooth = (diff(scaled, i) - diff(p, i)).x() / step;
  EXPECT_NEAR(smooth, 1.0, 1e-6);
  // Strictly between: beyond ten times the finite-difference tolerance of either limit, so that
  // neither limit itself passes.
  const double kApart = 10 * 1e-6;
  EXPECT_GT(coreLocalGain(beta), local + kApart);
  EXPECT_LT(coreLocalGain(beta), smooth - kApart);
}
