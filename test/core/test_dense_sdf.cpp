// Trilinear distance and unit gradient of a dense SDF (core/dense_sdf.h).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "wet_curly_hair/core/dense_sdf.h"

namespace wet_curly_hair {
namespace {

/// Field sampled from f at the voxel centres.
DenseSdf sampled(const Eigen::Vector3i& dims, double h, const Vec3& origin,
                 const std::function<double(const Vec3&)>& f) {
  DenseSdf s;
  s.dims = dims;
  s.voxel_m = h;
  s.origin_m = origin;
  s.distance_m.resize(int64_t{dims.x()} * dims.y() * dims.z());
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i)
        s.distance_m[s.index(i, j, k)] = static_cast<float>(f(origin + h * Vec3(i, j, k)));
  return s;
}

Vec3 boxMax(const DenseSdf& s) {
  return s.origin_m + s.voxel_m * (s.dims.cast<double>() - Vec3::Ones());
}

TEST(DenseSdf, EmptyAndContains) {
  DenseSdf s;
  EXPECT_TRUE(s.empty());
  EXPECT_FALSE(s.contains(Vec3::Zero()));
  EXPECT_EQ(s.distance(Vec3::Zero()), std::numeric_limits<double>::infinity());
  Vec3 g(1, 2, 3);
  EXPECT_EQ(s.distanceAndGradient(Vec3::Zero(), &g), std::numeric_limits<double>::infinity());
  EXPECT_EQ(g, Vec3::UnitZ());

  s = sampled(Eigen::Vector3i(4, 3, 2), 0.01, Vec3(1, 2, 3), [](const Vec3&) { return 0.5; });
  EXPECT_FALSE(s.empty());
  EXPECT_TRUE(s.contains(Vec3(1, 2, 3)));
  EXPECT_TRUE(s.contains(Vec3(1.03, 2.02, 3.01)));
  EXPECT_FALSE(s.contains(Vec3(1.0301, 2.02, 3.01)));
  EXPECT_FALSE(s.contains(Vec3(0.9999, 2.0, 3.0)));
  EXPECT_FALSE(s.contains(Vec3(std::nan(""), 2.0, 3.0)));

  DenseSdf bad = s;
  bad.distance_m.pop_back();
  EXPECT_TRUE(bad.empty());
  bad = s;
  bad.voxel_m = 0.0;
  EXPECT_TRUE(bad.empty());
  bad = s;
  bad.voxel_m = std::nan("");
  EXPECT_TRUE(bad.empty());
  bad = s;
  bad.dims.y() = -3;
  EXPECT_TRUE(bad.empty());
  EXPECT_EQ(bad.distance(Vec3(1, 2, 3)), std::numeric_limits<double>::infinity());
}

TEST(DenseSdf, NonFiniteQueryGivesNanAndUnitGradient) {
  const DenseSdf s =
      sampled(Eigen::Vector3i(4, 4, 4), 0.01, Vec3::Zero(), [](const Vec3& p) { return p.x(); });
  Vec3 g;
  EXPECT_TRUE(std::isnan(s.distance(Vec3(std::nan(""), 0, 0))));
  EXPECT_TRUE(
      std::isnan(s.distanceAndGradient(Vec3(0, std::numeric_limits<double>::infinity(), 0), &g)));
  EXPECT_EQ(g, Vec3::UnitZ());
  // Far away but finite: finite and conservative.
  const double far = s.distanceAndGradient(Vec3(1e300, 0, 0), &g);
  EXPECT_TRUE(std::isfinite(far));
  EXPECT_NEAR(g.norm(), 1.0, 1e-12);
  EXPECT_NO_FATAL_FAILURE(s.distanceAndGradient(Vec3(0, 0, 0), nullptr));
}

TEST(DenseSdf, LinearFieldIsReproducedExactly) {
  const Vec3 n = Vec3(0.3, -0.5, 0.8).normalized();
  const auto plane = [&](const Vec3& p) { return n.dot(p) - 0.01; };
  const DenseSdf s = sampled(Eigen::Vector3i(11, 9, 7), 0.004, Vec3(-0.02, -0.015, -0.01), plane);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Vec3 lo = s.origin_m, hi = boxMax(s);
  for (int t = 0; t < 2000; ++t) {
    const Vec3 p = lo + (hi - lo).cwiseProduct(Vec3(u(rng), u(rng), u(rng)));
    Vec3 g;
    const double d = s.distanceAndGradient(p, &g);
    ASSERT_NEAR(d, plane(p), 1e-6);  // Float storage.
    ASSERT_NEAR(s.distance(p), d, 1e-15);
    ASSERT_NEAR((g - n).norm(), 0.0, 1e-5);
  }
}

TEST(DenseSdf, OutsideTheBoxAddsTheDistanceToTheBox) {
  const auto f = [](const Vec3& p) { return 0.1 * p.x() + 0.2 * p.y() - 0.05 * p.z(); };
  const DenseSdf s = sampled(Eigen::Vector3i(5, 6, 7), 0.01, Vec3(0.1, 0.2, 0.3), f);
  const Vec3 lo = s.origin_m, hi = boxMax(s);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-0.5, 1.5);
  int outside = 0;
  for (int t = 0; t < 2000; ++t) {
    const Vec3 p = lo + (hi - lo).cwiseProduct(Vec3(u(rng), u(rng), u(rng)));
    const Vec3 q = p.cwiseMax(lo).cwiseMin(hi);
    const double expected = f(q) + (p - q).norm();
    EXPECT_NEAR(s.distance(p), expected, 1e-6);
    Vec3 g;
    EXPECT_NEAR(s.distanceAndGradient(p, &g), expected, 1e-6);
    EXPECT_NEAR(g.norm(), 1.0, 1e-12);
    EXPECT_EQ(s.contains(p), p == q);
    if (p != q) {
      ++outside;
      // The gradient points away from the box: moving along it increases the distance.
      EXPECT_GT(s.distance(p + 1e-4 * g), s.distance(p));
    }
  }
  EXPECT_GT(outside, 1000);
}

TEST(DenseSdf, GradientIsUnitAtVoxelCentresFacesEdgesAndCorners) {
  const Vec3 c(0.0123, -0.0051, 0.0077);
  const auto sphere = [&](const Vec3& p) { return (p - c).norm() - 0.03; };
  const double h = 0.005;
  const DenseSdf s = sampled(Eigen::Vector3i(21, 21, 21), h, Vec3(-0.05, -0.05, -0.05), sphere);
  int checked = 0;
  for (int k = 0; k < 21; ++k)
    for (int j = 0; j < 21; ++j)
      for (int i = 0; i < 21; ++i)
        for (const Vec3& off : {Vec3(0, 0, 0), Vec3(0.5, 0, 0), Vec3(0, 0.5, 0.5),
                                Vec3(0.5, 0.5, 0.5), Vec3(0.25, 0, 0.75)}) {
          const Vec3 p = s.origin_m + h * (Vec3(i, j, k) + off);
          Vec3 g;
          const double d = s.distanceAndGradient(p, &g);
          ASSERT_TRUE(std::isfinite(d));
          ASSERT_NEAR(g.norm(), 1.0, 1e-12) << p.transpose();
          // Away from the centre (r > 7 h) the direction is the sphere normal, to O(h / r).
          const double r = (p - c).norm();
          if (r > 0.035 && s.contains(p)) {
            ASSERT_LT(std::acos(std::min(1.0, g.dot((p - c) / r))), 0.1) << p.transpose();
          }
          ++checked;
        }
  EXPECT_EQ(checked, 21 * 21 * 21 * 5);
}

TEST(DenseSdf, CentralDifferenceAtSamplePlanes) {
  // f = x^2 + y on samples: at the sample plane x = 0.02 the one-sided x slopes are 0.03 and
  // 0.05, the derivative used is their mean 0.04 (= 2x); inside a cell it is the cell slope.
  const double h = 0.01;
  const DenseSdf s = sampled(Eigen::Vector3i(6, 2, 2), h, Vec3::Zero(),
                             [](const Vec3& p) { return p.x() * p.x() + p.y(); });
  Vec3 g;
  s.distanceAndGradient(Vec3(0.02, 0.005, 0.0), &g);
  EXPECT_NEAR((g - Vec3(0.04, 1.0, 0.0).normalized()).norm(), 0.0, 1e-6);
  s.distanceAndGradient(Vec3(0.025, 0.005, 0.0), &g);
  EXPECT_NEAR((g - Vec3(0.05, 1.0, 0.0).normalized()).norm(), 0.0, 1e-6);
  // One-sided on the box boundary.
  s.distanceAndGradient(Vec3(0.0, 0.005, 0.0), &g);
  EXPECT_NEAR((g - Vec3(0.01, 1.0, 0.0).normalized()).norm(), 0.0, 1e-6);
  s.distanceAndGradient(Vec3(0.05, 0.005, 0.0), &g);
  EXPECT_NEAR((g - Vec3(0.09, 1.0, 0.0).normalized()).norm(), 0.0, 1e-6);
  // Symmetric samples around a minimum: the raw gradient vanishes at the sample, the fallback
  // (central differences over one voxel) vanishes too, so +z is returned.
  const DenseSdf v = sampled(Eigen::Vector3i(5, 1, 1), h, Vec3(-0.02, 0, 0),
                             [](const Vec3& p) { return std::abs(p.x()); });
  v.distanceAndGradient(Vec3(0, 0, 0), &g);
  EXPECT_EQ(g, Vec3::UnitZ());
  // Just beside the sample the cell slope gives +-x.
  v.distanceAndGradient(Vec3(0.001, 0, 0), &g);
  EXPECT_NEAR((g - Vec3::UnitX()).norm(), 0.0, 1e-12);
  v.distanceAndGradient(Vec3(-0.001, 0, 0), &g);
  EXPECT_NEAR((g + Vec3::UnitX()).norm(), 0.0, 1e-12);
}

TEST(DenseSdf, ConstantFieldFallsBackToPlusZ) {
  const DenseSdf s =
      sampled(Eigen::Vector3i(5, 5, 5), 0.01, Vec3::Zero(), [](const Vec3&) { return 0.2; });
  Vec3 g;
  EXPECT_NEAR(s.distanceAndGradient(Vec3(0.02, 0.023, 0.015), &g), 0.2, 1e-7);
  EXPECT_EQ(g, Vec3::UnitZ());
}

TEST(DenseSdf, FlatGridsInterpolateInTheirPlane) {
  // One voxel thick along z: no interpolation and no gradient along z inside the box.
  const auto f = [](const Vec3& p) { return p.x() + 2.0 * p.y(); };
  const DenseSdf s = sampled(Eigen::Vector3i(4, 4, 1), 0.01, Vec3::Zero(), f);
  EXPECT_NEAR(s.distance(Vec3(0.015, 0.005, 0.0)), 0.025, 1e-7);
  EXPECT_NEAR(s.distance(Vec3(0.015, 0.005, 0.02)), 0.025 + 0.02, 1e-7);
  Vec3 g;
  s.distanceAndGradient(Vec3(0.015, 0.005, 0.0), &g);
  EXPECT_NEAR((g - Vec3(1, 2, 0).normalized()).norm(), 0.0, 1e-6);
  const DenseSdf one = sampled(Eigen::Vector3i(1, 1, 1), 0.01, Vec3::Zero(), f);
  EXPECT_NEAR(one.distance(Vec3(0.03, 0.04, 0.0)), 0.05, 1e-12);
  one.distanceAndGradient(Vec3(0.03, 0.04, 0.0), &g);
  EXPECT_NEAR((g - Vec3(0.6, 0.8, 0.0)).norm(), 0.0, 1e-12);
}

TEST(DenseSdf, MemoryBytesCountsTheSamples) {
  const DenseSdf s =
      sampled(Eigen::Vector3i(10, 10, 10), 0.01, Vec3::Zero(), [](const Vec3&) { return 1.0; });
  EXPECT_GE(s.memoryBytes(), 4000u + sizeof(DenseSdf));
  EXPECT_LT(s.memoryBytes(), 4000u + sizeof(DenseSdf) + 64);
}

}  // namespace
}  // namespace wet_curly_hair
