// Sag-free start (docs/physics.md §8, src/core/sag_free.cpp): the groom is an equilibrium under
// gravity, a curly strand on a still head keeps its groom, and without gravity nothing changes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/sag_free.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/springs.h"
#include "wet_curly_hair/io/scene.h"

using namespace wet_curly_hair;

namespace {

constexpr double kFrame = 1.0 / 60.0;

Groom generated(double curl_radius_m, int strands) {
  GroomConfig c;
  c.strands = strands;
  c.curl_radius_m = curl_radius_m;
  c.jitter = 0.1;
  return generateGroom(c, EllipsoidShape());
}

/// An imported-looking groom: strands that leave the scalp, rise, arc over and fall, with random
/// kinks and uneven edge lengths (edges under compression and under tension).
Groom arbitraryGroom(int strands) {
  Groom g;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int s = 0; s < strands; ++s) {
    const int n = 20 + 5 * s;
    Vec3 p(0.01 * s, 0.0, 0.11);
    Vec3 dir = Vec3(0.3 * u(rng), 0.3 * u(rng), 1.0).normalized();
    for (int i = 0; i < n; ++i) {
      g.points.push_back(p);
      // Turns from up to down over the strand, plus kinks.
      const double a = M_PI * i / (n - 1);
      dir = (Vec3(std::sin(a), 0.2 * std::sin(3.0 * a), std::cos(a)) +
             0.4 * Vec3(u(rng), u(rng), u(rng)))
                .normalized();
      p += (0.006 + 0.004 * (0.5 + 0.5 * u(rng))) * dir;
    }
    g.strand_offsets.push_back(static_cast<uint32_t>(g.points.size()));
    g.root_normals.push_back(Vec3::UnitZ());
  }
  return g;
}

HairModel makeModel(const Groom& g, const SolverConfig& c) {
  HairModel m;
  std::string why;
  EXPECT_TRUE(buildModel(g, GroomConfig().linear_density_kg_per_m, HeadShape(), c, &m, &why))
      << why;
  return m;
}

/// Net force on every particle at the rest pose on the still head (identity), computed as
/// The stepper's stages 2-3 (strand_block.h): frames along the alpha_b-smoothed curve, stretch +
/// bend + core per edge with F_i += f, F_{i+1} -= f, plus gravity.
Vec3List restPoseForces(const HairModel& m, const SolverConfig& c) {
  Vec3List force(m.particleCount(), Vec3::Zero());
  Vec3List d, b;
  Mat3List frames;
  for (int s = 0; s < m.strandCount(); ++s) {
    const int begin = m.strandBegin(s), n = m.strandSize(s);
    const Vec3* p = &m.rest_position_head[begin];
    d.resize(n - 1);
    b.resize(n - 1);
    frames.resize(n - 1);
    smoothDifferences(p, n, m.beta_bend[s], d.data());
    transportFrames(m.root_frame_head[s], d.data(), n - 1, frames.data());
    smoothDifferences(p, n, m.beta_core[s], b.data());
    Vec3* f = &force[begin];
    for (int i = 0; i < n; ++i) f[i] = m.mass_kg[begin + i] * c.gravity_m_s2;
    for (int i = 0; i + 1 < n; ++i) {
      const Vec3 e = p[i + 1] - p[i];
      const Vec3 fs = stretchForce(e, m.rest_edge_m[begin + i], m.stretch_k[begin + i]) +
                      bendForce(e, frames[i] * m.bend_local_target[begin + i], m.bend_k[s]) +
                      coreForce(b[i], m.core_rest_m[begin + i], m.core_k[s]);
      f[i] += fs;
      f[i + 1] -= fs;
    }
  }
  return force;
}

/// Largest |F_j| / (m_j |g|) over the non-root particles.
double worstResidual(const HairModel& m, const SolverConfig& c) {
  const Vec3List f = restPoseForces(m, c);
  double worst = 0.0;
  for (int s = 0; s < m.strandCount(); ++s)
    for (int i = m.strandBegin(s) + 1; i < m.strandBegin(s) + m.strandSize(s); ++i)
      worst = std::max(worst, f[i].norm() / (m.mass_kg[i] * c.gravity_m_s2.norm()));
  return worst;
}

struct Deviation {
  double rms = 0.0;  ///< RMS particle distance to the groom / strand length.
  double max = 0.0;  ///< largest of the same.
};

Deviation deviation(const HairModel& m, const HairState& s) {
  Deviation dev;
  double sum = 0.0;
  int count = 0;
  for (int st = 0; st < m.strandCount(); ++st) {
    for (int i = m.strandBegin(st) + 1; i < m.strandBegin(st) + m.strandSize(st); ++i) {
      const double r = (s.position[i] - m.rest_position_head[i]).norm() / m.strand_length_m[st];
      sum += r * r;
      ++count;
      dev.max = std::max(dev.max, r);
    }
  }
  dev.rms = std::sqrt(sum / count);
  return dev;
}

HairState runStill(const HairModel& m, const SolverConfig& c, double seconds) {
  HairState s = makeState(m, Pose(), Twist());
  HeadMotionConfig still;
  const int frames = static_cast<int>(std::lround(seconds / kFrame));
  for (int f = 0; f < frames; ++f) {
    StepInputs in{headPose(still, f * kFrame), headPose(still, (f + 1) * kFrame)};
    step(m, c, in, kFrame, &s, nullptr);
  }
  return s;
}

}  // namespace

TEST(SagFree, NetForceAtTheGroomIsZeroForAnyGroom) {
  for (int which = 0; which < 3; ++which) {
    SCOPED_TRACE(which == 0 ? "curly" : which == 1 ? "straight" : "arbitrary");
    const Groom g = which == 0   ? generated(0.01, 12)
                    : which == 1 ? generated(0.0, 12)
                                 : arbitraryGroom(6);
    SolverConfig c;
    const HairModel plain = makeModel(g, c);
    // Without the option, the elastic forces vanish at the groom: the net force is the weight.
    EXPECT_NEAR(worstResidual(plain, c), 1.0, 1e-9);
    c.sag_free = true;
    SagFreeStats stats;
    HairModel m = makeModel(g, c);
    EXPECT_LT(worstResidual(m, c), 1e-9);
    // The stats of a direct call on the plain model agree with what buildModel did.
    HairModel again = plain;
    makeSagFree(c, c.gravity_m_s2, &again, &stats);
    EXPECT_EQ(again.rest_edge_m, m.rest_edge_m);
    EXPECT_EQ(stats.edges, g.particleCount() - g.strandCount());
    EXPECT_LT(stats.max_preload_strain, 0.5 * c.stretch.strain_limit + 1e-12);
    EXPECT_GT(stats.max_bend_shift_m, 0.0);
    // Other gravity directions too (a head starting tilted: gravity in the head frame).
    const Vec3 tilted = Eigen::AngleAxisd(0.7, Vec3(1.0, 2.0, 0.5).normalized()) * c.gravity_m_s2;
    HairModel t = plain;
    makeSagFree(c, tilted, &t);
    SolverConfig ct = c;
    ct.gravity_m_s2 = tilted;
    EXPECT_LT(worstResidual(t, ct), 1e-9);
    // The soft scene springs of the built-in scene.
    SolverConfig soft = c;
    soft.bend.stiffness_n_m2 = 1.9e-4;
    soft.bend.damping_n_s = 5.1e-4;
    soft.core.stiffness_n = 0.08;
    EXPECT_LT(worstResidual(makeModel(g, soft), soft), 1e-9);
  }
}

TEST(SagFree, TheSolverSeesNoForceAtTheGroom) {
  // Through the real step: one frame from rest on the still head leaves the hair still, to
  // round-off in double (the double4 lanes). In float (float16 lanes; float8, the default
  // without AVX-512, computes the same lane by lane) the spring forces that hold the hair up are
  // computed from positions known to 2^-24 of their distance from the head (1e-8 m against 8 mm
  // edges): the residual is a small fraction of gravity.
  // Bound: 1e-4 m/s, 1/1600 of the 0.16 m/s a free fall reaches in the frame.
  for (const char* layout : {"double4", "float16"}) {
    SolverConfig c;
    c.sag_free = true;
    c.integrator.lane_layout = layout;
    const HairModel m = makeModel(generated(0.01, 12), c);
    const HairState s = runStill(m, c, kFrame);
    double speed = 0.0;
    for (const Vec3& v : s.velocity) speed = std::max(speed, v.norm());
    std::printf("%s: largest speed after a frame %.3g m/s\n", layout, speed);
    EXPECT_LT(speed, std::string(layout) == "double4" ? 1e-10 : 1e-4) << layout;
  }
}

TEST(SagFree, CurlyStrandsOnAStillHeadKeepTheirGroom) {
  // The default springs and a soft set (the built-in scene's); 2 s on the still head, dry.
  for (int soft = 0; soft < 2; ++soft) {
    SolverConfig c;
    if (soft) {
      c.bend.stiffness_n_m2 = 1.9e-4;
      c.bend.damping_n_s = 5.1e-4;
      c.core.stiffness_n = 0.08;
    }
    const Groom g = generated(0.01, 12);
    const Deviation off = deviation(makeModel(g, c), runStill(makeModel(g, c), c, 2.0));
    c.sag_free = true;
    const HairModel m = makeModel(g, c);
    const HairState s = runStill(m, c, 2.0);
    const Deviation on = deviation(m, s);
    std::printf(
        "[ measured ] %s springs, 2 s: RMS deviation / length %.3g -> %.3g, max %.3g -> %.3g\n",
        soft ? "soft" : "default", off.rms, on.rms, off.max, on.max);
    EXPECT_GT(off.rms, 1e-2);  // the hair does sag without the option
    EXPECT_LT(on.rms, 0.1 * off.rms);
    EXPECT_LT(on.max, 0.1 * off.max);
    EXPECT_EQ(s.warnings.total(), 0u);
  }
}

TEST(SagFree, TheEquilibriumIsStable) {
  // Equilibrium alone is not enough: kicked, the hair must come back to its groom, not to a
  // sagged or fluttering shape. Every particle gets a random 0.1 m/s kick on the still head.
  for (int soft = 0; soft < 2; ++soft) {
    SolverConfig c;
    if (soft) {
      c.bend.stiffness_n_m2 = 1.9e-4;
      c.bend.damping_n_s = 5.1e-4;
      c.core.stiffness_n = 0.08;
    }
    c.sag_free = true;
    const HairModel m = makeModel(generated(0.01, 12), c);
    HairState s = makeState(m, Pose(), Twist());
    std::mt19937 rng(3);
    std::normal_distribution<double> kick(0.0, 0.1 / std::sqrt(3.0));
    for (int st = 0; st < m.strandCount(); ++st)
      for (int i = m.strandBegin(st) + 1; i < m.strandBegin(st) + m.strandSize(st); ++i)
        s.velocity[i] = Vec3(kick(rng), kick(rng), kick(rng));
    HeadMotionConfig still;
    double early = 0.0;
    for (int f = 0; f < 180; ++f) {
      StepInputs in{headPose(still, f * kFrame), headPose(still, (f + 1) * kFrame)};
      step(m, c, in, kFrame, &s, nullptr);
      if (f < 30) early = std::max(early, deviation(m, s).max);
    }
    const Deviation late = deviation(m, s);
    std::printf(
        "[ measured ] %s springs, kicked: max deviation / length %.3g in the first 0.5 s, "
        "%.3g (RMS %.3g) at 3 s\n",
        soft ? "soft" : "default", early, late.max, late.rms);
    EXPECT_LT(late.max, 0.1 * early);
    EXPECT_EQ(s.warnings.total(), 0u);
  }
}

TEST(SagFree, RestStaysRestWithoutGravity) {
  SolverConfig c;
  c.gravity_m_s2.setZero();
  const Groom g = generated(0.01, 6);
  const HairModel off = makeModel(g, c);
  c.sag_free = true;
  const HairModel on = makeModel(g, c);
  EXPECT_EQ(on.rest_edge_m, off.rest_edge_m);
  for (size_t i = 0; i < on.bend_local_target.size(); ++i)
    EXPECT_EQ(on.bend_local_target[i], off.bend_local_target[i]) << i;
  EXPECT_EQ(on.core_rest_m, off.core_rest_m);
  const HairState a = runStill(off, c, 1.0), b = runStill(on, c, 1.0);
  for (size_t i = 0; i < a.position.size(); ++i) EXPECT_EQ(a.position[i], b.position[i]) << i;
}

TEST(SagFree, ValidatedAndRebuiltOnItsInputs) {
  SolverConfig c;
  c.sag_free = true;
  c.bend.stiffness_n_m2 = 0.0;
  std::string why;
  EXPECT_FALSE(c.validate("solver.", &why));
  EXPECT_NE(why.find("solver.sag_free"), std::string::npos) << why;
  c.gravity_m_s2.setZero();
  EXPECT_TRUE(c.validate("solver.", &why)) << why;

  io::SceneConfig scene = io::builtinScene();
  EXPECT_FALSE(scene.solver.sag_free);
  bool rebuild = false;
  ASSERT_TRUE(io::applyParameters({"solver.gravity_m_s2.z"}, {-5.0}, &scene, &rebuild, &why));
  EXPECT_FALSE(rebuild);
  ASSERT_TRUE(io::applyParameters({"solver.sag_free"}, {1.0}, &scene, &rebuild, &why)) << why;
  EXPECT_TRUE(rebuild);
  EXPECT_TRUE(scene.solver.sag_free);
  ASSERT_TRUE(io::applyParameters({"solver.gravity_m_s2.z"}, {-9.81}, &scene, &rebuild, &why));
  EXPECT_TRUE(rebuild);
  ASSERT_TRUE(
      io::applyParameters({"solver.bend.stiffness_n_m2"}, {2.2e-4}, &scene, &rebuild, &why));
  EXPECT_TRUE(rebuild);
  ASSERT_TRUE(io::applyParameters({"solver.bend.damping_n_s"}, {5.6e-4}, &scene, &rebuild, &why));
  EXPECT_FALSE(rebuild);
  EXPECT_FALSE(io::applyParameters({"solver.bend.stiffness_n_m2"}, {0.0}, &scene, &rebuild, &why));
}
