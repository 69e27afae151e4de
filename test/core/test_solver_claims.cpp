// README claims about the step, each held to what it says through the public API (step(),
// StepStats, HairState, the configs): the curl rotation's time constant, stiffness relative to the
// head, rotational head jumps and the strain limit's velocity rules.
#include <gtest/gtest.h>

#include <cmath>

#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/solver.h"

using namespace wet_curly_hair;

namespace {

constexpr double kFrame = 1.0 / 60.0;

HairModel makeModel(const GroomConfig& g, const SolverConfig& c) {
  HairModel m;
  std::string why;
  EXPECT_TRUE(buildModel(generateGroom(g, EllipsoidShape()), g.linear_density_kg_per_m, HeadShape(),
                         c, &m, &why))
      << why;
  return m;
}

GroomConfig smallGroom(int strands) {
  GroomConfig g;
  g.strands = strands;
  g.particles = 16;
  return g;
}

/// Angle (rad) of the rotation taking b onto a.
double angleBetween(const Mat3& a, const Mat3& b) {
  return Eigen::AngleAxisd(a * b.transpose()).angle();
}

// CurlConfig::rotation_time_constant_s: "M follows the axis with that time constant". A still,
// wet strand at rest (no gravity, a curl weight too small to move it) keeps its root-to-tip axis;
// M started 1 rad away from it closes the gap as exp(-t / tc), on both paths; tc = 0 takes M at
// once.
TEST(SolverClaims, CurlRotationFollowsTheAxisWithItsTimeConstant) {
  for (bool lanes : {true, false}) {
    for (double tc : {0.1, 0.3, 0.0}) {
      SolverConfig c;
      c.gravity_m_s2 = Vec3::Zero();
      c.curl.weight_n = 1e-11;
      c.curl.rotation_time_constant_s = tc;
      c.cohesion.mode = "off";
      c.integrator.strand_lanes = lanes;
      const HairModel m = makeModel(smallGroom(8), c);
      HairState s = makeState(m, Pose(), Twist());
      s.saturation.assign(s.saturation.size(), 1.0);
      const Mat3 target = s.curl_rotation[3].toRotationMatrix();
      const Mat3 start =
          Eigen::AngleAxisd(1.0, Vec3(1, 2, 3).normalized()).toRotationMatrix() * target;
      s.curl_rotation[3] = Quat(start);
      double t = 0.0;
      for (int f = 0; f < 12; ++f) {
        StepStats stats;
        step(m, c, StepInputs{}, kFrame, &s, &stats);
        t += kFrame;
        ASSERT_GT(stats.curl_particle_substeps, 0u);
        const double expected = tc > 0.0 ? std::exp(-t / tc) : 0.0;
        EXPECT_NEAR(angleBetween(s.curl_rotation[3].toRotationMatrix(), target), expected, 2e-3)
            << "lanes " << lanes << ", tc " << tc << ", t " << t;
      }
    }
  }
}

/// Largest distance, in the head frame, between the hair and its rest pose.
double shapeChangeM(const HairModel& m, const HairState& s, const Pose& head) {
  double worst = 0.0;
  for (int i = 0; i < m.particleCount(); ++i)
    worst = std::max(worst, (head.applyInverse(s.position[i]) - m.rest_position_head[i]).norm());
  return worst;
}

// StiffnessConfig::relative_to_head: eq. (13) damps the velocity relative to the head's rigid
// motion, so wet hair on a head moving steadily keeps its shape exactly; damping the absolute
// velocity (false, the literal form) makes it lag the head.
TEST(SolverClaims, StiffnessRelativeToTheHeadDoesNotMakeHairLag) {
  double lag[2] = {0.0, 0.0};
  for (bool relative : {true, false}) {
    SolverConfig c;
    c.gravity_m_s2 = Vec3::Zero();
    c.curl.enabled = false;
    c.cohesion.mode = "off";
    c.stiffness.relative_to_head = relative;
    c.integrator.lane_layout = "double4";  // exact to round-off (float lanes: ~1e-7 m)
    const HairModel m = makeModel(smallGroom(6), c);
    HeadMotionConfig motion;
    motion.type = "linear";
    motion.speed_m_s = 2.0;
    motion.axis = Vec3::UnitX();
    HairState s = makeState(m, headPose(motion, 0.0), headTwist(motion, 0.0));
    s.saturation.assign(s.saturation.size(), 1.0);
    for (int f = 0; f < 60; ++f) {
      StepStats stats;
      step(m, c, StepInputs{headPose(motion, f * kFrame), headPose(motion, (f + 1) * kFrame)},
           kFrame, &s, &stats);
    }
    lag[relative ? 0 : 1] = shapeChangeM(m, s, headPose(motion, 60 * kFrame));
  }
  EXPECT_LT(lag[0], 1e-9) << "relative to the head";
  EXPECT_GT(lag[1], 1e-5) << "absolute";
  EXPECT_GT(lag[1], 1e4 * lag[0]);
}

// IntegratorConfig::teleport_angle_rad: a head that turns more than this within a step has
// jumped: the hair is carried rigidly by the rotation (the count head_jumps says so); a turn
// just below it is simulated.
TEST(SolverClaims, RotationalHeadJumpCarriesTheHairRigidly) {
  SolverConfig c;
  c.integrator.lane_layout = "double4";  // exact to round-off (float lanes: ~1e-7 m)
  const HairModel m = makeModel(smallGroom(6), c);
  HairState still = makeState(m, Pose(), Twist());
  HairState jumped = still;
  StepStats s_still, s_jump;
  step(m, c, StepInputs{Pose(), Pose()}, kFrame, &still, &s_still);
  Pose turned;
  turned.rotation = Quat(Eigen::AngleAxisd(1.6, Vec3::UnitZ()));  // 96 rad/s, no translation
  step(m, c, StepInputs{Pose(), turned}, kFrame, &jumped, &s_jump);
  EXPECT_EQ(s_still.head_jumps, 0u);
  EXPECT_EQ(s_jump.head_jumps, 1u);
  EXPECT_EQ(jumped.warnings.head_jumps, 1u);
  // The jumped hair is the still-head step turned with the head, velocities included.
  double worst = 0.0;
  for (int i = 0; i < m.particleCount(); ++i) {
    worst = std::max(worst, (jumped.position[i] - turned.rotate(still.position[i])).norm());
    worst =
        std::max(worst, (jumped.velocity[i] - turned.rotate(still.velocity[i])).norm() * kFrame);
  }
  EXPECT_LT(worst, 1e-9);
  // 1.4 rad within the step is below the bound: simulated (no jump), the hair lags the turn.
  HairState moved = makeState(m, Pose(), Twist());
  Pose near;
  near.rotation = Quat(Eigen::AngleAxisd(1.4, Vec3::UnitZ()));
  StepStats s_move;
  step(m, c, StepInputs{Pose(), near}, kFrame, &moved, &s_move);
  EXPECT_EQ(s_move.head_jumps, 0u);
  EXPECT_GT(shapeChangeM(m, moved, near), 1e-3);
}

/// Kinetic energy plus the stretch springs' energy.
double stretchEnergy(const HairModel& m, const SolverConfig& c, const HairState& s) {
  double e = 0.0;
  for (int st = 0; st < m.strandCount(); ++st) {
    const int b = m.strandBegin(st), n = m.strandSize(st);
    for (int i = b; i < b + n; ++i)
      e += 0.5 * m.mass_kg[i] * s.velocity[i].squaredNorm() * (i > b ? 1.0 : 0.0);
    for (int i = b; i + 1 < b + n; ++i) {
      const double d = (s.position[i + 1] - s.position[i]).norm() - m.rest_edge_m[i];
      e += 0.5 * m.stretch_k[i] * d * d;
    }
  }
  return e;
}

/// Straight strands with only stretch springs (no gravity, bending, core, curl or head), flung
/// outward along themselves from a held root, so that the strain limit acts.
SolverConfig flungStrandsConfig() {
  SolverConfig c;
  c.gravity_m_s2 = Vec3::Zero();
  c.bend.stiffness_n_m2 = 0.0;
  c.core.stiffness_n = 0.0;
  c.curl.enabled = false;
  c.collision.head_enabled = false;
  c.cohesion.mode = "off";
  return c;
}

GroomConfig straightGroom() {
  GroomConfig g = smallGroom(4);
  g.curl_radius_m = 0.0;
  g.jitter = 0.0;
  return g;
}

HairState flungState(const HairModel& m) {
  HairState s = makeState(m, Pose(), Twist());
  for (int st = 0; st < m.strandCount(); ++st) {
    const int b = m.strandBegin(st), n = m.strandSize(st);
    const Vec3 axis = (s.position[b + n - 1] - s.position[b]).normalized();
    for (int k = 1; k < n; ++k) s.velocity[b + k] = (4.0 * k / (n - 1)) * axis;
  }
  return s;
}

// StretchConfig::limit_velocity "inelastic": the strain limit removes the edge's stretching
// relative velocity, from the tip side only. With the root held and the strands flung along
// themselves the energy (kinetic + stretch) never grows while the limiter works.
TEST(SolverClaims, InelasticStrainLimitNeverAddsEnergy) {
  SolverConfig c = flungStrandsConfig();
  c.stretch.limit_velocity = "inelastic";
  const HairModel m = makeModel(straightGroom(), c);
  HairState s = flungState(m);
  double energy = stretchEnergy(m, c, s);
  uint64_t limited = 0;
  for (int f = 0; f < 30; ++f) {
    StepStats stats;
    step(m, c, StepInputs{}, kFrame, &s, &stats);
    limited += stats.strain_limited_edges;
    const double now = stretchEnergy(m, c, s);
    EXPECT_LE(now, energy * (1.0 + 1e-9)) << "frame " << f;
    energy = now;
  }
  EXPECT_GT(limited, 0u);  // the limiter did act
}

// StretchConfig::limit_velocity "auto" (the default): the inelastic velocity without hair
// contact, the displacement with it. The flung strands after 10 frames, to the bit; the two
// rules part there (else the comparison would prove nothing).
TEST(SolverClaims, AutoStrainLimitVelocityIsInelasticAloneAndDisplacementWithHairContact) {
  EXPECT_EQ(SolverConfig().stretch.limit_velocity, "auto");
  for (const bool contact : {false, true}) {
    auto run = [&](const char* rule) {
      SolverConfig c = flungStrandsConfig();
      c.hair_contact.enabled = contact;
      c.stretch.limit_velocity = rule;
      const HairModel m = makeModel(straightGroom(), c);
      HairState s = flungState(m);
      for (int f = 0; f < 10; ++f) step(m, c, StepInputs{}, kFrame, &s, nullptr);
      return s.position;
    };
    const Vec3List automatic = run("auto"), inelastic = run("inelastic"),
                   displacement = run("displacement");
    ASSERT_NE(inelastic, displacement) << "contact " << contact;
    EXPECT_EQ(automatic, contact ? displacement : inelastic) << "contact " << contact;
  }
}

}  // namespace
