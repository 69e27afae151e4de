// The head's analytic colliders and the Bridson collision response (docs/physics.md §6).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "wet_curly_hair/core/head_collider.h"

using namespace wet_curly_hair;

TEST(HeadCollider, EllipsoidDistanceIsExactOnASphere) {
  EllipsoidShape s;
  s.radii_m = Vec3(0.1, 0.1, 0.1);
  s.center_m = Vec3(0.01, 0.02, 0.03);
  for (const Vec3& dir : {Vec3(1, 0, 0), Vec3(0.3, -0.5, 0.8).normalized()}) {
    for (double r : {0.02, 0.1, 0.13, 0.5}) {
      Vec3 n;
      const double d = ellipsoidDistance(s, s.center_m + r * dir, &n);
      EXPECT_NEAR(d, r - 0.1, 1e-12);
      EXPECT_LT((n - dir).norm(), 1e-12);
    }
  }
}

TEST(HeadCollider, EllipsoidDistanceIsZeroOnTheSurfaceAndCloseNearIt) {
  EllipsoidShape e;  // default head
  for (double th = 0.1; th < 3.1; th += 0.3) {
    for (double ph = 0.0; ph < 6.2; ph += 0.5) {
      const Vec3 u(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
      const Vec3 x = u.cwiseProduct(e.radii_m);  // on the surface
      Vec3 n;
      EXPECT_NEAR(ellipsoidDistance(e, x, &n), 0.0, 1e-15);
      // Exact normal on the surface: x / r^2 normalised.
      EXPECT_LT((n - x.cwiseQuotient(e.radii_m.cwiseProduct(e.radii_m)).normalized()).norm(),
                1e-12);
      // 5 mm outward along the normal: the estimate is within 5 % of the true 5 mm.
      EXPECT_NEAR(ellipsoidDistance(e, x + 0.005 * n, &n), 0.005, 0.00025);
    }
  }
}

TEST(HeadCollider, CapsuleDistanceIsExact) {
  CapsuleShape c{"neck", Vec3(0, 0, 0), Vec3(0, 0, -0.2), 0.05};
  Vec3 n;
  EXPECT_NEAR(capsuleDistance(c, Vec3(0.08, 0, -0.1), &n), 0.03, 1e-15);
  EXPECT_LT((n - Vec3(1, 0, 0)).norm(), 1e-15);
  EXPECT_NEAR(capsuleDistance(c, Vec3(0, 0, 0.07), &n), 0.02, 1e-15);
  EXPECT_NEAR(capsuleDistance(c, Vec3(0, 0.01, -0.1), &n), -0.04, 1e-15);
  EXPECT_TRUE(std::isfinite(capsuleDistance(c, Vec3(0, 0, -0.1), &n)));  // on the axis
  EXPECT_NEAR(n.norm(), 1.0, 1e-12);
}

TEST(HeadCollider, HeadShapeTakesTheClosestShape) {
  HeadShape h;
  h.capsules.push_back({"neck", Vec3(0, 0, -0.05), Vec3(0, 0, -0.3), 0.05});
  Vec3 n;
  EXPECT_NEAR(h.distance(Vec3(0.06, 0, -0.25), &n), 0.01, 1e-12);
}

TEST(HeadCollider, SurelyFartherThanNeverHidesAContact) {
  // Points all around the default head with a neck: whenever the cheap bound says "farther than
  // d", the full distance agrees; on a sphere the bound is the distance itself, so it answers
  // true exactly beyond d (plus its 1 nm margin).
  HeadShape h;
  h.capsules.push_back({"neck", Vec3(-0.01, 0, -0.06), Vec3(-0.02, 0, -0.25), 0.055});
  int said_far = 0, points = 0;
  for (double th = 0.05; th < 3.1; th += 0.1)
    for (double ph = 0.0; ph < 6.2; ph += 0.2)
      for (double r = 0.05; r < 0.4; r += 0.01) {
        const Vec3 x =
            r * Vec3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
        for (double d : {0.0, 0.002, 0.01}) {
          Vec3 n;
          ++points;
          if (!h.surelyFartherThan(x, d)) continue;
          ++said_far;
          ASSERT_GE(h.distance(x, &n), d) << x.transpose() << " d " << d;
        }
      }
  EXPECT_GT(said_far, points / 3) << "the bound never helps";
  HeadShape sphere;
  sphere.ellipsoid.radii_m = Vec3(0.1, 0.1, 0.1);
  EXPECT_TRUE(sphere.surelyFartherThan(Vec3(0, 0, 0.1021), 0.002));
  EXPECT_FALSE(sphere.surelyFartherThan(Vec3(0, 0, 0.1019), 0.002));
  EXPECT_FALSE(sphere.surelyFartherThan(Vec3(0, 0, 0.05), 0.0));  // inside
}

TEST(HeadCollider, ProjectionIsInelasticWithoutAddedVelocity) {
  Vec3 x(0, 0, -0.002), v(0.0, 0.0, -1.0);
  EXPECT_TRUE(collideParticle(-0.002, Vec3::UnitZ(), 0.001, 0.0, Vec3::Zero(), &x, &v));
  EXPECT_NEAR(x.z(), 0.001, 1e-15);        // moved to the offset surface
  EXPECT_NEAR(v.norm(), 0.0, 1e-15);       // approaching normal velocity removed, nothing added
  Vec3 y(0, 0, -0.002), w(0.0, 0.0, 2.0);  // already leaving: velocity untouched
  collideParticle(-0.002, Vec3::UnitZ(), 0.001, 0.3, Vec3::Zero(), &y, &w);
  EXPECT_NEAR(w.z(), 2.0, 1e-15);
  Vec3 far(0, 0, 1), vf(1, 2, 3);
  EXPECT_FALSE(collideParticle(0.5, Vec3::UnitZ(), 0.001, 0.3, Vec3::Zero(), &far, &vf));
}

TEST(HeadCollider, CoulombFrictionKineticAndStatic) {
  // Kinetic: tangential speed reduced by mu times the removed normal speed.
  Vec3 x(0, 0, 0), v(1.0, 0.0, -1.0);
  collideParticle(0.0, Vec3::UnitZ(), 0.001, 0.3, Vec3::Zero(), &x, &v);
  EXPECT_NEAR(v.x(), 0.7, 1e-15);
  EXPECT_NEAR(v.z(), 0.0, 1e-15);
  // Static: friction would reverse it, so it stops (relative to the moving collider).
  const Vec3 vobj(0.2, 0.0, 0.0);
  Vec3 y(0, 0, 0), w = vobj + Vec3(0.1, 0.0, -1.0);
  collideParticle(0.0, Vec3::UnitZ(), 0.001, 0.3, vobj, &y, &w);
  EXPECT_LT((w - vobj).norm(), 1e-15);
}

TEST(HeadCollider, TheLowerBoundIsBelowTheDistanceAndOneLipschitz) {
  // The head distance cache of the solver rests on this: where the bound b(x) is positive, the
  // distance at any y is at least b(x) - |y - x|. Points and pairs all around the default head
  // with a neck and two ears; on a sphere the bound is the distance itself.
  HeadShape h;
  h.capsules.push_back({"neck", Vec3(-0.01, 0, -0.06), Vec3(-0.02, 0, -0.25), 0.055});
  h.capsules.push_back({"ear_l", Vec3(0, 0.07, -0.01), Vec3(0, 0.09, -0.01), 0.012});
  h.capsules.push_back({"ear_r", Vec3(0, -0.07, -0.01), Vec3(0, -0.09, -0.01), 0.012});
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> box(-0.25, 0.25), step(-0.03, 0.03);
  int positive = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec3 x(box(rng), box(rng), box(rng));
    V3<double> n;
    double bound = 0.0;
    const double d = h.distance(toV3(x), &n, &bound);
    if (!(bound > 0.0)) continue;
    ++positive;
    ASSERT_LE(bound, d + 1e-15) << x.transpose();
    const Vec3 y = x + Vec3(step(rng), step(rng), step(rng));
    Vec3 ny;
    ASSERT_GE(h.distance(y, &ny), bound - (y - x).norm() - 1e-15) << x.transpose();
  }
  EXPECT_GT(positive, 10000);
  HeadShape sphere;
  sphere.ellipsoid.radii_m = Vec3(0.1, 0.1, 0.1);
  V3<double> n;
  double bound = 0.0;
  const double d = sphere.distance(toV3(Vec3(0.03, -0.05, 0.12)), &n, &bound);
  EXPECT_NEAR(bound, d, 1e-15);
  EXPECT_NEAR(d, Vec3(0.03, -0.05, 0.12).norm() - 0.1, 1e-15);
}
