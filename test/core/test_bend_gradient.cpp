// The bending force with the derivative through the frames is the gradient of the bending
// energy (include/wet_curly_hair/core/bend_gradient.h): central finite differences of
// bendEnergyOfStrand against bendForce (frames held) + addBendFrameGradientForce, on a bent curly
// strand, a straight one, one with a zero-length edge and one that folds back on itself. The core
// spring applied through the filter's transpose against finite differences of its energy, on the
// same kinds of strand.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "wet_curly_hair/core/bend_gradient.h"
#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/springs.h"

namespace wet_curly_hair {
namespace {

struct Strand {
  Vec3List p, local_target;
  Mat3 root_frame = Mat3::Identity();
  double beta = 0.2, k_b = 10.0;
  int n() const { return static_cast<int>(p.size()); }
};

/// A model strand (rest targets from its groom), then moved away from rest by `bend`.
Strand curlyStrand(int particles, double radius, const std::function<Vec3(int)>& bend) {
  GroomConfig g;
  g.strands = 1;
  g.particles = particles;
  g.curl_radius_m = radius;
  g.jitter = 0.0;
  SolverConfig c;
  HairModel m;
  std::string why;
  EXPECT_TRUE(buildModel(generateGroom(g, EllipsoidShape()), g.linear_density_kg_per_m, HeadShape(),
                         c, &m, &why))
      << why;
  Strand s;
  for (int i = 0; i < particles; ++i) s.p.push_back(m.rest_position_head[i] + bend(i));
  s.local_target.assign(m.bend_local_target.begin(), m.bend_local_target.begin() + particles - 1);
  s.root_frame = m.root_frame_head[0];
  s.beta = m.beta_bend[0];
  s.k_b = m.bend_k[0];
  return s;
}

/// The applied force: frames held (bendForce, the segment convention) plus the frame part.
Vec3List appliedForce(const Strand& s, bool with_frames) {
  const int n = s.n();
  Vec3List d(n - 1), f(n, Vec3::Zero()), adjoint(n - 1);
  Mat3List frames(n - 1);
  smoothDifferences(s.p.data(), n, s.beta, d.data());
  transportFrames(s.root_frame, d.data(), n - 1, frames.data());
  for (int i = 0; i + 1 < n; ++i) {
    const Vec3 fb = bendForce(s.p[i + 1] - s.p[i], frames[i] * s.local_target[i], s.k_b);
    f[i] += fb;
    f[i + 1] -= fb;
  }
  if (with_frames)
    addBendFrameGradientForce(s.p.data(), n, s.beta, s.root_frame, s.local_target.data(), s.k_b,
                              frames.data(), d.data(), adjoint.data(), f.data());
  return f;
}

/// Largest |applied - (-dE/dp)| over particles 1..n-1, relative to the largest gradient.
double gradientMismatch(Strand s, bool with_frames) {
  const Vec3List f = appliedForce(s, with_frames);
  double worst = 0.0, scale = 0.0;
  for (int i = 1; i < s.n(); ++i) {
    Vec3 g;
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-7, x0 = s.p[i][k];
      s.p[i][k] = x0 + h;
      const double ep =
          bendEnergyOfStrand(s.p.data(), s.n(), s.beta, s.root_frame, s.local_target.data(), s.k_b);
      s.p[i][k] = x0 - h;
      const double em =
          bendEnergyOfStrand(s.p.data(), s.n(), s.beta, s.root_frame, s.local_target.data(), s.k_b);
      s.p[i][k] = x0;
      g[k] = -(ep - em) / (2.0 * h);
    }
    worst = std::max(worst, (f[i] - g).norm());
    scale = std::max(scale, g.norm());
  }
  return worst / scale;
}

}  // namespace

TEST(BendGradient, FramesHeldIsNotTheGradientWithTheFramePartItIs) {
  struct Case {
    const char* name;
    int particles;
    double radius;
    std::function<Vec3(int)> bend;
  };
  const Case cases[] = {
      {"curly, bent", 24, 0.01,
       [](int i) {
         return Vec3(0.002 * std::sin(0.7 * i), 0.0015 * i / 24.0, 0.001 * std::cos(i));
       }},
      {"straight, bent", 20, 0.0, [](int i) { return Vec3(0.0004 * i * i / 20.0, 0.0, 0.0); }},
      {"curly, folding back", 16, 0.01,
       [](int i) { return i >= 8 ? Vec3(0.0, 0.0, -0.012 * (i - 7)) : Vec3::Zero(); }},
      {"straight, folded back on itself: antiparallel edges", 16, 0.0,
       [](int i) { return i >= 8 ? Vec3(0.0, 0.0005, -0.0312 * (i - 8)) : Vec3::Zero(); }},
  };
  for (const Case& c : cases) {
    Strand s = curlyStrand(c.particles, c.radius, c.bend);
    const double held = gradientMismatch(s, false), full = gradientMismatch(s, true);
    std::printf("%s: frames held %.3g, with the frame part %.3g (relative)\n", c.name, held, full);
    // Central differences at h = 1e-7 m are good to ~1e-6 of the force here.
    EXPECT_LT(full, 1e-5) << c.name;
    EXPECT_GT(held, 1e-3) << c.name;
  }
  // At rest (the groom, straight or curly) the energy is at its minimum: no force either way.
  for (double radius : {0.0, 0.01}) {
    const Strand rest = curlyStrand(12, radius, [](int) { return Vec3::Zero(); });
    for (const Vec3& f : appliedForce(rest, true)) EXPECT_LT(f.norm(), 1e-9) << radius;
  }
}

TEST(BendGradient, ZeroLengthEdgeAndShortStrandsAreFinite) {
  Strand s = curlyStrand(10, 0.01, [](int) { return Vec3::Zero(); });
  s.p[5] = s.p[4];  // a zero-length edge: its smoothed difference still has length
  s.p[6] = s.p[4];
  Vec3List f = appliedForce(s, true);
  for (const Vec3& v : f) EXPECT_TRUE(v.allFinite());
  // Two particles: one edge, the root frame only; nothing to add.
  Strand two = curlyStrand(2, 0.0, [](int) { return Vec3(0.001, 0, 0); });
  const Vec3List held = appliedForce(two, false), full = appliedForce(two, true);
  EXPECT_EQ(held[1], full[1]);
}

}  // namespace wet_curly_hair

namespace wet_curly_hair {

namespace {

/// The core spring as the stepper applies it with CoreSpringConfig::filter_gradient
/// (strand_block.h, elasticForces): coreForce on each smoothed difference b_i, through the
/// filter's transpose to the edges, then the segment convention to the particles.
Vec3List coreForceThroughFilter(const Vec3List& p, double beta, const std::vector<double>& rest,
                                double k_c) {
  const int n = static_cast<int>(p.size());
  Vec3List b(n - 1), f(n, Vec3::Zero());
  smoothDifferences(p.data(), n, beta, b.data());
  for (int i = 0; i + 1 < n; ++i) b[i] = coreForce(b[i], rest[i], k_c);
  smoothDifferencesAdjoint(b.data(), n, beta, b.data());
  for (int i = 0; i + 1 < n; ++i) f[i] += b[i], f[i + 1] -= b[i];
  return f;
}

/// Sum over the differences of 1/2 k_c (|b_i| - |b0_i|)^2 (coreEnergy, what the diagnostics sum).
double coreEnergyOfStrand(const Vec3List& p, double beta, const std::vector<double>& rest,
                          double k_c) {
  const int n = static_cast<int>(p.size());
  Vec3List b(n - 1);
  smoothDifferences(p.data(), n, beta, b.data());
  double e = 0.0;
  for (int i = 0; i + 1 < n; ++i) e += coreEnergy(b[i], rest[i], k_c);
  return e;
}

}  // namespace

TEST(CoreGradient, TheCoreSpringThroughTheFilterIsTheGradientOfItsEnergy) {
  // Rest lengths |b0_i| from a curly rest shape; each case moves the strand away from it. Central
  // differences at h = 1e-7 m are good to ~1e-6 of the force; the core force on edge i alone
  // (the default, frames-and-filter held) is checked to be far from the gradient, so the test
  // sees the difference the transpose makes.
  const int n = 20;
  const double beta = smoothingBeta(0.008, 0.08), k_c = 50.0;
  Vec3List rest_p(n);
  for (int i = 0; i < n; ++i)
    rest_p[i] = Vec3(0.01 * std::cos(0.8 * i), 0.01 * std::sin(0.8 * i), 0.004 * i);
  Vec3List rest_b(n - 1);
  smoothDifferences(rest_p.data(), n, beta, rest_b.data());
  std::vector<double> rest(n - 1);
  for (int i = 0; i + 1 < n; ++i) rest[i] = rest_b[i].norm();
  struct Case {
    const char* name;
    std::function<Vec3(int, const Vec3&)> shape;
  };
  const Case cases[] = {
      {"curly, stretched and bent",
       [](int i, const Vec3& x) { return Vec3(1.2 * x + Vec3(0.001 * std::sin(i), 0, 0)); }},
      {"straight", [](int i, const Vec3&) { return Vec3(0.0, 0.0, 0.006 * i); }},
      {"a zero-length edge",
       [](int i, const Vec3& x) {
         return i == 9 ? Vec3(0.01 * std::cos(6.4), 0.01 * std::sin(6.4), 0.032) : x;
       }},
      {"folded back: antiparallel edges",
       [](int i, const Vec3&) { return Vec3(0.0, 0.0, 0.006 * (i <= 10 ? i : 20 - i)); }},
  };
  for (const Case& c : cases) {
    Vec3List p(n);
    for (int i = 0; i < n; ++i) p[i] = c.shape(i, rest_p[i]);
    const Vec3List applied = coreForceThroughFilter(p, beta, rest, k_c);
    double worst = 0.0, local_worst = 0.0, scale = 0.0;
    for (int i = 1; i < n; ++i) {
      Vec3 g;
      for (int k = 0; k < 3; ++k) {
        const double h = 1e-7, x0 = p[i][k];
        p[i][k] = x0 + h;
        const double ep = coreEnergyOfStrand(p, beta, rest, k_c);
        p[i][k] = x0 - h;
        const double em = coreEnergyOfStrand(p, beta, rest, k_c);
        p[i][k] = x0;
        g[k] = -(ep - em) / (2.0 * h);
      }
      Vec3List b(n - 1);
      smoothDifferences(p.data(), n, beta, b.data());
      Vec3 local = Vec3::Zero();  // edge i-1 pushes particle i, edge i pulls it
      local -= coreForce(b[i - 1], rest[i - 1], k_c);
      if (i + 1 < n) local += coreForce(b[i], rest[i], k_c);
      worst = std::max(worst, (applied[i] - g).norm());
      local_worst = std::max(local_worst, (local - g).norm());
      scale = std::max(scale, g.norm());
    }
    std::printf("%s: through the filter %.3g, on the edge alone %.3g (relative)\n", c.name,
                worst / scale, local_worst / scale);
    EXPECT_LT(worst, 1e-5 * scale) << c.name;
    EXPECT_GT(local_worst, 1e-2 * scale) << c.name;
  }
}

TEST(SmoothingAdjoint, IsTheTransposeOfTheFilter) {
  // <g, S e> = <S^T g, e> for the linear map S: edges -> smoothed differences of eq. (2), with
  // the start d_{-1} = d_{-2} = e_0, on random edges and adjoints: the dot-product test.
  for (double beta : {1.0, 0.6, 0.15, 0.02}) {
    const int n = 17;
    Vec3List p(n), g(n - 1), d(n - 1), dedge(n - 1);
    for (int i = 0; i < n; ++i) p[i] = Vec3(std::sin(1.3 * i), std::cos(0.7 * i * i), 0.1 * i);
    for (int i = 0; i + 1 < n; ++i)
      g[i] = Vec3(std::cos(2.1 * i), std::sin(i + 0.5), 1.0 / (i + 1));
    smoothDifferences(p.data(), n, beta, d.data());
    smoothDifferencesAdjoint(g.data(), n, beta, dedge.data());
    double lhs = 0.0, rhs = 0.0;
    for (int i = 0; i + 1 < n; ++i) {
      lhs += g[i].dot(d[i]);
      rhs += dedge[i].dot(p[i + 1] - p[i]);
    }
    EXPECT_NEAR(lhs, rhs, 1e-12 * std::abs(lhs)) << beta;
  }
  // In place (g and the output the same array), as the stepper calls it.
  Vec3List g = {Vec3(1, 2, 3), Vec3(-1, 0, 2), Vec3(0.5, 0.5, 0.5)}, out(3), in_place = g;
  smoothDifferencesAdjoint(g.data(), 4, 0.3, out.data());
  smoothDifferencesAdjoint(in_place.data(), 4, 0.3, in_place.data());
  for (int i = 0; i < 3; ++i) EXPECT_EQ(out[i], in_place[i]);
}

}  // namespace wet_curly_hair
