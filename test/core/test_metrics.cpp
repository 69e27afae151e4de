// The runner's neighbour measurements on their spatial grids against the test of every pair
// (brute force) on random grooms, and against analytic answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <random>
#include <vector>

#include "strands_only.h"
#include "wet_curly_hair/core/diagnostics.h"
#include "wet_curly_hair/core/metrics.h"

using namespace wet_curly_hair;

// Every global operator new counts itself, so that a test can tell whether the measurements
// allocate once their scratch has grown (their buffers are std::vectors: operator new).
extern "C" {
void* __libc_malloc(size_t size);
void* __libc_memalign(size_t alignment, size_t size);
void __libc_free(void* p);
}
namespace {
std::atomic<long> g_news{0};
}  // namespace
void* operator new(size_t size) {
  g_news.fetch_add(1, std::memory_order_relaxed);
  if (void* p = __libc_malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](size_t size) { return operator new(size); }
void* operator new(size_t size, std::align_val_t align) {
  g_news.fetch_add(1, std::memory_order_relaxed);
  const size_t a = static_cast<size_t>(align);
  if (void* p = __libc_memalign(a, size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](size_t size, std::align_val_t align) { return operator new(size, align); }
void operator delete(void* p) noexcept { __libc_free(p); }
void operator delete[](void* p) noexcept { __libc_free(p); }
void operator delete(void* p, size_t) noexcept { __libc_free(p); }
void operator delete[](void* p, size_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete(void* p, size_t, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, size_t, std::align_val_t) noexcept { __libc_free(p); }

namespace {

/// Random-walk strands crowded into a box a few edges wide: many contacts, every orientation.
/// With `lattice` > 0 every coordinate is a multiple of it, so points sit on cell boundaries
/// and distances tie.
struct RandomGroom {
  HairModel model;
  Vec3List points;
  std::vector<double> saturation;
  RandomGroom(int strands, int particles, double edge, double box, unsigned seed,
              double lattice = 0.0) {
    model = strandsOnly(std::vector<int>(strands, particles));
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    auto snap = [lattice](double x) {
      return lattice > 0.0 ? lattice * std::round(x / lattice) : x;
    };
    for (int s = 0; s < strands; ++s) {
      Vec3 x(box * u(rng), box * u(rng), box * u(rng));
      for (int i = 0; i < particles; ++i) {
        points.push_back(Vec3(snap(x.x()), snap(x.y()), snap(x.z())));
        Vec3 d(u(rng), u(rng), u(rng) - 0.6);  // mostly downward, like hanging hair
        x += edge * d.normalized();
      }
    }
    saturation.resize(points.size());
    for (double& v : saturation) v = u(rng) > -0.4 ? 0.5 + 0.5 * u(rng) : 0.0;  // some dry
  }
};

/// Every pair of segments of different strands, tested (segments with a non-finite end never
/// touch: their distance is NaN).
int bruteTangles(const HairModel& m, const Vec3List& p, double strand_radius) {
  int count = 0;
  for (int s = 0; s < m.strandCount(); ++s)
    for (int t = s + 1; t < m.strandCount(); ++t)
      for (int i = m.strandBegin(s); i + 1 < m.strandBegin(s) + m.strandSize(s); ++i)
        for (int j = m.strandBegin(t); j + 1 < m.strandBegin(t) + m.strandSize(t); ++j)
          if (segmentDistance(p[i], p[i + 1], p[j], p[j + 1]) < 2.0 * strand_radius) ++count;
  return count;
}

/// The sampled estimate from every pair tested: every k-th strand's touching pairs, summed (a
/// pair of two sampled strands twice), times strands / (2 sampled strands), rounded.
int bruteTangleEstimate(const HairModel& m, const Vec3List& p, double strand_radius, int k) {
  long degrees = 0;
  int sampled = 0;
  for (int s = 0; s < m.strandCount(); s += k, ++sampled)
    for (int t = 0; t < m.strandCount(); ++t)
      for (int i = m.strandBegin(s); t != s && i + 1 < m.strandBegin(s) + m.strandSize(s); ++i)
        for (int j = m.strandBegin(t); j + 1 < m.strandBegin(t) + m.strandSize(t); ++j)
          if (segmentDistance(p[std::min(i, j)], p[std::min(i, j) + 1], p[std::max(i, j)],
                              p[std::max(i, j) + 1]) < 2.0 * strand_radius)
            ++degrees;
  return static_cast<int>(std::lround(double(m.strandCount()) * degrees / (2.0 * sampled)));
}

/// Every wet particle of every k-th strand against every particle of another strand, summed in
/// particle order.
double bruteClump(const HairModel& m, const Vec3List& p, const std::vector<double>& sat,
                  double radius, int k = 1) {
  double sum = 0.0;
  long count = 0;
  for (int s = 0; s < m.strandCount(); s += k) {
    for (int i = m.strandBegin(s); i < m.strandBegin(s) + m.strandSize(s); ++i) {
      if (sat[i] <= 0.0) continue;
      double best2 = radius * radius;
      for (int t = 0; t < m.strandCount(); ++t) {
        if (t == s) continue;
        for (int j = m.strandBegin(t); j < m.strandBegin(t) + m.strandSize(t); ++j) {
          const double dx = p[j].x() - p[i].x(), dy = p[j].y() - p[i].y(), dz = p[j].z() - p[i].z();
          const double r2 = dx * dx + dy * dy + dz * dz;
          if (r2 < best2) best2 = r2;
        }
      }
      sum += std::sqrt(best2);
      ++count;
    }
  }
  return count ? sum / count : 0.0;
}

}  // namespace

TEST(Metrics, GridTanglesEqualEveryPairTestedOnRandomGrooms) {
  MetricScratch scratch;  // reused across sizes, as the runner does
  int cases = 0, nonzero = 0;
  for (unsigned seed = 1; seed <= 12; ++seed) {
    const int strands = 5 + 7 * (seed % 4), particles = 4 + seed % 9;
    const double lattice = seed % 3 == 0 ? 0.001 : 0.0;
    RandomGroom g(strands, particles, 0.008, 0.01, seed, lattice);
    for (double radius : {0.0005, 0.002, 0.006}) {
      const int expected = bruteTangles(g.model, g.points, radius);
      for (int threads : {1, 2}) {
        EXPECT_EQ(tangleCount(g.model, g.points, radius, &scratch, threads), expected)
            << "seed " << seed << " radius " << radius << " threads " << threads;
      }
      ++cases;
      nonzero += expected > 0;
    }
  }
  EXPECT_GE(nonzero, cases / 2) << "the random grooms must actually touch";
}

TEST(Metrics, GridClumpDistanceEqualsEveryPairTestedToTheLastBit) {
  MetricScratch scratch;
  for (unsigned seed = 1; seed <= 12; ++seed) {
    const int strands = 4 + 6 * (seed % 4), particles = 3 + seed % 10;
    const double lattice = seed % 3 == 0 ? 0.002 : 0.0;
    // Sparse (box 8 cm: many particles find nobody within the radius) and dense (1 cm).
    const double box = seed % 2 ? 0.08 : 0.01;
    RandomGroom g(strands, particles, 0.008, box, 100 + seed, lattice);
    for (double radius : {0.003, 0.02, 0.05}) {
      const double expected = bruteClump(g.model, g.points, g.saturation, radius);
      for (int threads : {1, 2})
        EXPECT_EQ(clumpDistance(g.model, g.points, g.saturation, radius, &scratch, threads),
                  expected)
            << "seed " << seed << " radius " << radius << " threads " << threads;
    }
  }
}

TEST(Metrics, SampledStrandsGiveTheirEstimateFromEveryPairTested) {
  MetricScratch scratch;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    RandomGroom g(9 + 5 * seed, 6 + seed % 5, 0.008, 0.012, 300 + seed);
    g.points[7] += Vec3(0.5, 0.0, 0.3);  // two long edges: their pairs go by weight too
    for (int k : {2, 3, 5}) {
      for (double radius : {0.001, 0.004}) {
        const int expected = bruteTangleEstimate(g.model, g.points, radius, k);
        EXPECT_EQ(tangleCount(g.model, g.points, radius, &scratch, 2, k), expected)
            << "seed " << seed << " stride " << k << " radius " << radius;
      }
      EXPECT_EQ(clumpDistance(g.model, g.points, g.saturation, 0.03, &scratch, 2, k),
                bruteClump(g.model, g.points, g.saturation, 0.03, k))
          << "seed " << seed << " stride " << k;
    }
    // Stride 1 of the estimate is the exact count.
    EXPECT_EQ(bruteTangleEstimate(g.model, g.points, 0.004, 1),
              bruteTangles(g.model, g.points, 0.004));
  }
}

TEST(Metrics, NonFiniteAndStretchedEdgesAreHandledLikeEveryPairTested) {
  MetricScratch scratch;
  RandomGroom g(12, 10, 0.008, 0.01, 7);
  // A NaN particle (its two segments never touch; as a wet particle it counts as the radius),
  // and an edge pulled 2 m long (too many cells to enter in the grid: tested apart).
  g.points[15].x() = std::numeric_limits<double>::quiet_NaN();
  g.points[44] += Vec3(2.0, 0.5, -1.0);
  g.points[61] += Vec3(-0.3, 0.0, 0.0);  // a second long edge: the long pair counted once
  g.points[62] += Vec3(0.3, 0.0, 0.0);
  g.saturation[15] = 1.0;
  for (double radius : {0.0005, 0.003}) {
    EXPECT_EQ(tangleCount(g.model, g.points, radius, &scratch, 1),
              bruteTangles(g.model, g.points, radius));
  }
  EXPECT_EQ(clumpDistance(g.model, g.points, g.saturation, 0.02, &scratch, 2),
            bruteClump(g.model, g.points, g.saturation, 0.02));
}

TEST(Metrics, CrossingStrandsAnalytic) {
  // Strand 0 along x at z = 0, strand 1 along y at height z = gap: only the two segments at the
  // crossing (one per strand, the crossing point inside both) are gap apart; each of the two
  // neighbours of the crossing segment on either strand is farther than gap.
  const int n = 11;
  HairModel m = strandsOnly({n, n});
  Vec3List p;
  for (int i = 0; i < n; ++i) p.push_back(Vec3(-0.05 + 0.01 * i + 0.005, 0.0, 0.0));
  for (int i = 0; i < n; ++i) p.push_back(Vec3(0.0, -0.05 + 0.01 * i + 0.005, 0.001));
  MetricScratch scratch;
  EXPECT_EQ(tangleCount(m, p, 0.0005 * 0.999, &scratch), 0);  // contact just under 1 mm
  EXPECT_EQ(tangleCount(m, p, 0.0005 * 1.001, &scratch), 1);  // just over
  // Wet crossing: the particles nearest the crossing are 5 mm from it in the plane and the
  // strands 1 mm apart in height: sqrt(0.005^2 + 0.005^2 + 0.001^2) to the other strand.
  std::vector<double> sat(2 * n, 0.0);
  sat[5] = 1.0;      // (0.005, 0, 0): nearest (0, 0.005, 0.001)
  sat[n + 5] = 1.0;  // (0, 0.005, 0.001): nearest (0.005, 0, 0)
  const double d = std::sqrt(2 * 0.005 * 0.005 + 0.001 * 0.001);
  EXPECT_NEAR(clumpDistance(m, p, sat, 0.05, &scratch), d, 1e-15);
  // Beyond the search radius: the radius.
  EXPECT_NEAR(clumpDistance(m, p, sat, 0.004, &scratch), 0.004, 1e-15);
}

TEST(Metrics, CrossingsCountSegmentsPassingThroughEachOther) {
  // Strand 0 along x at z = 0; strand 1 along y, moving from z = +dz to z = -dz between the
  // frames: exactly its segment over the crossing passes through strand 0's segment there.
  const int n = 11;
  HairModel m = strandsOnly({n, n});
  auto frame = [&](double z1, double shift) {
    Vec3List p;
    for (int i = 0; i < n; ++i) p.push_back(Vec3(-0.05 + 0.01 * i + 0.005, 0.0, 0.0));
    for (int i = 0; i < n; ++i) p.push_back(Vec3(shift, -0.05 + 0.01 * i + 0.005, z1));
    return p;
  };
  MetricScratch scratch;
  for (int threads : {1, 2}) {
    EXPECT_EQ(crossingCount(m, frame(0.003, 0.0), frame(-0.003, 0.0), &scratch, threads), 1);
    EXPECT_EQ(crossingCount(m, frame(-0.003, 0.0), frame(0.003, 0.0), &scratch, threads), 1);
    // Down to just above strand 0: no crossing.
    EXPECT_EQ(crossingCount(m, frame(0.003, 0.0), frame(1e-6, 0.0), &scratch, threads), 0);
    // A diagonal strand passing 2 mm beyond strand 0's free end (x = 0.055): the lines cross
    // at x = 0.057, the segments do not, though their swept boxes overlap.
    auto diagonal = [&](double z1) {
      Vec3List p = frame(0.0, 0.0);
      for (int k = 0; k < n; ++k) {
        const double t = (k - 5 + 0.5) * 0.01 / std::sqrt(2.0);
        p[n + k] = Vec3(0.057 + t, t, z1);
      }
      return p;
    };
    EXPECT_EQ(crossingCount(m, diagonal(0.003), diagonal(-0.003), &scratch, threads), 0);
    // A still pair, and one sliding along without passing through: nothing.
    EXPECT_EQ(crossingCount(m, frame(0.002, 0.0), frame(0.002, 0.0), &scratch, threads), 0);
    EXPECT_EQ(crossingCount(m, frame(0.002, 0.0), frame(0.002, 0.02), &scratch, threads), 0);
  }
  // Random grooms moved randomly: the grid finds exactly the pairs that a test of every pair of
  // segments (of different strands, each as a two-strand model of its own) finds, for any thread
  // count.
  std::mt19937 rng(11);
  std::normal_distribution<double> jolt(0.0, 0.004);
  const HairModel pair = strandsOnly({2, 2});
  int64_t total = 0;
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const RandomGroom g(20, 8, 0.008, 0.01, seed);
    Vec3List after = g.points;
    for (Vec3& x : after) x += Vec3(jolt(rng), jolt(rng), jolt(rng));
    int64_t expected = 0;
    const HairModel& gm = g.model;
    for (int a = 0; a < gm.strandCount(); ++a)
      for (int b = a + 1; b < gm.strandCount(); ++b)
        for (int i = gm.strandBegin(a); i + 1 < gm.strandBegin(a) + gm.strandSize(a); ++i)
          for (int j = gm.strandBegin(b); j + 1 < gm.strandBegin(b) + gm.strandSize(b); ++j) {
            const Vec3List p0 = {g.points[i], g.points[i + 1], g.points[j], g.points[j + 1]};
            const Vec3List p1 = {after[i], after[i + 1], after[j], after[j + 1]};
            expected += crossingCount(pair, p0, p1, &scratch);
          }
    for (int threads : {1, 2})
      EXPECT_EQ(crossingCount(gm, g.points, after, &scratch, threads), expected) << seed;
    total += expected;
  }
  EXPECT_GT(total, 10);
}

TEST(Metrics, HeadPenetrationOnThreadsEqualsTheDiagnostic) {
  // Strands around a turned, moved head: particles outside the ellipsoid (some in the neck),
  // one particle of one strand deeper inside; the roots at the centre, deeper still, do not
  // count.
  const int strands = 40, n = 8;
  HairModel m = strandsOnly(std::vector<int>(strands, n));
  CapsuleShape neck;
  neck.a_m = Vec3(-0.01, 0, -0.06);
  neck.b_m = Vec3(-0.02, 0, -0.25);
  neck.radius_m = 0.055;
  m.head.capsules = {neck};
  Pose pose;
  pose.rotation = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  pose.translation = Vec3(0.3, -0.1, 1.2);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  HairState state;
  for (int s = 0; s < strands; ++s) {
    for (int i = 0; i < n; ++i) {
      Vec3 x = Vec3::Zero();
      while (i > 0 && x.norm() < 0.12) x = Vec3(u(rng), u(rng), u(rng));
      state.position.push_back(pose.apply(x));
    }
  }
  MetricScratch unused;
  for (int deepest : {5 * n + 3, 22 * n + 7, 39 * n + 1}) {
    Vec3List p = state.position;
    p[deepest] = pose.apply(Vec3(0.001, 0.002, 0.06));  // 5 cm below the crown
    HairState at = state;
    at.position = p;
    const double expected = maxHeadPenetration(m, at, pose);
    ASSERT_GT(expected, 0.04);
    ASSERT_LT(expected, 0.07);  // a root at the centre is 7.8 cm deep
    // Four particles at a time, into the head frame by a matrix instead of the quaternion:
    // the same distance up to rounding.
    for (int threads : {1, 2, 3})
      EXPECT_NEAR(headPenetration(m, p, pose, threads), expected, 1e-12)
          << deepest << " " << threads;
  }
}

TEST(Metrics, LengthStatsEqualEdgeStrainAndTheArcLengths) {
  RandomGroom g(37, 9, 0.008, 0.01, 11);
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(0.9, 1.1);
  // Rest edges within 10 % of the current ones: strains of both signs.
  g.model.rest_edge_m.assign(g.points.size(), 0.0);
  g.model.strand_length_m.assign(g.model.strandCount(), 0.0);
  for (int s = 0; s < g.model.strandCount(); ++s) {
    for (int i = g.model.strandBegin(s); i + 1 < g.model.strandBegin(s) + g.model.strandSize(s);
         ++i) {
      g.model.rest_edge_m[i] = u(rng) * (g.points[i + 1] - g.points[i]).norm();
      g.model.strand_length_m[s] += g.model.rest_edge_m[i];
    }
  }
  HairState state;
  state.position = g.points;
  const StrainStats strain = edgeStrain(g.model, state);
  double max_ext = -1e300, ext_sum = 0.0;
  for (int s = 0; s < g.model.strandCount(); ++s) {
    double arc = 0.0;
    for (int i = g.model.strandBegin(s); i + 1 < g.model.strandBegin(s) + g.model.strandSize(s);
         ++i)
      arc += (g.points[i + 1] - g.points[i]).norm();
    max_ext = std::max(max_ext, arc / g.model.strand_length_m[s] - 1.0);
    ext_sum += arc / g.model.strand_length_m[s] - 1.0;
  }
  ASSERT_GT(strain.max, 0.0);
  ASSERT_LT(max_ext, 0.1);
  MetricScratch scratch;
  for (int threads : {1, 2}) {
    const LengthStats l = lengthStats(g.model, g.points, &scratch, threads);
    EXPECT_EQ(l.max_strain, strain.max);
    EXPECT_NEAR(l.mean_strain, strain.mean, 1e-15);
    EXPECT_EQ(l.max_extension, max_ext);
    EXPECT_EQ(l.mean_extension, ext_sum / g.model.strandCount());
  }
}

TEST(Metrics, NoAllocationOnceTheScratchHasGrown) {
  RandomGroom g(30, 12, 0.008, 0.01, 21);
  g.model.rest_edge_m.assign(g.points.size(), 0.008);
  g.model.strand_length_m.assign(g.model.strandCount(), 0.008 * 11);
  Pose pose;
  MetricScratch scratch;
  auto all = [&] {
    tangleCount(g.model, g.points, 0.002, &scratch, 1, 1);
    tangleCount(g.model, g.points, 0.002, &scratch, 1, 3);
    clumpDistance(g.model, g.points, g.saturation, 0.03, &scratch, 1, 1);
    clumpDistance(g.model, g.points, g.saturation, 0.03, &scratch, 1, 4);
    lengthStats(g.model, g.points, &scratch, 1);
    headPenetration(g.model, g.points, pose, 1);
  };
  const long before_warm_up = g_news.load();
  all();  // grows the scratch
  const long warm_up = g_news.load() - before_warm_up;
  ASSERT_GT(warm_up, 0) << "the counter must see the scratch grow";
  const long before = g_news.load();
  for (int k = 0; k < 3; ++k) all();
  EXPECT_EQ(g_news.load() - before, 0);
}
