// Exact squared EDT and the signed distance field of an occupancy grid (core/edt.h).
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <limits>
#include <random>

#include "wet_curly_hair/core/edt.h"

namespace wet_curly_hair {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

int64_t cellCount(const Eigen::Vector3i& d) { return int64_t{d.x()} * d.y() * d.z(); }

/// Brute-force generalised squared distance transform: min_q f[q] + |p - q|^2, voxel units.
std::vector<float> bruteForce(const std::vector<float>& f, const Eigen::Vector3i& d) {
  std::vector<float> out(f.size(), kInf);
  for (int z = 0; z < d.z(); ++z)
    for (int y = 0; y < d.y(); ++y)
      for (int x = 0; x < d.x(); ++x) {
        double best = std::numeric_limits<double>::infinity();
        for (int k = 0; k < d.z(); ++k)
          for (int j = 0; j < d.y(); ++j)
            for (int i = 0; i < d.x(); ++i) {
              const float fq = f[i + d.x() * (j + d.y() * k)];
              if (fq == kInf) continue;
              const double v =
                  fq + double(x - i) * (x - i) + double(y - j) * (y - j) + double(z - k) * (z - k);
              best = std::min(best, v);
            }
        out[x + d.x() * (y + d.y() * z)] = static_cast<float>(best);
      }
  return out;
}

std::vector<uint8_t> randomOccupancy(const Eigen::Vector3i& d, double p, std::mt19937* rng) {
  std::bernoulli_distribution occ(p);
  std::vector<uint8_t> g(cellCount(d));
  for (auto& v : g) v = occ(*rng) ? 1 : 0;
  return g;
}

Eigen::Vector3i randomDims(std::mt19937* rng, int max_dim) {
  std::uniform_int_distribution<int> dim(1, max_dim);
  return Eigen::Vector3i(dim(*rng), dim(*rng), dim(*rng));
}

TEST(SquaredDistanceTransform, MatchesBruteForceOnRandomSiteGrids) {
  std::mt19937 rng(7);
  const double densities[] = {0.002, 0.02, 0.1, 0.5, 0.95};
  int grids = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const Eigen::Vector3i d = randomDims(&rng, trial < 20 ? 6 : 14);
    const std::vector<uint8_t> occ = randomOccupancy(d, densities[trial % 5], &rng);
    std::vector<float> f(occ.size());
    for (size_t i = 0; i < occ.size(); ++i) f[i] = occ[i] ? 0.0f : kInf;
    const std::vector<float> expected = bruteForce(f, d);
    std::string error;
    ASSERT_TRUE(squaredDistanceTransform(&f, d, &error)) << error;
    for (size_t i = 0; i < f.size(); ++i) {
      ASSERT_EQ(f[i], expected[i]) << "dims " << d.transpose() << " cell " << i;
    }
    ++grids;
  }
  EXPECT_EQ(grids, 60);
}

TEST(SquaredDistanceTransform, MatchesBruteForceForGeneralisedInput) {
  // f = small integers or +infinity: the lower envelope of shifted parabolas, still exact.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> value(0, 40);
  std::bernoulli_distribution infinite(0.7);
  for (int trial = 0; trial < 30; ++trial) {
    const Eigen::Vector3i d = randomDims(&rng, 10);
    std::vector<float> f(cellCount(d));
    for (auto& v : f) v = infinite(rng) ? kInf : static_cast<float>(value(rng));
    const std::vector<float> expected = bruteForce(f, d);
    std::string error;
    ASSERT_TRUE(squaredDistanceTransform(&f, d, &error)) << error;
    for (size_t i = 0; i < f.size(); ++i) ASSERT_EQ(f[i], expected[i]) << "cell " << i;
  }
}

TEST(SquaredDistanceTransform, ExactOnLongAxes) {
  // Squared distances up to ~2e6 voxels^2 along a 1500-voxel axis stay exact integers.
  std::mt19937 rng(13);
  for (const Eigen::Vector3i& d :
       {Eigen::Vector3i(1500, 4, 2), Eigen::Vector3i(3, 1500, 2), Eigen::Vector3i(2, 3, 1500)}) {
    const std::vector<uint8_t> occ = randomOccupancy(d, 0.002, &rng);
    std::vector<float> f(occ.size());
    for (size_t i = 0; i < occ.size(); ++i) f[i] = occ[i] ? 0.0f : kInf;
    f[0] = 0.0f;  // At least one site, at a corner.
    const std::vector<float> expected = bruteForce(f, d);
    std::string error;
    ASSERT_TRUE(squaredDistanceTransform(&f, d, &error)) << error;
    for (size_t i = 0; i < f.size(); ++i) ASSERT_EQ(f[i], expected[i]) << "cell " << i;
  }
}

TEST(SquaredDistanceTransform, NoSitesStaysInfinite) {
  const Eigen::Vector3i d(5, 4, 3);
  std::vector<float> f(cellCount(d), kInf);
  std::string error;
  ASSERT_TRUE(squaredDistanceTransform(&f, d, &error)) << error;
  for (float v : f) EXPECT_EQ(v, kInf);
}

TEST(SquaredDistanceTransform, ResultIndependentOfThreadCount) {
  std::mt19937 rng(3);
  const Eigen::Vector3i d(67, 45, 38);
  const std::vector<uint8_t> occ = randomOccupancy(d, 0.003, &rng);
  std::vector<float> f(occ.size());
  for (size_t i = 0; i < occ.size(); ++i) f[i] = occ[i] ? 0.0f : kInf;
  const int saved = omp_get_max_threads();
  std::vector<std::vector<float>> results;
  std::vector<std::vector<float>> sdfs;
  for (int threads : {1, 2, 3, 5}) {
    omp_set_num_threads(threads);
    std::vector<float> g = f;
    std::string error;
    ASSERT_TRUE(squaredDistanceTransform(&g, d, &error)) << error;
    results.push_back(g);
    DenseSdf sdf;
    ASSERT_TRUE(buildSignedDistanceField(occ, d, 0.01, Vec3::Zero(), &sdf, &error)) << error;
    sdfs.push_back(sdf.distance_m);
  }
  omp_set_num_threads(saved);
  for (size_t t = 1; t < results.size(); ++t) {
    EXPECT_TRUE(results[t] == results[0]) << "thread setting " << t;
    EXPECT_TRUE(sdfs[t] == sdfs[0]) << "thread setting " << t;
  }
}

TEST(SquaredDistanceTransform, RefusesBadInput) {
  std::string error;
  std::vector<float> f(8, 0.0f);
  EXPECT_FALSE(squaredDistanceTransform(nullptr, Eigen::Vector3i(2, 2, 2), &error));
  EXPECT_NE(error.find("grid is null"), std::string::npos) << error;
  EXPECT_FALSE(squaredDistanceTransform(&f, Eigen::Vector3i(2, 0, 2), &error));
  EXPECT_NE(error.find("dims"), std::string::npos) << error;
  EXPECT_FALSE(squaredDistanceTransform(&f, Eigen::Vector3i(2, 2, 3), &error));
  EXPECT_NE(error.find("grid has 8 values"), std::string::npos) << error;
  f[3] = -1.0f;
  EXPECT_FALSE(squaredDistanceTransform(&f, Eigen::Vector3i(2, 2, 2), &error));
  EXPECT_NE(error.find("grid[3]"), std::string::npos) << error;
  f[3] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(squaredDistanceTransform(&f, Eigen::Vector3i(2, 2, 2), &error));
  EXPECT_NE(error.find("grid[3]"), std::string::npos) << error;
  EXPECT_TRUE(std::isnan(f[3]));  // Unchanged.
  EXPECT_FALSE(squaredDistanceTransform(&f, Eigen::Vector3i(2048, 2048, 1024), &error));
  EXPECT_NE(error.find("more than the limit"), std::string::npos) << error;
}

/// Expected signed field from brute-force squared distances.
std::vector<float> expectedSdf(const std::vector<uint8_t>& occ, const Eigen::Vector3i& d, float h) {
  std::vector<float> to_occ(occ.size()), to_free(occ.size());
  for (size_t i = 0; i < occ.size(); ++i) {
    to_occ[i] = occ[i] ? 0.0f : kInf;
    to_free[i] = occ[i] ? kInf : 0.0f;
  }
  const std::vector<float> dout = bruteForce(to_occ, d), din = bruteForce(to_free, d);
  std::vector<float> sdf(occ.size());
  for (size_t i = 0; i < occ.size(); ++i) {
    sdf[i] = occ[i] ? -(std::sqrt(din[i]) - 0.5f) * h : (std::sqrt(dout[i]) - 0.5f) * h;
  }
  return sdf;
}

TEST(BuildSignedDistanceField, MatchesBruteForceOnRandomGrids) {
  std::mt19937 rng(5);
  const double densities[] = {0.01, 0.1, 0.4, 0.8, 0.97};
  for (int trial = 0; trial < 40; ++trial) {
    const Eigen::Vector3i d = randomDims(&rng, 12);
    const std::vector<uint8_t> occ = randomOccupancy(d, densities[trial % 5], &rng);
    int n_occ = 0;
    for (uint8_t v : occ) n_occ += v;
    if (n_occ == 0 || n_occ == static_cast<int>(occ.size())) continue;
    const float h = 0.005f;
    const std::vector<float> expected = expectedSdf(occ, d, h);
    DenseSdf sdf;
    std::string error;
    const Vec3 origin(0.1, -0.2, 0.3);
    ASSERT_TRUE(buildSignedDistanceField(occ, d, h, origin, &sdf, &error)) << error;
    EXPECT_EQ(sdf.dims, d);
    EXPECT_EQ(sdf.origin_m, origin);
    EXPECT_FALSE(sdf.empty());
    for (size_t i = 0; i < occ.size(); ++i) {
      ASSERT_EQ(sdf.distance_m[i], expected[i]) << "dims " << d.transpose() << " cell " << i;
      ASSERT_EQ(sdf.distance_m[i] < 0.0f, occ[i] != 0);
    }
  }
}

TEST(BuildSignedDistanceField, SingleVoxelAndSingleHole) {
  const Eigen::Vector3i d(9, 9, 9);
  std::vector<uint8_t> occ(cellCount(d), 0);
  occ[4 + 9 * (4 + 9 * 4)] = 1;
  DenseSdf sdf;
  std::string error;
  ASSERT_TRUE(buildSignedDistanceField(occ, d, 0.01, Vec3::Zero(), &sdf, &error)) << error;
  EXPECT_NEAR(sdf.distance_m[4 + 9 * (4 + 9 * 4)], -0.005, 1e-7);
  EXPECT_NEAR(sdf.distance_m[0], (std::sqrt(48.0) - 0.5) * 0.01, 1e-6);
  EXPECT_NEAR(sdf.distance_m[5 + 9 * (4 + 9 * 4)], 0.005, 1e-7);
  for (auto& v : occ) v = 1 - v;
  ASSERT_TRUE(buildSignedDistanceField(occ, d, 0.01, Vec3::Zero(), &sdf, &error)) << error;
  EXPECT_NEAR(sdf.distance_m[4 + 9 * (4 + 9 * 4)], 0.005, 1e-7);
  EXPECT_NEAR(sdf.distance_m[0], -(std::sqrt(48.0) - 0.5) * 0.01, 1e-6);
}

TEST(BuildSignedDistanceField, AllFreeAndAllOccupiedGiveTheGridDiagonal) {
  const Eigen::Vector3i d(4, 5, 6);
  const double h = 0.02;
  const double diag = h * std::sqrt(16.0 + 25.0 + 36.0);
  DenseSdf sdf;
  std::string error;
  ASSERT_TRUE(
      buildSignedDistanceField(std::vector<uint8_t>(120, 0), d, h, Vec3::Zero(), &sdf, &error))
      << error;
  for (float v : sdf.distance_m) EXPECT_NEAR(v, diag, 1e-6);
  ASSERT_TRUE(
      buildSignedDistanceField(std::vector<uint8_t>(120, 1), d, h, Vec3::Zero(), &sdf, &error))
      << error;
  for (float v : sdf.distance_m) EXPECT_NEAR(v, -diag, 1e-6);
}

TEST(BuildSignedDistanceField, RefusesBadInputAndLeavesOutputUnchanged) {
  DenseSdf sdf;
  sdf.voxel_m = 123.0;
  sdf.distance_m = {42.0f};
  const std::vector<uint8_t> occ(8, 0);
  const Eigen::Vector3i d(2, 2, 2);
  std::string error;
  auto unchanged = [&]() {
    EXPECT_EQ(sdf.voxel_m, 123.0);
    ASSERT_EQ(sdf.distance_m.size(), 1u);
    EXPECT_EQ(sdf.distance_m[0], 42.0f);
  };
  for (double h : {0.0, -0.01, std::nan(""), std::numeric_limits<double>::infinity()}) {
    error.clear();
    EXPECT_FALSE(buildSignedDistanceField(occ, d, h, Vec3::Zero(), &sdf, &error));
    EXPECT_NE(error.find("voxel_m"), std::string::npos) << error;
    unchanged();
  }
  EXPECT_FALSE(
      buildSignedDistanceField(occ, Eigen::Vector3i(2, -2, 2), 0.01, Vec3::Zero(), &sdf, &error));
  EXPECT_NE(error.find("dims"), std::string::npos) << error;
  EXPECT_FALSE(
      buildSignedDistanceField(occ, Eigen::Vector3i(2, 2, 0), 0.01, Vec3::Zero(), &sdf, &error));
  EXPECT_NE(error.find("dims"), std::string::npos) << error;
  EXPECT_FALSE(
      buildSignedDistanceField(occ, Eigen::Vector3i(2, 2, 3), 0.01, Vec3::Zero(), &sdf, &error));
  EXPECT_NE(error.find("occupied has 8 entries"), std::string::npos) << error;
  EXPECT_FALSE(buildSignedDistanceField(occ, Eigen::Vector3i(2048, 1024, 1025), 0.01, Vec3::Zero(),
                                        &sdf, &error));
  EXPECT_NE(error.find("more than the limit"), std::string::npos) << error;
  EXPECT_FALSE(buildSignedDistanceField(occ, d, 0.01, Vec3(0, std::nan(""), 0), &sdf, &error));
  EXPECT_NE(error.find("origin_m"), std::string::npos) << error;
  unchanged();
  EXPECT_FALSE(buildSignedDistanceField(occ, d, 0.01, Vec3::Zero(), nullptr, &error));
  EXPECT_NE(error.find("out is null"), std::string::npos) << error;
  EXPECT_FALSE(buildSignedDistanceField(occ, d, 0.0, Vec3::Zero(), &sdf, nullptr));  // No crash.
}

}  // namespace
}  // namespace wet_curly_hair
