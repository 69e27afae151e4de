// Physical invariants of the curly-hair step (docs/physics.md §2, §9): rest stays rest, a hanging
// chain stretches as its weight says, rigid motion stays rigid, strain stays limited, no
// flutter inside the validated range (and flutter outside it), no energy from nowhere, repairs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "../../src/core/solver_internal.h"
#include "wet_curly_hair/core/diagnostics.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/springs.h"

using namespace wet_curly_hair;

namespace {

constexpr double kFrame = 1.0 / 60.0;

Groom curlyGroom(int strands, int particles = 32) {
  GroomConfig c;
  c.strands = strands;
  c.particles = particles;
  c.jitter = 0.1;
  return generateGroom(c, EllipsoidShape());
}

HairModel makeModel(const Groom& g, const SolverConfig& c) {
  HairModel m;
  std::string why;
  EXPECT_TRUE(buildModel(g, GroomConfig().linear_density_kg_per_m, HeadShape(), c, &m, &why))
      << why;
  return m;
}

/// Runs `seconds` of the motion; calls check(t, state) after every frame.
template <typename Check>
void run(const HairModel& m, const SolverConfig& c, const HeadMotionConfig& motion, double seconds,
         HairState* s, Check check) {
  const int frames = static_cast<int>(std::lround(seconds / kFrame));
  for (int f = 0; f < frames; ++f) {
    StepInputs in{headPose(motion, f * kFrame), headPose(motion, (f + 1) * kFrame)};
    StepStats stats;
    step(m, c, in, kFrame, s, &stats);
    check((f + 1) * kFrame, *s, stats);
  }
}

/// Largest distance, in the head frame, between the hair now and its rest pose, relative to the
/// strand length.
double shapeChange(const HairModel& m, const HairState& s, const Pose& head) {
  double worst = 0.0;
  for (int st = 0; st < m.strandCount(); ++st) {
    for (int i = m.strandBegin(st); i < m.strandBegin(st) + m.strandSize(st); ++i) {
      const double d = (head.applyInverse(s.position[i]) - m.rest_position_head[i]).norm();
      worst = std::max(worst, d / m.strand_length_m[st]);
    }
  }
  return worst;
}

}  // namespace

TEST(Solver, CurlyStrandAtRestStaysAtRest) {
  SolverConfig c;
  c.gravity_m_s2.setZero();
  const HairModel m = makeModel(curlyGroom(3), c);
  HeadMotionConfig still;
  HairState s = makeState(m, Pose(), Twist());
  run(m, c, still, 10.0, &s, [](double, const HairState&, const StepStats&) {});
  EXPECT_LT(shapeChange(m, s, Pose()), 1e-6);
  EXPECT_EQ(s.warnings.total(), 0u);
}

TEST(Solver, HangingStraightChainStretchesAsItsWeightSays) {
  // A straight chain hanging down from a root: edge i carries the weight of the particles below
  // it. Eq. (4) compares whole vectors, k_b (e - t) with |t| = |e0|, so on a straight chain the
  // bending spring is a second axial spring: the stretch is W_i / (k_s + k_b), with the per-length
  // constants k_s = EA / L, k_b = B / (L alpha_b^2) and W_i the weight below edge i: rho g L per
  // interior particle, half that at the tip (lumped masses), rho g L (n - 1.5 - i).
  // Core spring off (its smoothed curve would share the load unevenly).
  Groom g;
  const int n = 32;
  const double edge = 0.008;
  for (int i = 0; i < n; ++i) g.points.push_back(Vec3(0, 0, -0.2 - edge * i));
  g.strand_offsets = {0, static_cast<uint32_t>(n)};
  g.root_normals = {Vec3(0, 0, -1)};
  SolverConfig c;
  c.core.stiffness_n = 0.0;
  c.core.damping_n_s = 0.0;
  c.collision.head_enabled = false;
  const HairModel m = makeModel(g, c);
  HairState s = makeState(m, Pose(), Twist());
  run(m, c, HeadMotionConfig(), 6.0, &s, [](double, const HairState&, const StepStats&) {});
  const double rho = GroomConfig().linear_density_kg_per_m;
  const double alpha = c.bend.smoothing_length_m;  // 6 edges: above the flutter bound of 4
  const double k =
      c.stretch.axial_stiffness_n / edge + c.bend.stiffness_n_m2 / (edge * alpha * alpha);
  for (int i = 0; i + 1 < n; ++i) {
    const double expected = rho * 9.81 * edge * (n - 1.5 - i) / k;
    const double got = (s.position[i + 1] - s.position[i]).norm() - edge;
    EXPECT_NEAR(got, expected, 0.01 * expected) << "edge " << i;
  }
}

TEST(Solver, RigidTranslationKeepsTheShape) {
  // In double the shape holds to round-off. In float, positions are known to 2^-24 of their
  // distance from the head (2e-8 m at 0.36 m, 8e-8 of a 25 cm strand): the springs turn that
  // rounding into force noise on every substep, a floor of ~1e-6 of the strand length that does
  // not grow (measured 1.1e-6 at most over 2 s, 0.6-0.9e-6 at every quarter second). Bound: 25
  // times that resolution.
  for (const char* layout : {"double4", "float8"}) {
    SolverConfig c;
    c.integrator.lane_layout = layout;
    c.gravity_m_s2.setZero();
    const HairModel m = makeModel(curlyGroom(4), c);
    HeadMotionConfig motion;
    motion.type = "linear";
    motion.speed_m_s = 0.7;
    motion.axis = Vec3(1, 2, -0.5);
    HairState s = makeState(m, headPose(motion, 0.0), headTwist(motion, 0.0));
    double worst = 0.0;
    run(m, c, motion, 2.0, &s, [&](double t, const HairState& st, const StepStats&) {
      worst = std::max(worst, shapeChange(m, st, headPose(motion, t)));
    });
    const double resolution = std::ldexp(0.36, -24) / 0.25;
    EXPECT_LT(worst, std::string(layout) == "double4" ? 1e-12 : 25.0 * resolution) << layout;
  }
}

namespace {

/// The explicit method at 2e-4 s, the reference integrator: the claims about the model below
/// (co-rotation, energy) were measured with it; an implicit integrator adds its own time error
/// on top (the bench's speed-against-error chart measures that: docs/performance.md).
SolverConfig explicitReference() {
  SolverConfig c;
  c.integrator.method = "explicit";
  c.integrator.substep_s = 2e-4;
  return c;
}

/// Largest head-frame shape change over `seconds` of a steady spin at rate_hz, gravity off, the
/// hair started co-rotating; springs scaled by `stiffness_scale` (damping by its square root, so
/// the damping ratios stay, and the substep by its inverse square root, so stability does).
double spinShapeChange(double rate_hz, double stiffness_scale, double seconds) {
  SolverConfig c = explicitReference();
  c.gravity_m_s2.setZero();
  for (double* k : {&c.stretch.axial_stiffness_n, &c.bend.stiffness_n_m2, &c.core.stiffness_n})
    *k *= stiffness_scale;
  for (double* d : {&c.stretch.damping_n_s, &c.bend.damping_n_s, &c.core.damping_n_s})
    *d *= std::sqrt(stiffness_scale);
  c.integrator.substep_s /= std::sqrt(stiffness_scale);
  const HairModel m = makeModel(curlyGroom(4), c);
  HeadMotionConfig motion;
  motion.type = "spin";
  motion.rate_hz = rate_hz;
  HairState s = makeState(m, headPose(motion, 0.0), headTwist(motion, 0.0));
  double worst = 0.0;
  run(m, c, motion, seconds, &s, [&](double t, const HairState& st, const StepStats&) {
    worst = std::max(worst, shapeChange(m, st, headPose(motion, t)));
  });
  return worst;
}

}  // namespace

TEST(Solver, SteadySpinCorotatingKeepsTheShape) {
  // Spinning hair is loaded by the centrifugal force m w^2 r, so it bends elastically by an
  // amount proportional to w^2 / k; nothing else may change its shape in the head frame. At
  // 0.25 rev/s the default (soft) hair bends by about 0.2 % of its length (0.4 % at the first
  // overshoot); hair 5x stiffer stays within 1e-3 of the strand length over 5 s.
  EXPECT_LT(spinShapeChange(0.25, 5.0, 5.0), 1e-3);
  // With the default springs the change is elastic: it scales as w^2 (a quarter at half the rate).
  const double full = spinShapeChange(0.25, 1.0, 5.0);
  const double half = spinShapeChange(0.125, 1.0, 5.0);
  EXPECT_NEAR(full / half, 4.0, 0.4) << "full " << full << " half " << half;
  EXPECT_LT(full, 1e-2);
}

TEST(Solver, EdgeStrainNeverExceedsTheLimit) {
  // Hard driving: fast spin under gravity, then a shake; the limiter holds every frame.
  SolverConfig c;
  const HairModel m = makeModel(curlyGroom(20), c);
  for (const char* spec : {"spin:rate_hz=2", "shake:freq_hz=4,amplitude_rad=0.6",
                           "teleport:distance_m=0.3,start_s=0.2"}) {
    HeadMotionConfig motion;
    std::string why;
    ASSERT_TRUE(parseMotionSpec(spec, &motion, &why)) << why;
    HairState s = makeState(m, headPose(motion, 0.0), headTwist(motion, 0.0));
    run(m, c, motion, 1.0, &s, [&](double t, const HairState& st, const StepStats&) {
      EXPECT_LE(edgeStrain(m, st).max, c.stretch.strain_limit + 1e-9) << spec << " t=" << t;
    });
  }
}

namespace {

/// Max particle speed after `seconds` of a single curly strand (32 particles, edges L = 25 cm /
/// 31) hanging still under gravity, with alpha_b = alpha_edges L and c_b at damping_ratio of
/// critical, 2 sqrt(k_b rho L). buildModel's raise to the flutter bounds only with `stabilize`.
double settledSpeed(double alpha_edges, double damping_ratio, double seconds, double substep = 2e-4,
                    bool stabilize = false) {
  SolverConfig c;
  GroomConfig gc;
  gc.strands = 1;
  gc.jitter = 0.0;
  const double l = gc.length_m / (gc.particles - 1), rho = gc.linear_density_kg_per_m;
  const double alpha = alpha_edges * l;
  c.bend.smoothing_length_m = alpha;
  const double k_b = c.bend.stiffness_n_m2 / (l * alpha * alpha);
  c.bend.damping_n_s = damping_ratio * 2.0 * std::sqrt(k_b * rho * l) * l;  // c_b = D_b / L
  c.integrator.substep_s = substep;
  c.collision.head_enabled = false;
  HairModel m;
  const Groom g = generateGroom(gc, EllipsoidShape());
  std::string why;
  if (stabilize)
    EXPECT_TRUE(buildModel(g, rho, HeadShape(), c, &m, &why)) << why;
  else
    buildModelUnchecked(g, rho, HeadShape(), c, &m);
  HairState s = makeState(m, Pose(), Twist());
  run(m, c, HeadMotionConfig(), seconds, &s, [](double, const HairState&, const StepStats&) {});
  return maxSpeed(m, s);
}

}  // namespace

TEST(Solver, BendingFlutterNoneWithDefaults) {
  SolverConfig c;
  c.collision.head_enabled = false;
  GroomConfig gc;
  gc.strands = 1;
  gc.jitter = 0.0;
  const HairModel m = makeModel(generateGroom(gc, EllipsoidShape()), c);
  HairState s = makeState(m, Pose(), Twist());
  run(m, c, HeadMotionConfig(), 3.0, &s, [](double, const HairState&, const StepStats&) {});
  EXPECT_LT(maxSpeed(m, s), 1e-3);
}

TEST(Solver, BendingFlutterBoundOnBothSides) {
  // Inside the validated range (alpha_b >= kMinBendSmoothingEdges, damping ratio >=
  // kMinBendDampingRatio) a hanging curl settles; outside it, it self-excites at any step size.
  EXPECT_LT(settledSpeed(kMinBendSmoothingEdges, 1.0, 3.0), 1e-3);
  EXPECT_LT(settledSpeed(kMinBendSmoothingEdges, 2.0 * kMinBendDampingRatio, 4.0), 1e-3);
  EXPECT_GT(settledSpeed(2.0, 1.0, 3.0), 0.1)
      << "short smoothing flutters even when critically damped";
  EXPECT_GT(settledSpeed(2.0, 1.0, 3.0, 5e-5), 0.1) << "and at a 4x smaller step";
  EXPECT_GT(settledSpeed(kMinBendSmoothingEdges, 0.25, 3.0), 0.1) << "too little damping flutters";
  // buildModel raises what would flutter to the bounds (a resolution too coarse for the
  // configured alpha_b and c_b), so that both settle.
  EXPECT_LT(settledSpeed(2.0, 1.0, 3.0, 2e-4, true), 1e-3);
  EXPECT_LT(settledSpeed(kMinBendSmoothingEdges, 0.25, 4.0, 2e-4, true), 1e-3);
}

TEST(Solver, BuildModelRaisesBendingToTheFlutterBoundsAndCountsIt) {
  GroomConfig gc;
  gc.strands = 3;
  gc.particles = 16;  // 17 mm edges: the default alpha_b of 48 mm is 2.9 of them
  const Groom g = generateGroom(gc, EllipsoidShape());
  SolverConfig c;
  HairModel m;
  std::string why;
  ASSERT_TRUE(buildModel(g, gc.linear_density_kg_per_m, HeadShape(), c, &m, &why)) << why;
  EXPECT_EQ(m.bend_stabilized_strands, 3);
  for (int s = 0; s < 3; ++s) {
    const double l = m.mean_edge_m[s];
    EXPECT_NEAR(m.beta_bend[s], smoothingBeta(l, kMinBendSmoothingEdges * l), 1e-15);
    const double alpha = kMinBendSmoothingEdges * l;
    EXPECT_NEAR(m.bend_k[s], c.bend.stiffness_n_m2 / (l * alpha * alpha), 1e-12 * m.bend_k[s]);
    const double critical = 2.0 * std::sqrt(m.bend_k[s] * gc.linear_density_kg_per_m * l);
    EXPECT_GE(m.bend_c[s], kMinBendDampingRatio * critical * (1.0 - 1e-12));
  }
  gc.particles = 64;  // 4 mm edges: the defaults are inside both bounds, nothing raised
  ASSERT_TRUE(buildModel(generateGroom(gc, EllipsoidShape()), gc.linear_density_kg_per_m,
                         HeadShape(), c, &m, &why))
      << why;
  EXPECT_EQ(m.bend_stabilized_strands, 0);
  EXPECT_NEAR(m.bend_c[0], c.bend.damping_n_s / m.mean_edge_m[0], 1e-12);
  // With little bend damping (a tenth of the default) it is raised to exactly half of critical,
  // at any resolution where it falls below it, and counted even where alpha_b is long enough.
  c.bend.damping_n_s *= 0.1;
  ASSERT_TRUE(buildModel(generateGroom(gc, EllipsoidShape()), gc.linear_density_kg_per_m,
                         HeadShape(), c, &m, &why))
      << why;
  EXPECT_EQ(m.bend_stabilized_strands, 3);
  for (int s = 0; s < 3; ++s) {
    const double critical =
        2.0 * std::sqrt(m.bend_k[s] * gc.linear_density_kg_per_m * m.mean_edge_m[s]);
    EXPECT_NEAR(m.bend_c[s], kMinBendDampingRatio * critical, 1e-12 * critical);
  }
}

TEST(Solver, EnergyDoesNotGrowWithoutDriving) {
  // Default damping, still head, curls dropped under gravity: total energy (kinetic + gravity +
  // springs) at each whole second is not above the previous second's while the hair moves.
  //
  // Measured finding (docs/physics.md §2.6 "Energy"): the bending force of eq. (4) is not the
  // gradient of an energy (frames come from the current curve; BendForceIsNotAnEnergyGradient
  // below). Once the hair has nearly settled (kinetic energy below 1e-6 J, speeds of mm/s) it
  // creeps toward the equilibrium of that force, which is not the minimum of the frame-fixed
  // energy: with the per-length parameters the total rises by 3.1e-6 J, 6e-5 of itself, between
  // t = 2 s and 3 s (kinetic 1.4e-7 -> 3e-9 J; the gravity energy rises, the springs' falls),
  // then stays flat to 1e-9 J. That phase is asserted separately, with its measured size (bound
  // about 1.5 times it), so a change is seen either way; the energy-consistent bending force of
  // issue 16 is what removes it. Both the reference integrator and the default (midpoint, which
  // has no numerical damping).
  for (const SolverConfig& c : {explicitReference(), SolverConfig()}) {
    const HairModel m = makeModel(curlyGroom(20), c);
    HeadMotionConfig still;
    HairState s = makeState(m, Pose(), Twist());
    EnergyParts previous = energy(m, c, Pose(), &s);
    double creep = 0.0;
    int frame = 0;
    run(m, c, still, 10.0, &s, [&](double t, const HairState&, const StepStats&) {
      if (++frame % 60 != 0) return;
      const EnergyParts e = energy(m, c, Pose(), &s);
      if (previous.kinetic > 1e-6) {
        EXPECT_LE(e.total(), previous.total())
            << c.integrator.method << ": energy grew in the second ending at t=" << t;
      } else {
        creep = std::max(creep, e.total() - previous.total());
      }
      previous = e;
    });
    EXPECT_LT(creep, 1e-4 * previous.total())
        << c.integrator.method << ": post-settling creep of the pseudo-energy";
    if (c.integrator.method == "explicit") {
      EXPECT_LT(previous.kinetic, 1e-12);
    } else {
      // Midpoint has no numerical damping: the hair settles to the float lanes' round-off floor
      // (measured over 40 s: flat between 2.1e-12 and 2.8e-12 J, not growing). Bound: every
      // particle moving by one float ulp of the strand length per substep.
      double mass = 0.0;
      for (double mi : m.mass_kg) mass += mi;
      const double ulp_speed =
          0.25 * std::numeric_limits<float>::epsilon() / c.integrator.substep_s;
      EXPECT_LT(previous.kinetic, 0.5 * mass * ulp_speed * ulp_speed);
    }
  }
}

TEST(Solver, WithTheFrameAndFilterGradientsEnergyNeverGrows) {
  // The same 20 curls with the bending force's part through the frames (BendConfig::
  // frame_gradient) and the core force through the filter's transpose (CoreSpringConfig::
  // filter_gradient): both are gradients of the energies the diagnostics sum, so with a still
  // head and damping the total never rises from one second to the next, not even by the creep
  // above. Measured (double4): it falls to 2 s, then stays flat to 1e-16 J of 0.048 J; with the
  // bending part alone it still rose by 4e-9 J between 2 and 3 s (the core spring's, local on
  // edge i, is not a gradient either). Bound: 1e-12 of the total, round-off. The explicit method
  // at 2e-4 s, the implicit ones at 5e-4 s: they solve with the frames and filter
  // held and correct these parts at the substep's predicted middle (correctGradientParts); with
  // them taken at the start of the substep only, midpoint, which has no numerical damping, did
  // not settle (measured: rise 1.1e-4 J, kinetic energy 4e-4 J after 8 s; docs/physics.md §2.6).
  // At the default 1e-3 s the implicit methods' total rises once, by 5e-6 to 1.5e-5 J, between
  // 1 and 2 s, and settles 0.5-1.4 % above explicit's (docs/physics.md §2.6: the options want
  // 5e-4 s).
  for (const char* method : {"explicit", "backward_euler", "theta", "midpoint"}) {
    SolverConfig c = explicitReference();
    if (std::string(method) != "explicit") {
      c.integrator = IntegratorConfig();
      c.integrator.substep_s = 5e-4;
    }
    c.integrator.method = method;
    c.bend.frame_gradient = true;
    c.core.filter_gradient = true;
    c.integrator.lane_layout = "double4";
    const HairModel m = makeModel(curlyGroom(20), c);
    HairState s = makeState(m, Pose(), Twist());
    double previous = energy(m, c, Pose(), &s).total(), worst_rise = -1.0;
    int frame = 0;
    run(m, c, HeadMotionConfig(), 8.0, &s, [&](double, const HairState&, const StepStats&) {
      if (++frame % 60 != 0) return;
      const double e = energy(m, c, Pose(), &s).total();
      worst_rise = std::max(worst_rise, e - previous);
      previous = e;
    });
    std::printf("%s: worst rise %.3g J of %.3g J, kinetic at the end %.3g J\n", method, worst_rise,
                previous, energy(m, c, Pose(), &s).kinetic);
    EXPECT_LE(worst_rise, 1e-12 * previous) << method;
    EXPECT_LT(energy(m, c, Pose(), &s).kinetic, 1e-12) << method;
  }
}

TEST(Solver, WithTheGradientsRestStaysRestAndRigidMotionStaysRigid) {
  // The parts through the frames and the filter vanish at the rest targets (the energy's
  // minimum) and move with the head: the curls keep their groom without gravity, on a still head
  // and carried.
  SolverConfig c;
  c.bend.frame_gradient = true;
  c.core.filter_gradient = true;
  c.gravity_m_s2.setZero();
  c.integrator.lane_layout = "double4";
  const HairModel m = makeModel(curlyGroom(3), c);
  HairState s = makeState(m, Pose(), Twist());
  run(m, c, HeadMotionConfig(), 2.0, &s, [](double, const HairState&, const StepStats&) {});
  EXPECT_LT(shapeChange(m, s, Pose()), 1e-9);
  HeadMotionConfig motion;
  motion.type = "linear";
  motion.speed_m_s = 0.7;
  motion.axis = Vec3(1, 2, -0.5);
  HairState moved = makeState(m, headPose(motion, 0.0), headTwist(motion, 0.0));
  double worst = 0.0;
  run(m, c, motion, 1.0, &moved, [&](double t, const HairState& st, const StepStats&) {
    worst = std::max(worst, shapeChange(m, st, headPose(motion, t)));
  });
  EXPECT_LT(worst, 1e-9);
}

TEST(Solver, BendForceIsNotAnEnergyGradient) {
  // Why the energy above can creep: the applied bending force k_b (e - t) holds the frames fixed,
  // but the frames (so the targets t) move with the particles. Finite differences of the bend
  // energy through the frames differ from the applied force on a bent strand.
  SolverConfig c;
  c.gravity_m_s2.setZero();
  GroomConfig gc;
  gc.strands = 1;
  gc.particles = 12;
  gc.jitter = 0.0;
  const HairModel m = makeModel(generateGroom(gc, EllipsoidShape()), c);
  HairState s = makeState(m, Pose(), Twist());
  for (int i = 1; i < m.particleCount(); ++i)
    s.position[i] += Vec3(0.001 * std::sin(i), 0.0007 * i, 0.0);
  auto bend = [&]() { return energy(m, c, Pose(), &s).bend; };
  const int i = 5;
  Vec3 fd_force;
  for (int k = 0; k < 3; ++k) {
    const double h = 1e-8, x0 = s.position[i][k];
    s.position[i][k] = x0 + h;
    const double ep = bend();
    s.position[i][k] = x0 - h;
    const double em = bend();
    s.position[i][k] = x0;
    fd_force[k] = -(ep - em) / (2 * h);
  }
  // The applied force on particle i: +f_i from its own edge, -f_{i-1} from the previous one.
  Vec3List d(m.particleCount() - 1);
  Mat3List frames(m.particleCount() - 1);
  smoothDifferences(s.position.data(), m.particleCount(), m.beta_bend[0], d.data());
  transportFrames(m.root_frame_head[0], d.data(), m.particleCount() - 1, frames.data());
  auto f = [&](int e) {
    return bendForce(s.position[e + 1] - s.position[e], frames[e] * m.bend_local_target[e],
                     m.bend_k[0]);
  };
  const Vec3 applied = f(i) - f(i - 1);
  // Measured: 2.4 % apart here; finite differences are good to ~1e-6, so 1 % is a clear gap.
  EXPECT_GT((applied - fd_force).norm(), 0.01 * fd_force.norm())
      << "applied " << applied.transpose() << " gradient " << fd_force.transpose();
}

TEST(Solver, NonFiniteStrandIsRepairedAndCountedAlone) {
  // Two broken strands, on different threads when there are two (the check runs on every
  // thread and counts per thread): both repaired and counted, the others untouched.
  for (int threads : {1, 2}) {
    SolverConfig c;
    c.integrator.threads = threads;
    const HairModel m = makeModel(curlyGroom(4), c);
    HairState s = makeState(m, Pose(), Twist());
    HairState reference = makeState(m, Pose(), Twist());
    StepInputs in;
    StepStats stats;
    step(m, c, in, kFrame, &s, &stats);
    step(m, c, in, kFrame, &reference, &stats);
    s.velocity[m.strandBegin(1) + 5] = Vec3(std::nan(""), 0, 0);
    s.position[m.strandBegin(3) + 2] = Vec3(0, std::numeric_limits<double>::infinity(), 0);
    StepStats repaired;
    step(m, c, in, kFrame, &s, &repaired);
    step(m, c, in, kFrame, &reference, &stats);
    EXPECT_EQ(repaired.repaired_strands, 2u) << threads;
    EXPECT_EQ(s.warnings.nonfinite_repairs, 2u) << threads;
    EXPECT_GT(s.warnings.nonfinite_values, 1u) << threads;
    for (const Vec3& p : s.position) EXPECT_TRUE(p.allFinite());
    // The other strands never notice.
    for (int st : {0, 2})
      for (int i = m.strandBegin(st); i < m.strandBegin(st) + m.strandSize(st); ++i)
        EXPECT_EQ(s.position[i], reference.position[i]) << threads;
  }
}

/// The head moving between two poses over a frame: 5 mm along x and 0.05 rad about z, well under
/// the teleport bounds.
StepInputs movingHead() {
  StepInputs in;
  in.head_end.translation = Vec3(0.005, 0.0, 0.0);
  in.head_end.rotation = Quat(Eigen::AngleAxisd(0.05, Vec3::UnitZ()));
  return in;
}

/// A copy of m whose strand s blows up in any step: a NaN stretch stiffness on one edge, laid in
/// the lanes too.
HairModel withNanStretchStiffness(const HairModel& m, int s) {
  HairModel broken = m;
  broken.stretch_k[broken.strandBegin(s) + 5] = std::nan("");
  relayModelLanes(&broken);
  return broken;
}

TEST(Solver, StrandThatBlowsUpRestartsFromWhereItStartedCarriedByTheHead) {
  // A NaN stretch stiffness in strand 2 (the state healthy, the step's result not): the strand
  // takes the state it started the step from, carried rigidly from the start pose to the end
  // pose, to the bit; the other strands step as if nothing happened.
  for (int threads : {1, 2}) {
    SolverConfig c;
    c.integrator.threads = threads;
    const HairModel m = makeModel(curlyGroom(4), c);
    const HairModel broken = withNanStretchStiffness(m, 2);
    HairState s = makeState(m, Pose(), Twist());
    StepStats stats;
    step(m, c, StepInputs(), kFrame, &s, &stats);  // a step in, so that v is not the rest's
    HairState reference = s;
    const HairState start = s;
    const StepInputs in = movingHead();
    StepStats repaired;
    step(broken, c, in, kFrame, &s, &repaired);
    step(m, c, in, kFrame, &reference, &stats);
    EXPECT_EQ(repaired.repaired_strands, 1u) << threads;
    EXPECT_EQ(repaired.nonfinite_repairs, 1u) << threads;
    EXPECT_EQ(repaired.rest_shape_repairs, 0u) << threads;
    for (int i = m.strandBegin(2); i < m.strandBegin(2) + m.strandSize(2); ++i) {
      EXPECT_EQ(s.position[i], in.head_end.apply(in.head_start.applyInverse(start.position[i])));
      EXPECT_EQ(s.velocity[i],
                in.head_end.rotate(in.head_start.rotation.conjugate() * start.velocity[i]));
    }
    for (int st : {0, 1, 3})
      for (int i = m.strandBegin(st); i < m.strandBegin(st) + m.strandSize(st); ++i) {
        EXPECT_EQ(s.position[i], reference.position[i]) << threads;
        EXPECT_EQ(s.velocity[i], reference.velocity[i]) << threads;
      }
  }
}

TEST(Solver, StrandWrittenUnhealthyBetweenStepsTakesItsRestShape) {
  // A caller's NaN in strand 1's state: nothing healthy to restart from, so the strand takes its
  // rest shape carried by the head, moving with it, counted apart.
  SolverConfig c;
  const HairModel m = makeModel(curlyGroom(4), c);
  HairState s = makeState(m, Pose(), Twist());
  StepStats stats;
  step(m, c, StepInputs(), kFrame, &s, &stats);
  s.velocity[m.strandBegin(1) + 5] = Vec3(std::nan(""), 0, 0);
  const StepInputs in = movingHead();
  StepStats repaired;
  step(m, c, in, kFrame, &s, &repaired);
  EXPECT_EQ(repaired.repaired_strands, 1u);
  EXPECT_EQ(repaired.rest_shape_repairs, 1u);
  EXPECT_EQ(s.warnings.rest_shape_repairs, 1u);
  for (int i = m.strandBegin(1); i < m.strandBegin(1) + m.strandSize(1); ++i) {
    const Vec3& rest = m.rest_position_head[i];
    EXPECT_EQ(s.position[i], in.head_end.apply(rest));
    // The head's velocity over the frame (its substeps' total length: kFrame to round-off).
    const Vec3 carried = (in.head_end.apply(rest) - in.head_start.apply(rest)) / kFrame;
    EXPECT_LT((s.velocity[i] - carried).norm(), 1e-12 * carried.norm());
  }
}

TEST(Solver, CoupledStrandThatBlowsUpRestartsFromItsLastSubstepsStart) {
  // With hair contact the strands step a substep at a time and every substep is checked: the
  // broken strand restarts, healthy, from where its substep started (not its rest shape).
  SolverConfig c;
  c.hair_contact.enabled = true;
  c.integrator.substep_s = kFrame / 3.0;
  const HairModel m = makeModel(curlyGroom(4), c);
  const HairModel broken = withNanStretchStiffness(m, 2);
  HairState s = makeState(m, Pose(), Twist());
  StepStats stats;
  step(m, c, StepInputs(), kFrame, &s, &stats);
  StepStats repaired;
  step(broken, c, movingHead(), kFrame, &s, &repaired);
  EXPECT_GE(repaired.repaired_strands, 1u);
  EXPECT_EQ(repaired.rest_shape_repairs, 0u);
  for (const Vec3& p : s.position) EXPECT_TRUE(p.allFinite());
  for (const Vec3& v : s.velocity) EXPECT_TRUE(v.allFinite());
  for (int st = 0; st < m.strandCount(); ++st) EXPECT_TRUE(detail::strandStrainOk(m, c, st, s));
}

TEST(Solver, SubstepsSplitTheFrameEvenly) {
  SolverConfig c;
  c.integrator.substep_s = 2e-4;
  const HairModel m = makeModel(curlyGroom(2), c);  // explicit bound 2.3e-4 s at 32 particles
  EXPECT_EQ(substepCount(c, 1.0 / 60.0), 84);
  EXPECT_EQ(substepCount(c, 2e-4), 1);
  EXPECT_EQ(substepCount(c, 0.0), 0);
}

TEST(Solver, HairContactKeepsItsOwnLongestSubstep) {
  // With contact on, no substep is longer than hair_contact.max_substep_s (5e-4 s by default)
  // nor than the integrator's: the contact split was measured and tested at 5e-4 s, and rings
  // at the default 1e-3 s (test_hair_contact, AStiffContactDoesNotRing).
  SolverConfig c;
  EXPECT_EQ(substepCount(c, 1.0 / 60.0), 17);  // 1e-3 s
  c.hair_contact.enabled = true;
  EXPECT_EQ(substepCount(c, 1.0 / 60.0), 34);  // 5e-4 s
  c.integrator.substep_s = 2.5e-4;             // a shorter integrator substep stands
  EXPECT_EQ(substepCount(c, 1.0 / 60.0), 67);
  c.hair_contact.max_substep_s = 1.0 / 240.0;
  EXPECT_EQ(substepCount(c, 1.0 / 60.0), 67);
  c.integrator.substep_s = 1.0 / 120.0;
  EXPECT_EQ(substepCount(c, 1.0 / 60.0), 4);
  std::string why;
  c.hair_contact.max_substep_s = 0.0;
  EXPECT_FALSE(c.validate("solver.", &why));
  EXPECT_NE(why.find("solver.hair_contact.max_substep_s"), std::string::npos) << why;
}

TEST(Solver, UpdatedSpringConstantsEqualARebuild) {
  // What set_parameters applies without a rebuild (stiffness, damping, curl weight) gives the
  // model a rebuild with the new values would give; an invalid config changes nothing.
  SolverConfig a, b;
  b.stretch.axial_stiffness_n *= 2.0;
  b.stretch.damping_n_s *= 0.5;
  b.bend.stiffness_n_m2 *= 3.0;
  b.bend.damping_n_s *= 0.1;  // below the flutter bound at 16 particles: raised in both
  b.core.stiffness_n *= 0.25;
  b.core.damping_n_s = 0.0;
  b.curl.weight_n *= 4.0;
  const Groom g = curlyGroom(3, 16);
  HairModel updated = makeModel(g, a);
  std::string why;
  ASSERT_TRUE(updateSpringConstants(b, &updated, &why)) << why;
  const HairModel rebuilt = makeModel(g, b);
  EXPECT_EQ(updated.stretch_k, rebuilt.stretch_k);
  EXPECT_EQ(updated.stretch_c, rebuilt.stretch_c);
  EXPECT_EQ(updated.bend_k, rebuilt.bend_k);
  EXPECT_EQ(updated.bend_c, rebuilt.bend_c);
  EXPECT_EQ(updated.core_k, rebuilt.core_k);
  EXPECT_EQ(updated.core_c, rebuilt.core_c);
  EXPECT_EQ(updated.curl_k, rebuilt.curl_k);
  EXPECT_EQ(updated.explicit_substep_bound_s, rebuilt.explicit_substep_bound_s);
  EXPECT_EQ(updated.max_damping_per_mass, rebuilt.max_damping_per_mass);
  EXPECT_EQ(updated.bend_stabilized_strands, rebuilt.bend_stabilized_strands);
  b.stretch.axial_stiffness_n = -1.0;
  const HairModel before = updated;
  EXPECT_FALSE(updateSpringConstants(b, &updated, &why));
  EXPECT_NE(why.find("solver.stretch.axial_stiffness_n"), std::string::npos) << why;
  EXPECT_EQ(updated.stretch_k, before.stretch_k);
}

TEST(Solver, ExplicitSubstepPastTheBoundIsRefused) {
  // symplectic Euler is stable for h omega_max < 2; omega_max^2 <= max_i 2 (k_{i-1} + k_i) / m_i
  // grows as 1 / L^2 with per-length parameters, so the explicit bound shrinks with the edge. A
  // substep past it is refused with the bound named (never shortened behind the user's back);
  // the implicit methods take any substep at any resolution.
  SolverConfig c;
  c.integrator.method = "explicit";
  c.integrator.substep_s = 1e-5;
  for (int particles : {32, 64, 128}) {
    const Groom g = curlyGroom(2, particles);
    const HairModel m = makeModel(g, c);
    double lambda = 0.0;
    for (int s = 0; s < m.strandCount(); ++s) {
      const double shared = m.bend_k[s] + m.core_k[s] + m.curl_k[s];
      for (int i = 1; i < m.strandSize(s); ++i) {
        const int k = m.strandBegin(s) + i;
        const double out = i + 1 < m.strandSize(s) ? m.stretch_k[k] + shared : 0.0;
        lambda = std::max(lambda, 2.0 * (m.stretch_k[k - 1] + shared + out) / m.mass_kg[k]);
      }
    }
    const double bound = kExplicitStabilityFraction * 2.0 / std::sqrt(lambda);
    EXPECT_NEAR(m.explicit_substep_bound_s, bound, 1e-12 * bound);
    if (particles >= 64) {
      EXPECT_LT(bound, 2e-4) << particles;
    }
    std::string why;
    HairModel out = m;
    const HairModel before = out;
    c.integrator.substep_s = bound * 0.999;
    EXPECT_TRUE(buildModel(g, GroomConfig().linear_density_kg_per_m, HeadShape(), c, &out, &why))
        << why;
    c.integrator.substep_s = bound * 1.01;
    out = before;
    EXPECT_FALSE(buildModel(g, GroomConfig().linear_density_kg_per_m, HeadShape(), c, &out, &why));
    EXPECT_NE(why.find("solver.integrator.substep_s"), std::string::npos) << why;
    char named[32];
    std::snprintf(named, sizeof named, "%.3g s", bound);
    EXPECT_NE(why.find(named), std::string::npos) << why << " should name " << named;
    EXPECT_EQ(out.stretch_k, before.stretch_k);
    EXPECT_EQ(substepCount(c, 1.0 / 60.0),
              static_cast<int>(std::ceil(1.0 / 60.0 / c.integrator.substep_s - 1e-9)));
    for (const char* method : {"backward_euler", "midpoint", "theta"}) {
      c.integrator.method = method;
      c.integrator.substep_s = 2e-3;
      EXPECT_TRUE(checkExplicitSubstep(m, c, &why)) << method;
    }
    c.integrator.method = "explicit";
    c.integrator.substep_s = 1e-5;
  }
  // A stiffer stretch spring lowers the bound under the substep: the update is refused, the
  // model unchanged.
  HairModel m = makeModel(curlyGroom(2), c);
  c.integrator.substep_s = m.explicit_substep_bound_s * 0.9;
  SolverConfig stiffer = c;
  stiffer.stretch.axial_stiffness_n *= 4.0;
  const HairModel before = m;
  std::string why;
  EXPECT_FALSE(updateSpringConstants(stiffer, &m, &why));
  EXPECT_NE(why.find("solver.integrator.substep_s"), std::string::npos) << why;
  EXPECT_EQ(m.stretch_k, before.stretch_k);
  EXPECT_EQ(m.explicit_substep_bound_s, before.explicit_substep_bound_s);
  EXPECT_TRUE(updateSpringConstants(c, &m, &why)) << why;
}

TEST(Solver, HairDrapesOnTheHeadWithoutPassingThrough) {
  SolverConfig c;
  const HairModel m = makeModel(curlyGroom(30), c);
  HeadMotionConfig nod;
  nod.type = "nod";
  HairState s = makeState(m, Pose(), Twist());
  run(m, c, nod, 2.0, &s, [&](double t, const HairState& st, const StepStats&) {
    EXPECT_LT(maxHeadPenetration(m, st, headPose(nod, t)), 1e-4) << t;
  });
}

/// One edge from a root on a sphere (R = 0.1 m) to a particle the collision pushes out radially,
/// 3 rest lengths from the root: the strain limit then pulls it back along the chord, which
/// runs inside the sphere (sag c^2 / 8R ~ 1.1 mm at the middle of a 3 cm chord, more than the
/// 1 mm offset). No springs, gravity or velocity: only the two constraints act.
struct ChordCase {
  static constexpr double kRadius = 0.1;
  static constexpr double kRest = 0.01;
  HairModel model;
  SolverConfig config;
  HairState state;
  HeadShape head;
  explicit ChordCase(int rounds) {
    head.ellipsoid.radii_m = Vec3::Constant(kRadius);
    const Vec3 root(0, 0, kRadius);
    Groom g;
    g.strand_offsets = {0, 2};
    g.points = {root, root + Vec3(0, 0, kRest)};
    g.root_normals = {Vec3::UnitZ()};
    config.stretch.axial_stiffness_n = 0.0;
    config.stretch.damping_n_s = 0.0;
    config.bend.stiffness_n_m2 = 0.0;
    config.bend.damping_n_s = 0.0;
    config.core.stiffness_n = 0.0;
    config.core.damping_n_s = 0.0;
    config.curl.weight_n = 0.0;
    config.gravity_m_s2 = Vec3::Zero();
    config.stiffness.global_factor = 1.0;
    config.integrator.substep_s = kFrame;
    config.collision.constraint_rounds = rounds;
    buildModelUnchecked(g, 1e-4, head, config, &model);
    state = makeState(model, Pose(), Twist());
    // 0.3 rad down the sphere from the root (chord ~3 cm), 5 mm under the surface.
    const double phi = 0.3;
    state.position[1] = (kRadius - 0.005) * Vec3(std::sin(phi), 0, std::cos(phi));
  }
  double surfaceDistance() const {
    Vec3 n;
    return head.distance(state.position[1], &n);
  }
  double strain() const { return (state.position[1] - state.position[0]).norm() / kRest - 1.0; }
};

TEST(Solver, CollisionAndStrainLimitRoundsLeaveNothingInside) {
  StepStats stats;
  ChordCase one_round(0);
  step(one_round.model, one_round.config, StepInputs(), kFrame, &one_round.state, &stats);
  // One round: the limit runs last and leaves the particle under the surface.
  EXPECT_LT(one_round.surfaceDistance(), -1e-4);
  EXPECT_NEAR(one_round.strain(), one_round.config.stretch.strain_limit, 1e-9);
  EXPECT_EQ(stats.constraint_rounds, 0u);

  ChordCase rounds(3);
  step(rounds.model, rounds.config, StepInputs(), kFrame, &rounds.state, &stats);
  // Three more rounds: outside (within the 1 mm cushion is allowed), strain still limited.
  EXPECT_GT(rounds.surfaceDistance(), 0.0);
  EXPECT_LE(rounds.strain(), rounds.config.stretch.strain_limit + 1e-9);
  EXPECT_GE(stats.constraint_rounds, 1u);
}

TEST(Solver, ConstraintRoundsAreValidatedByName) {
  SolverConfig c;
  std::string why;
  c.collision.constraint_rounds = -1;
  EXPECT_FALSE(c.validate("solver.", &why));
  EXPECT_NE(why.find("solver.collision.constraint_rounds"), std::string::npos) << why;
  c.collision.constraint_rounds = 0;
  EXPECT_TRUE(c.validate("solver.", &why)) << why;
}

TEST(Solver, HairRestingOnTheHeadRunsNoExtraConstraintRounds) {
  // Contact alone does not call for more rounds: only a strain limit that moved a particle of a
  // strand that touched can have pulled it back in. Soft bend and core springs (the built-in
  // scene's) so that the curls settle onto the scalp.
  SolverConfig c;
  c.bend.stiffness_n_m2 = 1.9e-4;  // the built-in scene's (io::builtinScene)
  c.core.stiffness_n = 0.08;
  const HairModel m = makeModel(curlyGroom(30), c);
  HeadMotionConfig still;
  still.type = "still";
  HairState s = makeState(m, Pose(), Twist());
  uint64_t contacts = 0, limited = 0, rounds = 0;
  run(m, c, still, 1.0, &s, [&](double, const HairState&, const StepStats& st) {
    contacts += st.head_contacts;
    limited += st.strain_limited_edges;
    rounds += st.constraint_rounds;
  });
  ASSERT_GT(contacts, 0u);  // the hair does lie on the head
  ASSERT_EQ(limited, 0u);   // within the strain limit throughout
  EXPECT_EQ(rounds, 0u);
}

TEST(Solver, CachedStiffnessFactorsEqualFreshOnes) {
  // Eq. (13)'s factors are kept per particle between steps and reused while the saturation and
  // the other inputs are the same: after a change of each input, a state that kept its cache
  // steps to the same bits as a copy whose cache was emptied.
  SolverConfig c;
  c.integrator.threads = 1;
  const Groom g = curlyGroom(4, 16);
  const HairModel m = makeModel(g, c);
  HairState kept = makeState(m, Pose(), Twist());
  for (double& sigma : kept.saturation) sigma = 0.5;
  const StepInputs inputs;
  step(m, c, inputs, kFrame, &kept, nullptr);
  enum Change { kSaturation, kWetFactor, kGlobalFactor, kDryFactor, kReference, kSubstep };
  for (Change change : {kSaturation, kWetFactor, kGlobalFactor, kDryFactor, kReference, kSubstep}) {
    switch (change) {
      case kSaturation:
        for (size_t i = 0; i < kept.saturation.size(); i += 3) kept.saturation[i] = 0.9;
        break;
      case kWetFactor:
        c.stiffness.wet_factor = 0.999;
        break;
      case kGlobalFactor:
        c.stiffness.global_factor = 0.9999;
        break;
      case kDryFactor:
        c.stiffness.dry_factor = 0.99999;
        break;
      case kReference:
        c.stiffness.reference_step_s = 2e-4;
        break;
      case kSubstep:
        c.integrator.substep_s *= 0.5;
        break;
    }
    HairState fresh = kept;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::fill(fresh.stiffness_factor.begin(), fresh.stiffness_factor.end(), nan);
    std::fill(fresh.stiffness_factor_saturation.begin(), fresh.stiffness_factor_saturation.end(),
              nan);
    std::fill(fresh.stiffness_factor_key.begin(), fresh.stiffness_factor_key.end(),
              StiffnessFactorKey());
    step(m, c, inputs, kFrame, &kept, nullptr);
    step(m, c, inputs, kFrame, &fresh, nullptr);
    for (size_t i = 0; i < kept.position.size(); ++i) {
      ASSERT_EQ(kept.position[i], fresh.position[i]) << "change " << change << ", particle " << i;
      ASSERT_EQ(kept.velocity[i], fresh.velocity[i]) << "change " << change << ", particle " << i;
    }
  }
}
