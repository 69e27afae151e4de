// The IIR smoothing filter, eq. (2) (docs/physics.md §2.3, A2, A3).
#include <gtest/gtest.h>

#include <cmath>

#include "wet_curly_hair/core/smoothing.h"

using namespace wet_curly_hair;

TEST(Smoothing, BetaFromMeanRestEdge) {
  EXPECT_DOUBLE_EQ(smoothingBeta(0.01, 0.06), 1.0 - std::exp(-1.0 / 6.0));
  EXPECT_DOUBLE_EQ(smoothingBeta(0.01, 0.0), 1.0);  // no smoothing
}

TEST(Smoothing, StraightUniformStrandIsReproducedExactly) {
  Vec3List p(40), d(39), curve(40);
  const Vec3 step(0.003, -0.002, 0.007);
  for (int i = 0; i < 40; ++i) p[i] = Vec3(0.1, 0.2, 0.3) + i * step;
  for (double beta : {0.05, 0.3, 0.9, 1.0}) {
    smoothDifferences(p.data(), 40, beta, d.data());
    for (int i = 0; i < 39; ++i)
      EXPECT_LT((d[i] - step).norm(), 1e-15) << "beta " << beta << " i " << i;
    rebuildCurve(p[0], d.data(), 40, curve.data());
    for (int i = 0; i < 40; ++i) EXPECT_LT((curve[i] - p[i]).norm(), 1e-14);
  }
}

TEST(Smoothing, FirstOutputIsFirstEdge) {
  Vec3List p = {Vec3(0, 0, 0), Vec3(1, 2, 3), Vec3(-4, 5, 1), Vec3(2, 2, 2)};
  Vec3List d(3);
  smoothDifferences(p.data(), 4, 0.2, d.data());
  EXPECT_LT((d[0] - (p[1] - p[0])).norm(), 1e-15);
}

TEST(Smoothing, UnitDcGain) {
  // A step in the edge input: the output converges to the new value (DC gain 1), with the
  // critically damped response of two cascaded first-order smoothers (no overshoot).
  const int n = 400;
  Vec3List p(n), d(n - 1);
  const Vec3 a(1, 0, 0), b(0, 0, 2);
  p[0].setZero();
  for (int i = 1; i < n; ++i) p[i] = p[i - 1] + (i <= 10 ? a : b);
  const double beta = 0.1;
  smoothDifferences(p.data(), n, beta, d.data());
  EXPECT_LT((d[n - 2] - b).norm(), 1e-12);
  for (int i = 10; i < n - 1; ++i) {
    EXPECT_LE(d[i].z(), 2.0 + 1e-12);
    EXPECT_GE(d[i].x(), -1e-12);
  }
  // Eq. (2) is two cascaded first-order smoothers with pole 1 - beta: compare with them.
  std::vector<double> x(n - 1), y1(n - 1), y2(n - 1);
  for (int i = 0; i < n - 1; ++i) x[i] = (i < 10 ? 0.0 : 2.0);
  double s1 = 0.0, s2 = 0.0;
  for (int i = 0; i < n - 1; ++i) {
    s1 = (1 - beta) * s1 + beta * x[i];
    s2 = (1 - beta) * s2 + beta * s1;
    EXPECT_NEAR(d[i].z(), s2, 1e-12) << i;
  }
}

TEST(Smoothing, IsCausal) {
  Vec3List p(20), q(20), dp(19), dq(19);
  for (int i = 0; i < 20; ++i) p[i] = q[i] = Vec3(std::sin(i), std::cos(0.3 * i), 0.1 * i);
  q[15] += Vec3(0.5, 0.5, 0.5);
  smoothDifferences(p.data(), 20, 0.3, dp.data());
  smoothDifferences(q.data(), 20, 0.3, dq.data());
  for (int i = 0; i < 14; ++i) EXPECT_EQ(dp[i], dq[i]) << i;
  EXPECT_NE(dp[14], dq[14]);
}
