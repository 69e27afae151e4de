// Kernels of the wet model (Kim 2023 eqs. 6-9, 12, 13; docs/physics.md A6-A10, A15, A17).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/wet_kernels.h"

using namespace wet_curly_hair;

TEST(Curl, RotationMapsHelixAxisOntoHairAxis) {
  // M h^ = p^ (A7) for random axes, parallel and antiparallel included (A8).
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  std::vector<std::pair<Vec3, Vec3>> cases;
  for (int k = 0; k < 200; ++k)
    cases.push_back(
        {Vec3(g(rng), g(rng), g(rng)).normalized(), Vec3(g(rng), g(rng), g(rng)).normalized()});
  const Vec3 a = Vec3(0.3, -0.4, 0.8).normalized();
  cases.push_back({a, a});
  cases.push_back({a, -a});
  cases.push_back({Vec3::UnitZ(), -Vec3::UnitZ()});
  cases.push_back({a, (a + Vec3(1e-10, 0, 0)).normalized()});
  cases.push_back({a, (-a + Vec3(0, 1e-10, 0)).normalized()});
  for (const auto& [h, p] : cases) {
    const Mat3 m = helixToHairRotation(h, p);
    EXPECT_LT((m * h - p).norm(), 1e-12) << h.transpose() << " -> " << p.transpose();
    EXPECT_LT((m.transpose() * m - Mat3::Identity()).norm(), 1e-12);
    EXPECT_NEAR(m.determinant(), 1.0, 1e-12);
    // The quaternion the time-constant filter slerps is the same rotation (about h x p, or the
    // half turn for opposite axes).
    const Quat q = helixToHairQuaternion(h, p);
    EXPECT_NEAR(q.norm(), 1.0, 1e-14);
    EXPECT_LT((q.toRotationMatrix() - m).norm(), 1e-12) << h.transpose() << " -> " << p.transpose();
  }
  // The analytic half-angle form: a quarter turn about z takes x to y, q = (cos 45, 0, 0, sin 45).
  const Quat quarter = helixToHairQuaternion(Vec3::UnitX(), Vec3::UnitY());
  EXPECT_NEAR(quarter.w(), std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(quarter.z(), std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(quarter.vec().head<2>().norm(), 0.0, 1e-15);
}

TEST(Curl, TheLiteralEq7DirectionIsTheTranspose) {
  // A7: the printed gamma = p x h rotates the hair onto the helix: the opposite of what eq. (9)
  // needs. It is the inverse of ours and maps h by twice the angle the wrong way.
  const Vec3 h = Vec3(0, 0, 1), p = Vec3(1, 0, 1).normalized();
  const Mat3 ours = helixToHairRotation(h, p), literal = literalEq7Rotation(h, p);
  EXPECT_LT((literal - ours.transpose()).norm(), 1e-14);
  EXPECT_LT((literal * p - h).norm(), 1e-14);
  EXPECT_GT((literal * h - p).norm(), 0.5);
}

TEST(Curl, HelixHasTheStrandsParticleCountAndEdgeLength) {
  for (int n : {8, 32, 129}) {
    for (double r : {0.0, 0.004, 0.01}) {
      const Vec3List h = makeHelix(n, 0.008, r, 0.02);
      ASSERT_EQ(static_cast<int>(h.size()), n);
      for (int i = 0; i + 1 < n; ++i) EXPECT_NEAR((h[i + 1] - h[i]).norm(), 0.008, 1e-12);
      if (r > 0.0) {  // on the cylinder of radius r about z
        for (const Vec3& x : h) EXPECT_NEAR(std::hypot(x.x(), x.y()), r, 1e-12);
      }
    }
  }
}

TEST(Curl, SpringVariantRestoresLiteralIsAConstantField) {
  const Vec3 target(0, 0.008, 0), e(0.008, 0, 0);
  const Vec3 spring = curlForce(target, e, 10.0, 0.5, true);
  EXPECT_LT((spring - 5.0 * (target - e)).norm(), 1e-15);
  EXPECT_EQ(curlForce(target, target, 10.0, 1.0, true), Vec3::Zero());  // at the target: none
  EXPECT_LT((curlForce(target, e, 10.0, 0.5, false) - 5.0 * target).norm(), 1e-15);
  EXPECT_EQ(curlForce(target, e, 10.0, 0.0, true), Vec3::Zero());  // dry: none
}

TEST(Adhesion, KernelZeroOutsideItsBandFiniteEverywherePeakAtThreeQuarters) {
  for (bool literal : {false, true}) {
    const double h = 0.01;
    for (double r : {-1.0, 0.0, 0.001, 0.005, 0.01 + 1e-12, 0.02, 1e9}) {
      if (r <= 0.5 * h || r > h) {
        EXPECT_EQ(adhesionKernel(r, h, literal), 0.0) << r;
      }
    }
    double best = 0.0, best_r = 0.0;
    for (int k = 0; k <= 100000; ++k) {
      const double r = -0.01 + 0.04 * k / 100000.0;
      const double a = adhesionKernel(r, h, literal);
      ASSERT_TRUE(std::isfinite(a)) << r;
      ASSERT_GE(a, 0.0);
      if (a > best) best = a, best_r = r;
    }
    EXPECT_NEAR(best_r, 0.75 * h, 1e-6);
    EXPECT_NEAR(adhesionKernelPeak(h, literal), best, best * 1e-9);
    EXPECT_EQ(adhesionKernel(std::nan(""), h, literal), 0.0);
  }
  // Akinci's peak: 0.007 / sqrt(2) h^-3 (A15).
  EXPECT_NEAR(adhesionKernelPeak(0.01, false), 0.007 / std::sqrt(2.0) * 1e6, 1e-6);
}

TEST(Adhesion, KernelOnLanesIsTheScalarKernel) {
  // The solver reads the kernel on lanes (float16 or double4) at 16 or 4 distances at once. Float
  // holds the polynomial to ~1e-7 of h; its fourth root is steep where the polynomial vanishes
  // (r -> h/2, h), so the bound there is the root of that, ~1e-2 of the peak within 1e-4 h.
  const double h = 0.01;
  for (bool literal : {false, true}) {
    const double peak = adhesionKernelPeak(h, literal);
    // Distances on a 2^-17 m grid from -1e-4 to 1.2e-2 m: the same value in float and double.
    for (int k = -16; k < 1584; k += 16) {
      float r[16];
      LaneFloat16 r16;
      LaneDouble4 r4;
      for (int l = 0; l < 16; ++l) r[l] = std::ldexp(float(k + l), -17), r16[l] = r[l];
      for (int l = 0; l < 4; ++l) r4[l] = r[l];
      const LaneFloat16 a16 = adhesionKernel(r16, h, literal);
      const LaneDouble4 a4 = adhesionKernel(r4, h, literal);
      for (int l = 0; l < 16; ++l) {
        const double expected = adhesionKernel(double(r[l]), h, literal);
        const bool steep = std::abs(r[l] - 0.5 * h) < 1e-4 * h || std::abs(r[l] - h) < 1e-4 * h;
        EXPECT_NEAR(a16[l], expected, (steep ? 1e-2 : 1e-5) * peak) << r[l];
        if (l < 4) {
          EXPECT_NEAR(a4[l], expected, 1e-12 * peak) << r[l];
        }
      }
    }
  }
}

TEST(Stiffness, DecayPerSecondIsTheSameAtTwoSubsteps) {
  // (xi zeta)^(h / h_ref) applied 1/h times per second: the same decay whatever h (A17).
  for (double sigma : {0.0, 0.5, 1.0}) {
    double v_small = 1.0, v_large = 1.0;
    for (int k = 0; k < 20000; ++k)
      v_small *= stiffnessFactor(0.999995, 0.9999, 1.0, sigma, 5e-5, 1e-4);
    for (int k = 0; k < 2500; ++k)
      v_large *= stiffnessFactor(0.999995, 0.9999, 1.0, sigma, 4e-4, 1e-4);
    EXPECT_NEAR(v_small / v_large, 1.0, 0.01) << sigma;
    // And eq. (13) per reference step: 1e4 steps of xi zeta per second.
    EXPECT_NEAR(v_small, std::pow(0.999995 * (sigma * 0.9999 + (1 - sigma)), 1e4), 1e-9);
  }
}

TEST(Kernels, AkinciCohesionKernelShape) {
  const double h = 0.02;
  EXPECT_EQ(akinciCohesionKernel(0.0, h), 0.0);
  EXPECT_EQ(akinciCohesionKernel(h * 1.01, h), 0.0);
  EXPECT_GT(akinciCohesionKernel(0.7 * h, h), 0.0);
  EXPECT_LT(akinciCohesionKernel(0.05 * h, h), 0.0);  // repulsive up close
  EXPECT_NEAR(poly6Shape(0.0, 4.0), 64.0, 1e-12);
  EXPECT_EQ(poly6Shape(4.0, 4.0), 0.0);
}
