// The spring kernels of eqs. (1), (4), (5) and the strain limiting of Iben/Selle (docs/physics.md §2).
#include <gtest/gtest.h>

#include "wet_curly_hair/core/springs.h"

using namespace wet_curly_hair;

TEST(Springs, StretchForceIsHookeAlongTheEdge) {
  const Vec3 e(0.0, 0.0, 0.011);
  const Vec3 f = stretchForce(e, 0.010, 500.0);
  // k_s (|e| - |e0|) e^ = 500 * 0.001 along +z; applied +f to the root side: pulls it toward the tip.
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

TEST(Springs, InternalForcesConserveMomentum) {
  // The segment convention F_i += f, F_{i+1} -= f: the forces of any segment sum to zero.
  const Vec3 e(0.002, 0.009, -0.003), t(0.004, 0.008, 0.0), dv(0.3, -0.1, 0.2);
  const Vec3 f = stretchForce(e, 0.008, 500) + bendForce(e, t, 50) + stretchDampingForce(e, dv, 0.1) +
                 bendDampingForce(e, dv, 0.1);
  const Vec3 fi = f, fj = -f;
  EXPECT_LT((fi + fj).norm(), 1e-18);
}
