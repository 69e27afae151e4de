// Shape statistics (core/shape_stats.h) against analytic answers: distribution distances of
// known samples, the tip height of straight strands, the curl radius of circles and helices, the
// clump distance of parallel strands.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "strands_only.h"
#include "wet_curly_hair/core/metrics.h"
#include "wet_curly_hair/core/shape_stats.h"

using namespace wet_curly_hair;

namespace {

/// `count` points of a helix of radius r rising `pitch` per turn, `per_turn` points a turn,
/// about the z axis through `centre`.
Vec3List helix(int count, double r, double pitch, int per_turn, const Vec3& centre) {
  Vec3List p;
  const double dphi = 2.0 * M_PI / per_turn;
  for (int k = 0; k < count; ++k)
    p.push_back(centre + Vec3(r * std::cos(k * dphi), r * std::sin(k * dphi),
                              pitch * k * dphi / (2.0 * M_PI)));
  return p;
}

}  // namespace

TEST(ShapeStats, WassersteinOfAShiftedSampleIsTheShift) {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, 0.01);
  std::vector<double> a(500), b;
  for (double& x : a) x = normal(rng);
  for (double x : a) b.push_back(x + 0.003);
  const SampleDistance d = compareSamples(a, b);
  EXPECT_NEAR(d.w1, 0.003, 1e-15);
  EXPECT_NEAR(compareSamples(b, a).w1, 0.003, 1e-15);
  EXPECT_EQ(compareSamples(a, a).w1, 0.0);
  EXPECT_EQ(compareSamples(a, a).ks, 0.0);
  // The order of a sample does not matter.
  std::vector<double> shuffled = a;
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  EXPECT_EQ(compareSamples(shuffled, a).w1, 0.0);
}

TEST(ShapeStats, WassersteinOfUnequalSizesFollowsTheQuantileFunctions) {
  // Quantiles of {0, 1}: 0 on (0, 1/2], 1 on (1/2, 1]; of {0, 0.5, 1}: 0, 0.5, 1 on thirds.
  // They differ by 0.5 on (1/3, 2/3]: W1 = 1/6.
  EXPECT_NEAR(compareSamples({0.0, 1.0}, {0.0, 0.5, 1.0}).w1, 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(compareSamples({0.0, 0.5, 1.0}, {1.0, 0.0}).w1, 1.0 / 6.0, 1e-15);
  // Against one value c: the mean distance to c. Repeating a sample does not change it.
  EXPECT_NEAR(compareSamples({0.0, 1.0, 2.0, 7.0}, {2.0}).w1, (2.0 + 1.0 + 0.0 + 5.0) / 4.0, 1e-15);
  EXPECT_NEAR(compareSamples({0.0, 1.0, 0.0, 1.0, 0.0, 1.0}, {0.0, 0.5, 1.0}).w1, 1.0 / 6.0, 1e-15);
}

TEST(ShapeStats, KolmogorovSmirnovOfKnownSamples) {
  EXPECT_EQ(compareSamples({1.0, 2.0, 3.0}, {4.0, 5.0}).ks, 1.0);  // disjoint
  EXPECT_EQ(compareSamples({4.0, 5.0}, {1.0, 2.0, 3.0}).ks, 1.0);
  EXPECT_EQ(compareSamples({1.0, 2.0, 3.0, 4.0}, {3.0, 4.0, 5.0, 6.0}).ks, 0.5);
  // Ties: after 1, 2/3 of a against 1/3 of b.
  EXPECT_NEAR(compareSamples({1.0, 1.0, 2.0}, {1.0, 2.0, 2.0}).ks, 1.0 / 3.0, 1e-15);
  // Interleaved: the cumulative distributions never differ by more than one step.
  EXPECT_NEAR(compareSamples({1.0, 3.0, 5.0, 7.0}, {2.0, 4.0, 6.0, 8.0}).ks, 0.25, 1e-15);
}

TEST(ShapeStats, SpreadIsTheMeanDeviationFromTheMedian) {
  // Median of {0, 1, 2, 7} is 1.5: deviations 1.5, 0.5, 0.5, 5.5.
  EXPECT_NEAR(compareSamples({0.0}, {0.0, 1.0, 2.0, 7.0}).spread_b, 2.0, 1e-15);
  // Median of {0, 1, 9} is 1: deviations 1, 0, 8.
  EXPECT_NEAR(compareSamples({0.0}, {0.0, 1.0, 9.0}).spread_b, 3.0, 1e-15);
}

TEST(ShapeStats, EmptyOrNonFiniteSamplesAreNotCompared) {
  for (const SampleDistance& d :
       {compareSamples({}, {1.0}), compareSamples({1.0}, {}), compareSamples({1.0, NAN}, {1.0}),
        compareSamples({1.0}, {INFINITY, 2.0})}) {
    EXPECT_TRUE(std::isnan(d.w1));
    EXPECT_TRUE(std::isnan(d.ks));
    EXPECT_TRUE(std::isnan(d.spread_b));
  }
}

TEST(ShapeStats, TipHeightOfStraightStrandsInTheHeadFrame) {
  // Strand 0 hangs straight down (head frame), strand 1 lies level, strand 2 stands up; 10
  // edges of 1 cm each.
  const int n = 11;
  HairModel m = strandsOnly({n, n, n});
  Vec3List head;
  for (int i = 0; i < n; ++i) head.push_back(Vec3(0.1, 0.0, -0.01 * i));
  for (int i = 0; i < n; ++i) head.push_back(Vec3(0.0, 0.1 + 0.01 * i, 0.0));
  for (int i = 0; i < n; ++i) head.push_back(Vec3(0.0, 0.0, 0.1 + 0.01 * i));
  Pose pose;  // the head tilted 1 rad about x and moved: the heights are the head frame's
  pose.rotation = Quat(Eigen::AngleAxisd(1.0, Vec3(1.0, 2.0, 0.5).normalized()));
  pose.translation = Vec3(0.3, -0.2, 1.5);
  Vec3List world;
  for (const Vec3& x : head) world.push_back(pose.apply(x));
  for (const Pose& p : {Pose(), pose}) {
    std::vector<double> h;
    tipHeights(m, p.translation.isZero() ? head : world, p, &h);
    ASSERT_EQ(h.size(), 3u);
    EXPECT_NEAR(h[0], -0.1, 1e-15);
    EXPECT_NEAR(h[1], 0.0, 1e-15);
    EXPECT_NEAR(h[2], 0.1, 1e-15);
  }
}

TEST(ShapeStats, CurlRadiusPerStrandIsItsCirclesAndHelicesRadius) {
  // A flat circle: the discrete curvature of evenly spaced points on it is 1 / r exactly.
  const int n = 30;
  HairModel m = strandsOnly({n, n, n});
  Vec3List p = helix(n, 0.01, 0.0, 24, Vec3::Zero());
  for (const Vec3& x : helix(n, 0.004, 0.0, 24, Vec3(0.1, 0.0, 0.0))) p.push_back(x);
  // A helix: the discrete curvature and torsion approach the helix's as the points per turn
  // grow, with a relative error of the order of the squared angle per point (2 pi / 200)^2 ~ 1e-3.
  for (const Vec3& x : helix(n, 0.008, 0.02, 200, Vec3(0.2, 0.0, 0.0))) p.push_back(x);
  CurlShape c;
  ASSERT_TRUE(strandTipCurl(m, p, 0, &c));
  EXPECT_NEAR(c.radius_m, 0.01, 1e-12);
  EXPECT_NEAR(c.pitch_m, 0.0, 1e-12);
  ASSERT_TRUE(strandTipCurl(m, p, 1, &c));
  EXPECT_NEAR(c.radius_m, 0.004, 1e-12);
  ASSERT_TRUE(strandTipCurl(m, p, 2, &c));
  EXPECT_NEAR(c.radius_m, 0.008, 0.008 * 2e-3);
  EXPECT_NEAR(c.pitch_m, 0.02, 0.02 * 2e-3);
  // The groom's mean is the mean of the strands'.
  const CurlShape mean = tipCurlShape(m, p);
  CurlShape c2;
  strandTipCurl(m, p, 2, &c2);
  EXPECT_NEAR(mean.radius_m, (0.01 + 0.004 + c2.radius_m) / 3.0, 1e-15);
  // The samples: one per strand.
  ShapeSamples s;
  MetricScratch scratch;
  appendShapeSamples(m, p, std::vector<double>(p.size(), 0.0), Pose(), 0.01, &scratch, &s);
  ASSERT_EQ(s.curl_radius_m.size(), 3u);
  EXPECT_NEAR(s.curl_radius_m[1], 0.004, 1e-12);
}

TEST(ShapeStats, StrandsTooShortForATipThirdHaveNoCurlSample) {
  HairModel m = strandsOnly({9, 10});
  Vec3List p = helix(9, 0.01, 0.0, 24, Vec3::Zero());
  for (const Vec3& x : helix(10, 0.01, 0.0, 24, Vec3::Zero())) p.push_back(x);
  CurlShape c;
  c.radius_m = 7.0;
  EXPECT_FALSE(strandTipCurl(m, p, 0, &c));
  EXPECT_EQ(c.radius_m, 7.0);  // unchanged
  EXPECT_TRUE(strandTipCurl(m, p, 1, &c));
  EXPECT_NEAR(c.radius_m, 0.01, 1e-12);
  EXPECT_NEAR(tipCurlShape(m, p).radius_m, 0.01, 1e-12);  // strand 0 left out of the mean
}

TEST(ShapeStats, ClumpDistanceSamplesOfParallelStrands) {
  // Two parallel vertical strands 3 mm apart, particles at the same heights: every wet
  // particle is 3 mm from the other strand. Strand 1's particles 2 and 5 are dry.
  const int n = 8;
  HairModel m = strandsOnly({n, n});
  Vec3List p;
  for (int s = 0; s < 2; ++s)
    for (int i = 0; i < n; ++i) p.push_back(Vec3(0.003 * s, 0.0, -0.01 * i));
  std::vector<double> sat(2 * n, 1.0);
  sat[n + 2] = sat[n + 5] = 0.0;
  MetricScratch scratch;
  std::vector<double> d = {-1.0};  // appended to
  clumpDistanceSamples(m, p, sat, 0.05, &scratch, &d);
  ASSERT_EQ(d.size(), 1u + 2 * n - 2);
  EXPECT_EQ(d[0], -1.0);
  for (size_t k = 1; k < d.size(); ++k) EXPECT_NEAR(d[k], 0.003, 1e-15);
  EXPECT_NEAR(clumpDistance(m, p, sat, 0.05, &scratch), 0.003, 1e-15);
  // Beyond the search radius: the radius. Every 2nd strand: strand 0's 8.
  d.clear();
  clumpDistanceSamples(m, p, sat, 0.002, &scratch, &d, 1, 2);
  ASSERT_EQ(d.size(), size_t(n));
  for (double x : d) EXPECT_EQ(x, 0.002);
  // Pooled over two frames: tip heights per strand, clump distance per wet particle.
  ShapeSamples s;
  for (int frame = 0; frame < 2; ++frame) appendShapeSamples(m, p, sat, Pose(), 0.05, &scratch, &s);
  EXPECT_EQ(s.tip_height_m.size(), 4u);
  EXPECT_EQ(s.clump_distance_m.size(), size_t(2 * (2 * n - 2)));
  for (double h : s.tip_height_m) EXPECT_NEAR(h, -0.07, 1e-15);
  // A frame against itself: no distance; against the strands 1 mm farther apart: 1 mm.
  ShapeSamples apart;
  for (Vec3& x : p) x.x() *= 4.0 / 3.0;
  for (int frame = 0; frame < 2; ++frame)
    appendShapeSamples(m, p, sat, Pose(), 0.05, &scratch, &apart);
  EXPECT_EQ(compareShapes(s, s).clump_distance.w1, 0.0);
  const ShapeDistance d2 = compareShapes(apart, s);
  EXPECT_NEAR(d2.clump_distance.w1, 0.001, 1e-15);
  EXPECT_EQ(d2.clump_distance.ks, 1.0);
  EXPECT_NEAR(d2.tip_height.w1, 0.0, 1e-15);
  EXPECT_TRUE(std::isnan(d2.curl_radius.w1));  // strands of 8: no curl sample
}
