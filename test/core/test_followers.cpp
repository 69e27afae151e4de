// Guides and followers (followers.h): follow ratio 1 is the full simulation, guides evolve as in
// the full simulation, a follower on a guide copies it (to the float placement's round-off), rigid
// hair stays rigid, followers end outside the head and the obstacles, weights are the modified
// Shepard weights and sum to 1; with the cohesion sums at the guides, a follower on a guide takes
// its display and the guides' display is unchanged; the followers' exaggerated rest shapes, held
// between placements, follow saturation and curl weight changes; a follower's placement does not
// depend on the strands beside it in the SIMD lanes.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "wet_curly_hair/core/cohesion.h"
#include "wet_curly_hair/core/diagnostics.h"
#include "wet_curly_hair/core/followers.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"

using namespace wet_curly_hair;

namespace {

constexpr double kFrame = 1.0 / 60.0;

Groom curlyGroom(int strands, int particles = 32) {
  GroomConfig c;
  c.strands = strands;
  c.particles = particles;
  return generateGroom(c, EllipsoidShape());
}

/// Six curly strands with strand 0 repeated as strand 1 (seven in all): farthest-point sampling
/// keeps 0 as a guide and never picks 1, which then follows 0 alone.
Groom twinGroom() {
  const Groom g = curlyGroom(6);
  Groom twin;
  for (int src : {0, 0, 1, 2, 3, 4, 5}) {
    twin.points.insert(twin.points.end(), g.points.begin() + g.strand_offsets[src],
                       g.points.begin() + g.strand_offsets[src + 1]);
    twin.strand_offsets.push_back(static_cast<uint32_t>(twin.points.size()));
    twin.root_normals.push_back(g.root_normals[src]);
  }
  return twin;
}

HairModel followerModel(const Groom& g, int follow_ratio, const SolverConfig& c) {
  HairModel m;
  std::string why;
  EXPECT_TRUE(buildFollowerModel(g, GroomConfig().linear_density_kg_per_m, follow_ratio,
                                 HeadShape(), c, &m, &why))
      << why;
  return m;
}

/// A wet nodding run of `frames` frames with a sphere in reach; returns the final state.
HairState wetNodRun(const HairModel& m, const SolverConfig& c, int frames) {
  HeadMotionConfig nod;
  nod.type = "nod";
  Obstacles obstacles;
  AnalyticObstacle sphere;
  sphere.center_m = Vec3(-0.16, 0.0, -0.05);
  sphere.radius_m = 0.05;
  obstacles.analytic.push_back(sphere);
  HairState s = makeState(m, headPose(nod, 0.0), headTwist(nod, 0.0));
  SaturationCommand wet;
  wet.root_value = 0.5;
  wet.tip_value = 1.0;
  applySaturation(m, wet, headPose(nod, 0.0), &s);
  for (int f = 0; f < frames; ++f) {
    StepInputs in{headPose(nod, f * kFrame), headPose(nod, (f + 1) * kFrame), &obstacles};
    step(m, c, in, kFrame, &s, nullptr);
  }
  return s;
}

/// How far single precision may move a follower particle (updateFollowers places them in float
/// lanes, relative to the head's position): each coordinate is rounded once from the guides'
/// double sums, then a few times in the edge hold and the pose's rotation, each rounding at most
/// half an ulp of a coordinate. 8 unit round-offs (2^-24) per coordinate, over 3 coordinates, at
/// scale_m, the largest distance of a particle from the head's position. The head's distance
/// from the world's origin does not count: the translation is added in double.
double placementRoundOff(double scale_m) { return 8.0 * std::sqrt(3.0) * 0x1p-24 * scale_m; }

/// placementRoundOff at the scale of the state's positions about the head's position under `pose`.
double placementRoundOff(const HairState& s, const Pose& pose) {
  double largest = 0.0;
  for (const Vec3& p : s.position) largest = std::max(largest, (p - pose.translation).norm());
  return placementRoundOff(largest);
}

/// Every guide at its rest shape carried by `pose` (followers anywhere).
void guidesAtRest(const HairModel& m, const Pose& pose, HairState* s) {
  for (int i = 0; i < static_cast<int>(m.strand_offsets[m.followers.guide_strands]); ++i)
    s->position[i] = pose.apply(m.rest_position_head[i]);
}

}  // namespace

TEST(Followers, SelectGuidesIsFarthestPointSampling) {
  // Ten roots on a line, 1 cm apart: from root 0 the farthest is 9, then 4 and 5 tie at 4 cm
  // from both (the lower index wins), then 2 (2 cm from 0 and 4; 7 is 2 cm from 5 and 9 too).
  Vec3List roots;
  for (int i = 0; i < 10; ++i) roots.push_back(Vec3(0.01 * i, 0.0, 0.0));
  EXPECT_EQ(selectGuides(roots, 1), (std::vector<int>{0}));
  EXPECT_EQ(selectGuides(roots, 2), (std::vector<int>{0, 9}));
  EXPECT_EQ(selectGuides(roots, 3), (std::vector<int>{0, 4, 9}));
  EXPECT_EQ(selectGuides(roots, 4), (std::vector<int>{0, 2, 4, 9}));
  EXPECT_EQ(selectGuides(roots, 10).size(), 10u);
  EXPECT_EQ(selectGuides(roots, 50).size(), 10u);
  // Coinciding roots: each strand is chosen once.
  const Vec3List same(4, Vec3(0.0, 0.0, 0.1));
  EXPECT_EQ(selectGuides(same, 3), (std::vector<int>{0, 1, 2}));
}

TEST(Followers, WeightsAreModifiedShepardAndSumToOne) {
  // d = 1, 2, 3 and the next guide at R = 4: w_i ~ ((R - d_i) / (R d_i))^2 = 9/16, 1/16, 1/144.
  const double d[4] = {1.0, 2.0, 3.0, 4.0};
  double w[3];
  followerWeights(d, 4, w);
  const double sum = 9.0 / 16 + 1.0 / 16 + 1.0 / 144;
  EXPECT_NEAR(w[0], 9.0 / 16 / sum, 1e-15);
  EXPECT_NEAR(w[1], 1.0 / 16 / sum, 1e-15);
  EXPECT_NEAR(w[2], 1.0 / 144 / sum, 1e-15);
  EXPECT_NEAR(w[0] + w[1] + w[2], 1.0, 1e-15);
  // A guide as far as the next one weighs nothing (continuity when the nearest set changes).
  const double tie[4] = {1.0, 2.0, 4.0, 4.0};
  followerWeights(tie, 4, w);
  EXPECT_EQ(w[2], 0.0);
  EXPECT_NEAR(w[0] + w[1], 1.0, 1e-15);
  // On a guide's root: that guide alone.
  const double hit[4] = {0.0, 1.0, 2.0, 3.0};
  followerWeights(hit, 4, w);
  EXPECT_EQ(w[0], 1.0);
  EXPECT_EQ(w[1] + w[2], 0.0);
  // Fewer guides than the stencil: R = 2 d_max, still a partition of unity.
  const double two[2] = {1.0, 3.0};
  followerWeights(two, 2, w);
  EXPECT_NEAR(w[0] + w[1], 1.0, 1e-15);
  EXPECT_NEAR(w[0] / w[1], std::pow((5.0 / 6) / (3.0 / 18), 2), 1e-12);
}

TEST(Followers, ModelWeightsSumToOneAndGuidesComeFirst) {
  const SolverConfig c;
  const Groom g = curlyGroom(200);
  const HairModel m = followerModel(g, 4, c);
  EXPECT_EQ(m.followers.guide_strands, 50);
  EXPECT_EQ(m.strandCount(), 200);
  EXPECT_EQ(m.simulatedStrandCount(), 50);
  std::vector<int> seen(200, 0);
  for (int s = 0; s < 200; ++s) {
    const int src = m.followers.source_strand[s];
    ++seen[src];
    EXPECT_EQ(m.rest_position_head[m.strandBegin(s)], g.points[g.strand_offsets[src]]);
  }
  for (int k : seen) EXPECT_EQ(k, 1);
  for (int f = 0; f < 150; ++f) {
    double sum = 0.0;
    for (int n = 0; n < kFollowerGuides; ++n) {
      const int guide = m.followers.guide[f * kFollowerGuides + n];
      EXPECT_GE(guide, 0);
      EXPECT_LT(guide, 50);
      EXPECT_GE(m.followers.weight[f * kFollowerGuides + n], 0.0);
      sum += m.followers.weight[f * kFollowerGuides + n];
    }
    EXPECT_NEAR(sum, 1.0, 1e-14) << "follower " << f;
  }
}

TEST(Followers, GuidesFirstTakesTheGroomsFirstStrandsAsAModelOrdersThem) {
  // A model's strands, guides first, written out as a groom (as the runner's .hair frames write
  // them) and read back with groom.guides "first": the same guides, followers, weights and
  // samples, every strand where it was.
  const SolverConfig c;
  const Groom g = curlyGroom(40);
  const HairModel sampled = followerModel(g, 4, c);
  Groom in_model_order;
  for (int s = 0; s < sampled.strandCount(); ++s) {
    const int src = sampled.followers.source_strand[s];
    in_model_order.points.insert(in_model_order.points.end(),
                                 g.points.begin() + g.strand_offsets[src],
                                 g.points.begin() + g.strand_offsets[src + 1]);
    in_model_order.strand_offsets.push_back(static_cast<uint32_t>(in_model_order.points.size()));
    in_model_order.root_normals.push_back(g.root_normals[src]);
  }
  HairModel first;
  std::string why;
  ASSERT_TRUE(buildFollowerModel(in_model_order, GroomConfig().linear_density_kg_per_m, 4,
                                 HeadShape(), c, &first, &why, GuideChoice::kFirst))
      << why;
  ASSERT_EQ(first.followers.guide_strands, sampled.followers.guide_strands);
  for (int s = 0; s < first.strandCount(); ++s) EXPECT_EQ(first.followers.source_strand[s], s);
  EXPECT_EQ(first.followers.guide, sampled.followers.guide);
  EXPECT_EQ(first.followers.weight, sampled.followers.weight);
  EXPECT_EQ(first.followers.sample_index, sampled.followers.sample_index);
  EXPECT_EQ(first.rest_position_head, sampled.rest_position_head);
  // On the generated groom the first strands are guides too, where sampling picks others.
  HairModel first_generated;
  ASSERT_TRUE(buildFollowerModel(g, GroomConfig().linear_density_kg_per_m, 4, HeadShape(), c,
                                 &first_generated, &why, GuideChoice::kFirst))
      << why;
  int sampled_elsewhere = 0;
  for (int s = 0; s < first_generated.followers.guide_strands; ++s) {
    EXPECT_EQ(first_generated.followers.source_strand[s], s);
    sampled_elsewhere += sampled.followers.source_strand[s] != s;
  }
  EXPECT_GT(sampled_elsewhere, 0);
  EXPECT_EQ(guideChoice("first"), GuideChoice::kFirst);
  EXPECT_EQ(guideChoice("sampled"), GuideChoice::kSampled);
}

TEST(Followers, BadFollowRatioIsRefusedWithTheKeyNamed) {
  const SolverConfig c;
  const Groom g = curlyGroom(10);
  for (int k : {0, -3, kMaxFollowRatio + 1}) {
    HairModel m;
    m.strand_offsets = {0, 7};
    std::string why;
    EXPECT_FALSE(buildFollowerModel(g, 0.0124, k, HeadShape(), c, &m, &why)) << k;
    EXPECT_NE(why.find("groom.follow_ratio"), std::string::npos) << why;
    EXPECT_EQ(m.strand_offsets, (std::vector<uint32_t>{0, 7})) << "a refused build changed it";
    GroomConfig gc;
    gc.follow_ratio = k;
    why.clear();
    EXPECT_FALSE(gc.validate("groom.", &why)) << k;
    EXPECT_NE(why.find("groom.follow_ratio"), std::string::npos) << why;
  }
}

TEST(Followers, FollowRatioOneIsTheFullSimulationToTheBit) {
  const SolverConfig c;
  const Groom g = curlyGroom(20);
  HairModel full;
  std::string why;
  ASSERT_TRUE(buildModel(g, GroomConfig().linear_density_kg_per_m, HeadShape(), c, &full, &why));
  const HairModel one = followerModel(g, 1, c);
  EXPECT_EQ(one.followers.guide_strands, 0);
  EXPECT_EQ(one.simulatedStrandCount(), 20);
  const HairState a = wetNodRun(full, c, 30), b = wetNodRun(one, c, 30);
  for (int i = 0; i < full.particleCount(); ++i) {
    ASSERT_EQ(a.position[i], b.position[i]) << i;
    ASSERT_EQ(a.wet_position[i], b.wet_position[i]) << i;
  }
  // Every strand was simulated (the tips left the rest pose carried by the head; the head ends
  // at the pose of the last frame, 0.5 s into the nod) and nothing was interpolated.
  HeadMotionConfig nod;
  nod.type = "nod";
  const Pose end = headPose(nod, 30 * kFrame);
  for (int s = 0; s < one.strandCount(); ++s) {
    const int tip = one.strandBegin(s) + one.strandSize(s) - 1;
    EXPECT_GT((end.applyInverse(b.position[tip]) - one.rest_position_head[tip]).norm(), 1e-3) << s;
  }
  HairState t = makeState(one, Pose(), Twist());
  StepStats stats;
  step(one, c, StepInputs{Pose(), Pose()}, kFrame, &t, &stats);
  EXPECT_EQ(stats.stage_particles[kStageFollowers], 0u);
}

TEST(Followers, GuidesMoveExactlyAsTheSameStrandsInTheFullSimulation) {
  // Strands couple only through per-step outputs (cohesion display positions, not fed back):
  // a guide must not notice that its neighbours became followers.
  const SolverConfig c;
  const Groom g = curlyGroom(40);
  const HairModel full = followerModel(g, 1, c), half = followerModel(g, 4, c);
  const HairState a = wetNodRun(full, c, 30), b = wetNodRun(half, c, 30);
  for (int s = 0; s < half.followers.guide_strands; ++s) {
    const int src = half.followers.source_strand[s];
    for (int i = 0; i < half.strandSize(s); ++i)
      ASSERT_EQ(b.position[half.strandBegin(s) + i], a.position[full.strandBegin(src) + i])
          << "guide " << s << " particle " << i;
  }
}

TEST(Followers, TheSimulatedStrandsEnergyCountsTheGuidesAlone) {
  // energy() over model.simulatedStrandCount() strands (the runner's energy_simulated): the
  // guides come first, so it must take every guide particle and no follower's. Kinetic energy
  // tells them apart: the guides moving at 1 m/s, the followers at 2 m/s.
  const SolverConfig c;
  const HairModel m = followerModel(curlyGroom(40), 4, c);
  const int guides = m.simulatedStrandCount();
  ASSERT_GT(guides, 0);
  ASSERT_LT(guides, m.strandCount());
  HairState s = makeState(m, Pose(), Twist());
  double guide_mass = 0.0, follower_mass = 0.0;  // non-root particles, as energy() counts them
  for (int st = 0; st < m.strandCount(); ++st)
    for (int i = m.strandBegin(st); i < m.strandBegin(st) + m.strandSize(st); ++i) {
      const bool guide = st < guides;
      s.velocity[i] = guide ? Vec3(1.0, 0.0, 0.0) : Vec3(0.0, 2.0, 0.0);
      if (i > m.strandBegin(st)) (guide ? guide_mass : follower_mass) += m.mass_kg[i];
    }
  EnergyParts simulated;
  const EnergyParts all = energy(m, c, Pose(), &s, guides, &simulated);
  EXPECT_NEAR(simulated.kinetic, 0.5 * guide_mass, 1e-12 * guide_mass);
  EXPECT_NEAR(all.kinetic, 0.5 * guide_mass + 2.0 * follower_mass, 1e-12 * follower_mass);
  EXPECT_EQ(all.total(), energy(m, c, Pose(), &s).total());  // the split changes no total
  // Every strand, however it is asked for.
  EnergyParts whole, beyond, unsplit;
  energy(m, c, Pose(), &s, m.strandCount(), &whole);
  energy(m, c, Pose(), &s, m.strandCount() + 5, &beyond);
  energy(m, c, Pose(), &s, -1, &unsplit);
  EXPECT_EQ(whole.total(), all.total());
  EXPECT_EQ(beyond.total(), all.total());
  EXPECT_EQ(unsplit.total(), all.total());
}

TEST(Followers, AFollowerOnAGuidesRootWithItsShapeCopiesIt) {
  // Strand 1 is strand 0 again: farthest-point sampling keeps 0 as a guide and never picks 1;
  // on 0's root its weight is 1, its arc-length samples fall on 0's particles, its saturation
  // is 0's: it must be 0, wet, nodding, near an obstacle.
  const Groom twin = twinGroom();
  ASSERT_EQ(twin.strandCount(), 7);
  std::string why;
  ASSERT_TRUE(twin.validate(&why)) << why;
  const SolverConfig c;
  const HairModel m = followerModel(twin, 2, c);
  ASSERT_EQ(m.followers.guide_strands, 4);
  int copy = -1, original = -1;
  for (int s = 0; s < m.strandCount(); ++s) {
    if (m.followers.source_strand[s] == 0) original = s;
    if (m.followers.source_strand[s] == 1) copy = s;
  }
  ASSERT_LT(original, m.followers.guide_strands);
  ASSERT_GE(copy, m.followers.guide_strands);
  const HairState s = wetNodRun(m, c, 40);
  const double round_off = placementRoundOff(s, Pose());  // the nod turns about the origin
  double moved = 0.0;
  for (int i = 0; i < m.strandSize(copy); ++i) {
    const Vec3& x = s.position[m.strandBegin(copy) + i];
    const Vec3& y = s.position[m.strandBegin(original) + i];
    EXPECT_LT((x - y).norm(), round_off) << "particle " << i;
    moved = std::max(moved, (m.rest_position_head[m.strandBegin(original) + i] - y).norm());
  }
  EXPECT_GT(moved, 1e-3) << "the guide did not move: the test proves nothing";
}

TEST(Followers, WithTheSumsAtTheGuidesAFollowerOnAGuideTakesItsDisplay) {
  // cohesion.gather_at "guides": strand 1 is strand 0 again (as above), so the offsets it
  // interpolates are 0's alone, at 0's particles: its p^w must be 0's, which moved (clumped).
  // Evaluated exactly and on the lattice.
  const Groom twin = twinGroom();
  for (const std::string evaluation : {"exact", "grid"}) {
    SolverConfig c;
    c.cohesion.gather_at = "guides";
    c.cohesion.evaluation = evaluation;
    const HairModel m = followerModel(twin, 2, c);
    int copy = -1, original = -1;
    for (int s = 0; s < m.strandCount(); ++s) {
      if (m.followers.source_strand[s] == 0) original = s;
      if (m.followers.source_strand[s] == 1) copy = s;
    }
    ASSERT_GE(copy, m.followers.guide_strands);
    const HairState s = wetNodRun(m, c, 40);
    // The offsets are 0's to the bit; the positions they ride on, to the placement's round-off.
    const double round_off = placementRoundOff(s, Pose());
    double clumped = 0.0;
    for (int i = 0; i < m.strandSize(copy); ++i) {
      const int a = m.strandBegin(copy) + i, b = m.strandBegin(original) + i;
      EXPECT_LT((s.wet_position[a] - s.wet_position[b]).norm(), round_off)
          << evaluation << " " << i;
      clumped = std::max(clumped, (s.wet_position[b] - s.position[b]).norm());
    }
    EXPECT_GT(clumped, 1e-4) << evaluation << ": no display offset, the test proves nothing";
  }
}

TEST(Followers, WithTheSumsAtTheGuidesTheGuidesDisplayIsUnchanged) {
  // Both evaluations give every particle, followers included, its volume (from its exact
  // density, the lattice's interpolated at it, or with node volumes its share of the nodes'),
  // so the guides' sums, and their p^w, are those of the sums at every particle to the bit; the
  // followers' differ (interpolated) but stay within the kernel's reach, lambda h, of their
  // positions.
  for (const char* evaluation : {"exact", "grid", "grid node volumes", "grid node sums"}) {
    SolverConfig all;
    all.cohesion.gather_at = "all";
    all.cohesion.evaluation = std::string(evaluation).substr(0, 5) == "exact" ? "exact" : "grid";
    all.cohesion.grid_node_volumes = std::string(evaluation) == "grid node volumes";
    if (std::string(evaluation) == "grid node sums") all.cohesion.grid_wet_sums = "nodes";
    SolverConfig guides = all;
    guides.cohesion.gather_at = "guides";
    // The node sums subtract the own strand as exact pairs only where other strands outweigh it 4
    // to 1: 600 strands, so that both of its forms run (60 take the lattice's form throughout).
    const bool node_sums = all.cohesion.grid_wet_sums == "nodes";
    const HairModel m = followerModel(curlyGroom(node_sums ? 600 : 60), 4, all);
    const HairState a = wetNodRun(m, all, 20), b = wetNodRun(m, guides, 20);
    const int first_follower = m.strandBegin(m.followers.guide_strands);
    int moved = 0, differ = 0;
    for (int i = 0; i < m.particleCount(); ++i) {
      ASSERT_EQ(a.position[i], b.position[i]) << i;  // p^w never feeds back
      if (i < first_follower) {
        ASSERT_EQ(a.wet_position[i], b.wet_position[i]) << evaluation << " " << i;
        moved += a.wet_position[i] != a.position[i];
      } else {
        const double offset = (b.wet_position[i] - b.position[i]).norm();
        ASSERT_LE(offset, all.cohesion.tightness * all.cohesion.radius_m) << i;
        differ += a.wet_position[i] != b.wet_position[i];
      }
    }
    EXPECT_GT(moved, 0) << evaluation << ": no guide clumped, the test proves nothing";
    EXPECT_GT(differ, 0) << evaluation << ": the followers' p^w was not interpolated";
  }
}

TEST(Followers, WithoutFollowersTheSumsAtTheGuidesAreTheSumsAtEveryParticle) {
  // With K = 1 every strand is a guide: a groom without followers gets the sums at every
  // particle either way, p^w to the bit.
  for (const char* evaluation : {"exact", "grid", "grid node sums"}) {
    SolverConfig all;
    all.cohesion.evaluation = std::string(evaluation).substr(0, 5) == "exact" ? "exact" : "grid";
    if (std::string(evaluation) == "grid node sums") all.cohesion.grid_wet_sums = "nodes";
    all.cohesion.gather_at = "all";
    SolverConfig guides = all;
    guides.cohesion.gather_at = "guides";
    const HairModel m = followerModel(curlyGroom(40), 1, all);
    ASSERT_EQ(m.followers.guide_strands, 0);
    const HairState a = wetNodRun(m, all, 12), b = wetNodRun(m, guides, 12);
    int moved = 0;
    for (int i = 0; i < m.particleCount(); ++i) {
      ASSERT_EQ(a.wet_position[i], b.wet_position[i]) << evaluation << " " << i;
      moved += a.wet_position[i] != a.position[i];
    }
    EXPECT_GT(moved, 0) << evaluation << ": nothing clumped, the test proves nothing";
  }
}

TEST(Followers, RigidHairStaysRigidWithTheHead) {
  // Guides at rest carried by a turned and moved head: every follower is its own rest shape
  // carried by the same head, to round-off, with the head's velocity from its previous pose.
  SolverConfig c;
  const HairModel m = followerModel(curlyGroom(100), 5, c);
  Pose before, after;
  after.rotation = Quat(Eigen::AngleAxisd(0.7, Vec3(0.3, -1.0, 0.2).normalized()));
  after.translation = Vec3(0.1, -0.2, 0.05);
  HairState s = makeState(m, before, Twist());
  guidesAtRest(m, after, &s);
  const double dt = 0.01;
  updateFollowers(m, c, after, nullptr, dt, 1, &s);
  const double round_off = placementRoundOff(s, after);
  for (int i = m.strand_offsets[m.followers.guide_strands]; i < m.particleCount(); ++i) {
    const Vec3 expected = after.apply(m.rest_position_head[i]);
    ASSERT_LT((s.position[i] - expected).norm(), round_off) << i;
    const Vec3 v = (expected - before.apply(m.rest_position_head[i])) / dt;
    ASSERT_LT((s.velocity[i] - v).norm(), round_off / dt) << i;
  }
  // And through step(): no gravity, a still head at that pose, rest stays rest for everyone.
  c.gravity_m_s2.setZero();
  HairState t = makeState(m, after, Twist());
  for (int f = 0; f < 60; ++f) step(m, c, StepInputs{after, after}, kFrame, &t, nullptr);
  for (int i = 0; i < m.particleCount(); ++i)
    ASSERT_LT((after.applyInverse(t.position[i]) - m.rest_position_head[i]).norm(), 1e-6) << i;
}

TEST(Followers, FarFromTheWorldsOriginFollowersKeepTheirPrecision) {
  // A head 2 km from the world's origin (a robot in a large map): the float lanes hold world
  // positions relative to the head, so rigid hair is as precise there as at the origin (a float
  // world coordinate at 2 km holds only 120 um), and the clearance from a sphere in the hair
  // holds to the same round-off.
  SolverConfig c;
  const HairModel m = followerModel(curlyGroom(100), 5, c);
  Pose far;
  far.rotation = Quat(Eigen::AngleAxisd(0.7, Vec3(0.3, -1.0, 0.2).normalized()));
  far.translation = Vec3(1500.0, -1300.0, 25.0);
  HairState s = makeState(m, far, Twist());
  guidesAtRest(m, far, &s);
  updateFollowers(m, c, far, nullptr, kFrame, 2, &s);
  const double round_off = placementRoundOff(s, far);
  ASSERT_LT(round_off, 1e-6);
  for (int i = m.strand_offsets[m.followers.guide_strands]; i < m.particleCount(); ++i)
    ASSERT_LT((s.position[i] - far.apply(m.rest_position_head[i])).norm(), round_off) << i;
  Obstacles obstacles;
  AnalyticObstacle sphere;  // 2 cm above the scalp, in the hair
  sphere.center_m = far.apply(Vec3(0.0, 0.0, 0.17));
  sphere.radius_m = 0.04;
  obstacles.analytic.push_back(sphere);
  updateFollowers(m, c, far, &obstacles, kFrame, 2, &s);
  int pushed = 0;
  for (int st = m.followers.guide_strands; st < m.strandCount(); ++st) {
    for (int i = m.strandBegin(st) + 1; i < m.strandBegin(st) + m.strandSize(st); ++i) {
      Vec3 normal;
      const double to_sphere = obstacles.distance(s.position[i], &normal);
      EXPECT_GE(to_sphere, c.obstacle.offset_m - round_off) << i;
      pushed += to_sphere < c.obstacle.offset_m + 1e-6;
    }
  }
  EXPECT_GT(pushed, 0) << "no follower reached the sphere: the test proves nothing";
}

TEST(Followers, FollowersEndOutsideTheHeadAndTheObstacles) {
  // Guides pushed 3 cm into the head along the head normal: their displacement carries the
  // followers inside too, and the projection must put every non-root particle back at least
  // min(offset, rest distance) out (the solver's rule), and out of a sphere in the hair.
  const SolverConfig c;
  const HairModel m = followerModel(curlyGroom(120), 4, c);
  const Pose pose;
  HairState s = makeState(m, pose, Twist());
  for (int i = 0; i < static_cast<int>(m.strand_offsets[m.followers.guide_strands]); ++i) {
    Vec3 normal;
    m.head.distance(m.rest_position_head[i], &normal);
    s.position[i] = m.rest_position_head[i] - 0.03 * normal;
  }
  Obstacles obstacles;
  AnalyticObstacle sphere;
  sphere.center_m = Vec3(0.0, 0.0, 0.17);
  sphere.radius_m = 0.04;
  obstacles.analytic.push_back(sphere);
  // Without the projections some followers would end inside the head.
  SolverConfig free_config = c;
  free_config.collision.head_enabled = false;
  HairState unprojected = s;
  updateFollowers(m, free_config, pose, nullptr, kFrame, 1, &unprojected);
  updateFollowers(m, c, pose, &obstacles, kFrame, 2, &s);
  // A particle projected to the offset surface, then rounded, may land round-off inside it.
  const double round_off = placementRoundOff(s, pose);
  int inside_unprojected = 0, near_sphere = 0;
  for (int st = m.followers.guide_strands; st < m.strandCount(); ++st) {
    for (int i = m.strandBegin(st) + 1; i < m.strandBegin(st) + m.strandSize(st); ++i) {
      Vec3 normal;
      const double offset =
          std::min(c.collision.offset_m, std::max(0.0, m.rest_head_distance_m[i]));
      EXPECT_GE(m.head.distance(s.position[i], &normal), offset - round_off) << i;
      // The sphere sits 2 cm above the scalp: its projection cannot push into the head.
      const double to_sphere = obstacles.distance(s.position[i], &normal);
      EXPECT_GE(to_sphere, c.obstacle.offset_m - round_off) << i;
      inside_unprojected += m.head.distance(unprojected.position[i], &normal) < 0.0;
      near_sphere += obstacles.distance(unprojected.position[i], &normal) < c.obstacle.offset_m;
    }
  }
  EXPECT_GT(inside_unprojected, 0) << "nothing to project: the test proves nothing";
  EXPECT_GT(near_sphere, 0) << "the sphere is out of reach: the test proves nothing";
}

TEST(Followers, AParticleAuthoredInsideTheHeadEndsOnItsSurfaceAsInTheSolver) {
  // A groom from another head: particles 1-3 of every strand authored 4 mm under the scalp. The
  // solver pushes a guide's to the surface (its offset min(delta, max(0, rest distance))); a
  // follower's placement must do the same, not leave it at its rest depth.
  Groom g = curlyGroom(120);
  for (int s = 0; s < g.strandCount(); ++s)
    for (uint32_t i = g.strand_offsets[s] + 1; i <= g.strand_offsets[s] + 3; ++i) {
      Vec3 normal;
      const double d = ellipsoidDistance(EllipsoidShape(), g.points[i], &normal);
      g.points[i] -= (d + 0.004) * normal;
    }
  const SolverConfig c;
  const HairModel m = followerModel(g, 4, c);
  int authored_inside = 0;
  for (int i = 0; i < m.particleCount(); ++i) authored_inside += m.rest_head_distance_m[i] < 0.0;
  ASSERT_GE(authored_inside, 3 * 120) << "nothing authored inside: the test proves nothing";
  const Pose pose;
  HairState s = makeState(m, pose, Twist());
  step(m, c, StepInputs{pose, pose, nullptr}, kFrame, &s, nullptr);
  const double round_off = placementRoundOff(s, pose);
  for (int st = 0; st < m.strandCount(); ++st) {
    const bool guide = st < m.followers.guide_strands;
    for (int i = m.strandBegin(st) + 1; i < m.strandBegin(st) + m.strandSize(st); ++i) {
      Vec3 normal;
      EXPECT_GE(m.head.distance(s.position[i], &normal), guide ? -1e-12 : -round_off)
          << (guide ? "guide" : "follower") << " particle " << i;
    }
  }
}

TEST(Followers, FollowerEdgesKeepTheStrainLimitAndTheirGuidesLengths) {
  // Each guide turned rigidly about its root by its own large angle: the turned offsets of
  // neighbouring guides disagree, and interpolated follower edges would stretch and crush. Every
  // follower edge ends within the strain limit of its rest length (the guides' edges are at rest
  // length: the lower bound is 1 - limit). No head: nothing projects after the limit.
  SolverConfig c;
  c.collision.head_enabled = false;
  const HairModel m = followerModel(curlyGroom(120), 4, c);
  const Pose pose;
  HairState s = makeState(m, pose, Twist());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(-1.2, 1.2), axis(-1.0, 1.0);
  for (int g = 0; g < m.followers.guide_strands; ++g) {
    const Vec3 root = m.rest_position_head[m.strandBegin(g)];
    const Mat3 turn =
        Eigen::AngleAxisd(angle(rng), Vec3(axis(rng), axis(rng), axis(rng)).normalized())
            .toRotationMatrix();
    for (int i = m.strandBegin(g); i < m.strandBegin(g) + m.strandSize(g); ++i)
      s.position[i] = root + turn * (m.rest_position_head[i] - root);
  }
  updateFollowers(m, c, pose, nullptr, kFrame, 2, &s);
  const double limit = c.stretch.strain_limit;
  // Each end of an edge within the placement's round-off: its length within twice that.
  const double round_off = placementRoundOff(s, pose);
  for (int st = m.followers.guide_strands; st < m.strandCount(); ++st) {
    for (int i = m.strandBegin(st); i + 1 < m.strandBegin(st) + m.strandSize(st); ++i) {
      const double ratio = (s.position[i + 1] - s.position[i]).norm() / m.rest_edge_m[i];
      const double slack = 2.0 * round_off / m.rest_edge_m[i];
      EXPECT_LE(ratio, 1.0 + limit + slack) << st << " " << i;
      EXPECT_GE(ratio, 1.0 - limit - slack) << st << " " << i;
    }
  }
}

TEST(Followers, InAWetNodWithASphereNoFollowerEdgeGoesPastTheRepairBound) {
  // The whole path (interpolation, hold, head and sphere projections) in a run: no follower edge
  // ends longer than 3x the strain limit, the bound past which the solver repairs a guide
  // (strandStrainOk). Without the hold, an edge reached 1.5x its rest length in this run.
  const SolverConfig c;
  const HairModel m = followerModel(curlyGroom(200), 4, c);
  const HairState s = wetNodRun(m, c, 60);
  const double bound = 1.0 + 3.0 * c.stretch.strain_limit;
  double largest = 0.0;
  for (int st = m.followers.guide_strands; st < m.strandCount(); ++st)
    for (int i = m.strandBegin(st); i + 1 < m.strandBegin(st) + m.strandSize(st); ++i)
      largest = std::max(largest, (s.position[i + 1] - s.position[i]).norm() / m.rest_edge_m[i]);
  EXPECT_LE(largest, bound);
}

TEST(Followers, ExaggeratedRestIsTheRestShapeWhenDryAndKeepsEdgeLengthsWhenWet) {
  const SolverConfig c;
  const HairModel m = followerModel(curlyGroom(8), 2, c);
  const int s = 5, begin = m.strandBegin(s), n = m.strandSize(s);
  std::vector<double> sigma(n, 0.0);
  Vec3List out(n);
  exaggeratedRest(m, c.curl, s, sigma.data(), out.data());
  for (int i = 0; i < n; ++i) ASSERT_EQ(out[i], m.rest_position_head[begin + i]);
  sigma.assign(n, 1.0);
  exaggeratedRest(m, c.curl, s, sigma.data(), out.data());
  // Fully wet: each edge turns by b = k_w / (k_w + k_b) toward the helix edge, its length kept.
  const double b = m.curl_k[s] / (m.curl_k[s] + m.bend_k[s]);
  double turned = 0.0;
  for (int i = 0; i + 1 < n; ++i) {
    const Vec3 e = m.rest_position_head[begin + i + 1] - m.rest_position_head[begin + i];
    const Vec3 h = m.followers.curl_turn[s] * m.helix_edge[begin + i];
    const Vec3 mix = (1.0 - b) * e + b * h;
    const Vec3 expected = mix * (e.norm() / mix.norm());
    EXPECT_LT((out[i + 1] - out[i] - expected).norm(), 1e-12) << i;
    EXPECT_NEAR((out[i + 1] - out[i]).norm(), e.norm(), 1e-12) << i;
    turned = std::max(turned, (out[i + 1] - out[i] - e).norm());
  }
  EXPECT_GT(turned, 1e-4);
  sigma.assign(n, 1.0);
  SolverConfig off = c;
  off.curl.enabled = false;
  exaggeratedRest(m, off.curl, s, sigma.data(), out.data());
  for (int i = 0; i < n; ++i) ASSERT_EQ(out[i], m.rest_position_head[begin + i]);
}

TEST(Followers, TheHeldRestShapesFollowSaturationAndCurlChanges) {
  // Each follower's exaggerated rest shape is kept in the state between placements: after a
  // saturation change (whole groom, one particle of one strand) or a curl weight change the
  // followers are where a fresh state puts them, to the bit, and the change did move them.
  SolverConfig c;
  HairModel m = followerModel(curlyGroom(100), 5, c);
  const Pose pose;
  const int first = static_cast<int>(m.strand_offsets[m.followers.guide_strands]);
  auto placed = [&](const HairModel& model, const SolverConfig& config, HairState* s) {
    guidesAtRest(model, pose, s);
    updateFollowers(model, config, pose, nullptr, 0.0, 1, s);
    return Vec3List(s->position.begin() + first, s->position.end());
  };
  auto fresh = [&](const HairModel& model, const SolverConfig& config,
                   const std::vector<double>& saturation) {
    HairState f = makeState(model, pose, Twist());
    f.saturation = saturation;
    return placed(model, config, &f);
  };
  HairState s = makeState(m, pose, Twist());
  SaturationCommand wet;
  wet.root_value = 0.5;
  wet.tip_value = 1.0;
  applySaturation(m, wet, pose, &s);
  const Vec3List wet_placed = placed(m, c, &s);
  ASSERT_EQ(wet_placed, fresh(m, c, s.saturation));
  ASSERT_EQ(placed(m, c, &s), wet_placed);  // nothing changed: the held shapes

  SaturationCommand drier;
  drier.root_value = 0.0;
  drier.tip_value = 0.3;
  applySaturation(m, drier, pose, &s);
  const Vec3List drier_placed = placed(m, c, &s);
  EXPECT_NE(drier_placed, wet_placed);
  EXPECT_EQ(drier_placed, fresh(m, c, s.saturation));

  const int last = m.particleCount() - 1;  // the tip of the last follower
  s.saturation[last - 1] = 1.0;
  const Vec3List one_placed = placed(m, c, &s);
  EXPECT_NE(one_placed, drier_placed);
  EXPECT_EQ(one_placed, fresh(m, c, s.saturation));

  SolverConfig curlier = c;
  curlier.curl.weight_n = 4.0 * c.curl.weight_n;
  std::string why;
  ASSERT_TRUE(updateSpringConstants(curlier, &m, &why)) << why;
  const Vec3List curl_placed = placed(m, curlier, &s);
  EXPECT_NE(curl_placed, one_placed);
  EXPECT_EQ(curl_placed, fresh(m, curlier, s.saturation));
}

TEST(Followers, AFollowerIsPlacedAloneWhateverItsNeighboursInTheLanes) {
  // The followers are placed in groups of 4, one per SIMD lane, strands of different lengths
  // together. 41 strands cut to 6-30 particles, and the same with strands 1-40 in reverse order
  // (the same guides, by farthest-point sampling from strand 0, but every follower beside other
  // ones): guides pushed 2 cm into the head but for their roots, the head turned, a sphere in
  // the hair. Each follower
  // must land where it landed among its first neighbours, to the bit, and outside the head and
  // the sphere at every particle, up to the tip of the longest.
  const Groom full = curlyGroom(41);
  Groom cut, reversed;
  auto add = [&](Groom* g, int src) {
    const int n = 6 + (src * 7) % 25;
    g->points.insert(g->points.end(), full.points.begin() + full.strand_offsets[src],
                     full.points.begin() + full.strand_offsets[src] + n);
    g->strand_offsets.push_back(static_cast<uint32_t>(g->points.size()));
    g->root_normals.push_back(full.root_normals[src]);
  };
  for (int src = 0; src < 41; ++src) add(&cut, src);
  add(&reversed, 0);
  for (int src = 40; src >= 1; --src) add(&reversed, src);
  const SolverConfig c;
  Pose pose;
  pose.rotation = Quat(Eigen::AngleAxisd(0.3, Vec3(0.2, 1.0, -0.4).normalized()));
  pose.translation = Vec3(0.02, -0.01, 0.03);
  Obstacles obstacles;
  AnalyticObstacle sphere;  // 2 cm above the scalp: its projection cannot push into the head
  sphere.center_m = pose.apply(Vec3(0.0, 0.0, 0.17));
  sphere.radius_m = 0.04;
  obstacles.analytic.push_back(sphere);
  // Source strand -> its placed world positions.
  auto place = [&](const Groom& g, int* near_sphere) {
    const HairModel m = followerModel(g, 4, c);
    HairState s = makeState(m, pose, Twist());
    for (int g = 0; g < m.followers.guide_strands; ++g) {
      for (int i = m.strandBegin(g); i < m.strandBegin(g) + m.strandSize(g); ++i) {
        Vec3 normal;
        m.head.distance(m.rest_position_head[i], &normal);
        const double depth = i > m.strandBegin(g) ? 0.02 : 0.0;  // the roots on the scalp
        s.position[i] = pose.apply(m.rest_position_head[i] - depth * normal);
      }
    }
    updateFollowers(m, c, pose, &obstacles, kFrame, 2, &s);
    const double round_off = placementRoundOff(s, pose);
    std::map<int, Vec3List> placed;
    for (int st = m.followers.guide_strands; st < m.strandCount(); ++st) {
      const int begin = m.strandBegin(st), n = m.strandSize(st);
      placed[m.followers.source_strand[st]] =
          Vec3List(s.position.begin() + begin, s.position.begin() + begin + n);
      for (int i = begin + 1; i < begin + n; ++i) {
        Vec3 normal;
        const double offset = std::min(c.collision.offset_m, m.rest_head_distance_m[i]);
        EXPECT_GE(m.head.distance(pose.applyInverse(s.position[i]), &normal), offset - round_off)
            << st << " " << i - begin << " of " << n;
        EXPECT_GE(obstacles.distance(s.position[i], &normal), c.obstacle.offset_m - round_off);
        *near_sphere += (s.position[i] - sphere.center_m).norm() < sphere.radius_m + 0.01;
      }
    }
    return placed;
  };
  int near_sphere = 0, near_sphere_reversed = 0;
  const std::map<int, Vec3List> first = place(cut, &near_sphere);
  const std::map<int, Vec3List> second = place(reversed, &near_sphere_reversed);
  ASSERT_EQ(first.size(), 30u);  // 41 strands at K = 4: 11 guides
  for (const auto& [src, positions] : first) {
    // reversed's strand k > 0 is cut's strand 41 - k
    const auto other = second.find(src == 0 ? 0 : 41 - src);
    ASSERT_NE(other, second.end()) << "the guides differ: the test proves nothing";
    EXPECT_EQ(positions, other->second) << "source strand " << src;
  }
  EXPECT_GT(near_sphere, 0) << "the sphere is out of reach: the test proves nothing";
}

TEST(Followers, AFreshStateHoldsNoRestShapeYet) {
  // Dry, no curl weight and no bending stiffness: saturations and constants all zero, as the held
  // rest shapes' records would be if a fresh state left them at zero (resetState marks them
  // empty). The first placement must compute the shapes, not read the state's empty ones:
  // followers of guides at rest sit at rest.
  SolverConfig c;
  c.curl.enabled = false;
  c.bend.stiffness_n_m2 = 0.0;
  c.gravity_m_s2.setZero();
  const HairModel m = followerModel(curlyGroom(40), 4, c);
  ASSERT_EQ(m.bend_k[m.followers.guide_strands], 0.0);
  const Pose pose;
  HairState s = makeState(m, pose, Twist());
  guidesAtRest(m, pose, &s);
  updateFollowers(m, c, pose, nullptr, 0.0, 1, &s);
  const double round_off = placementRoundOff(s, pose);
  for (int i = m.strand_offsets[m.followers.guide_strands]; i < m.particleCount(); ++i)
    ASSERT_LT((s.position[i] - m.rest_position_head[i]).norm(), round_off) << i;
}

TEST(Followers, EveryPathOfTheDisplayPassWritesTheOffsetsItHolds) {
  // cohesion.refresh_period_s > 0: exact or on the lattice, with the sums at every particle or at
  // the guides (the followers' interpolation), the evaluation writes each particle's offset
  // p^w - p with its p^w, and the frame after it carries those offsets on the moved positions.
  // The held offsets start as NaN, so a particle a path leaves out shows.
  for (const char* evaluation : {"exact", "grid"})
    for (const char* gather_at : {"all", "guides"}) {
      SolverConfig c;
      c.cohesion.evaluation = evaluation;
      c.cohesion.gather_at = gather_at;
      const HairModel m = followerModel(curlyGroom(60), 4, c);
      HairState s = wetNodRun(m, c, 10);
      c.cohesion.refresh_period_s = 2.0 * kFrame;
      std::fill(s.display_offset.begin(), s.display_offset.end(), Vec3::Constant(NAN));
      s.display_evaluated_s = NAN;  // the next call evaluates
      const std::string what = std::string(evaluation) + " " + gather_at;
      updateDisplayCohesion(m, c.cohesion, 10 * kFrame, &s, 2);
      int moved = 0;
      for (int i = 0; i < m.particleCount(); ++i) {
        const Vec3 offset = s.display_offset[i];
        ASSERT_LE((s.wet_position[i] - s.position[i] - offset).norm(), 1e-15) << what << " " << i;
        moved += offset != Vec3::Zero();
      }
      EXPECT_GT(moved, m.particleCount() / 4) << what << ": few offsets, the test proves little";
      const Vec3List held = s.display_offset;
      for (int i = 0; i < m.particleCount(); ++i) s.position[i] += Vec3(0.001, -0.002, 0.0005);
      updateDisplayCohesion(m, c.cohesion, 11 * kFrame, &s, 2);
      for (int i = 0; i < m.particleCount(); ++i)
        ASSERT_EQ(s.wet_position[i],
                  held[i] == Vec3::Zero() ? s.position[i] : Vec3(s.position[i] + held[i]))
            << what << " " << i;
    }
}
