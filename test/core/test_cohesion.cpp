// Stable cohesion (eq. 10, A11-A14) and the force-based baselines.
#include <gtest/gtest.h>

#include "wet_curly_hair/core/cohesion.h"
#include "wet_curly_hair/core/metrics.h"
#include "wet_curly_hair/core/solver.h"

using namespace wet_curly_hair;

namespace {

/// Two parallel straight strands `gap` apart, plus a third far away.
struct Fixture {
  HairModel model;
  HairState state;
  Fixture(double gap) {
    Groom g;
    for (int s = 0; s < 3; ++s) {
      const Vec3 base = s == 2 ? Vec3(1.0, 0, 0) : Vec3(s * gap, 0, 0);
      for (int i = 0; i < 10; ++i) g.points.push_back(base + Vec3(0, 0, -0.008 * i));
      g.strand_offsets.push_back(static_cast<uint32_t>(g.points.size()));
      g.root_normals.push_back(Vec3(0, 0, -1));
    }
    SolverConfig c;
    std::string why;
    EXPECT_TRUE(buildModel(g, 1e-4, HeadShape(), c, &model, &why)) << why;
    state = makeState(model, Pose(), Twist());
  }
};

}  // namespace

TEST(Cohesion, DryHairIsUntouched) {
  Fixture f(0.005);
  CohesionConfig c;
  EXPECT_EQ(computeDisplayCohesion(f.model, c, &f.state), 0);
  for (int i = 0; i < f.model.particleCount(); ++i) EXPECT_EQ(f.state.wet_position[i], f.state.position[i]);
}

TEST(Cohesion, WetNeighboursClumpIsolatedParticlesStay) {
  Fixture f(0.005);
  std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
  CohesionConfig c;
  c.include_self = false;  // the literal neighbour set of A13: exact pull of lambda * gap
  EXPECT_GT(computeDisplayCohesion(f.model, c, &f.state), 0);
  for (int i = 0; i < 10; ++i) {
    // Strand 0 moves toward strand 1 along x by lambda times the gap (its only neighbour), and
    // strand 1 toward strand 0: by 0.85 * 0.005 each (same-strand neighbours excluded, A13).
    EXPECT_NEAR(f.state.wet_position[i].x(), 0.85 * 0.005, 1e-12);
    EXPECT_NEAR(f.state.wet_position[10 + i].x(), 0.005 - 0.85 * 0.005, 1e-12);
    EXPECT_EQ(f.state.wet_position[20 + i], f.state.position[20 + i]) << "isolated strand";
  }
  // The dynamics never read p^w: positions are unchanged.
  EXPECT_EQ(f.state.position[3], f.state.last_good_position[3]);
}

TEST(Cohesion, SelfWeightMakesThePullGrowSmoothlyWithDistance) {
  // With the particle in its own Shepard sum, a neighbour near the edge of the support pulls
  // little; without it, any neighbour inside the support pulls by the full lambda.
  for (double gap : {0.019, 0.01, 0.002}) {
    Fixture f(gap);
    std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
    CohesionConfig c;
    c.radius_m = 0.02;
    computeDisplayCohesion(f.model, c, &f.state);
    const double pull = f.state.wet_position[5].x() / (0.85 * gap);
    if (gap > 0.015) EXPECT_LT(pull, 0.1) << gap;
    if (gap < 0.005) EXPECT_GT(pull, 0.3) << gap;
    EXPECT_LT(pull, 1.0) << gap;
  }
}

TEST(Cohesion, IsTranslationInvariant) {
  Fixture a(0.007), b(0.007);
  const Vec3 shift(12.3, -4.5, 6.7);
  for (Vec3& x : b.state.position) x += shift;
  for (Fixture* f : {&a, &b})
    for (int i = 0; i < f->model.particleCount(); ++i) f->state.saturation[i] = 0.3 + 0.05 * (i % 7);
  CohesionConfig c;
  computeDisplayCohesion(a.model, c, &a.state);
  computeDisplayCohesion(b.model, c, &b.state);
  for (int i = 0; i < a.model.particleCount(); ++i)
    EXPECT_LT((b.state.wet_position[i] - shift - a.state.wet_position[i]).norm(), 1e-12) << i;
}

TEST(Cohesion, BaselineForcesPullWetStrandsTogetherAndConserveMomentum) {
  for (const char* mode : {"lin", "kim"}) {
    Fixture f(0.01);
    std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
    CohesionConfig c;
    c.mode = mode;
    EXPECT_GT(computeCohesionForces(f.model, c, &f.state), 0) << mode;
    Vec3 total = Vec3::Zero();
    for (const Vec3& x : f.state.external_force) total += x;
    EXPECT_LT(total.norm(), 1e-12) << mode;
    EXPECT_GT(f.state.external_force[5].x(), 0.0) << mode << ": strand 0 pulled toward strand 1";
    EXPECT_EQ(f.state.external_force[25], Vec3::Zero()) << mode << ": isolated strand feels none";
  }
}

TEST(Metrics, ClumpDistanceTanglesAndCurlShape) {
  Fixture f(0.004);
  std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
  NeighborGrid grid;
  grid.resize(f.model.particleCount(), f.model.strand_offsets);
  // Strands 0 and 1 are 4 mm apart; strand 2 is isolated and counts as the search radius.
  EXPECT_NEAR(clumpDistance(f.model, f.state.position, f.state.saturation, 0.02, &grid),
              (20 * 0.004 + 10 * 0.02) / 30.0, 1e-12);
  EXPECT_EQ(tangleCount(f.model, f.state.position, 0.0005, &grid), 0);
  // 4.2 mm contact: each of the 9 segment pairs side by side, and the 2 x 8 pairs offset by one
  // edge (they share an end height, so they are 4 mm apart too).
  EXPECT_EQ(tangleCount(f.model, f.state.position, 0.0021, &grid), 25);
  EXPECT_NEAR(segmentDistance(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 1, 1), Vec3(0.5, -1, 1)), 1.0, 1e-15);
  // Curl shape of a generated helix comes back.
  Groom g;
  const Vec3List h = makeHelix(60, 0.006, 0.01, 0.03);
  g.points = h;
  g.strand_offsets = {0, 60};
  g.root_normals = {Vec3::UnitZ()};
  HairModel m;
  SolverConfig c;
  std::string why;
  ASSERT_TRUE(buildModel(g, 1e-4, HeadShape(), c, &m, &why)) << why;
  const CurlShape shape = tipCurlShape(m, h);
  EXPECT_NEAR(shape.radius_m, 0.01, 0.0005);
  EXPECT_NEAR(shape.pitch_m, 0.03, 0.0015);
}
