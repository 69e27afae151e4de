// The stages of the strand-block stepper (src/core/strand_block.h) on their own: the force
// assembly the solver runs, in one lane of double and in four, checked against the physics it
// must keep (internal forces carry no net momentum).
#include <gtest/gtest.h>

#include <random>

#include "../../src/core/strand_block.h"
#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"

using namespace wet_curly_hair;
using namespace wet_curly_hair::detail;

namespace {

/// Four wet curly strands, zero gravity, shaken out of their rest pose at random.
struct Scene {
  SolverConfig config;
  HairModel model;
  HairState state;
  StepInputs inputs;
  Scene() {
    config.gravity_m_s2 = Vec3::Zero();
    GroomConfig g;
    g.strands = 4;
    g.particles = 24;
    std::string why;
    EXPECT_TRUE(buildModel(generateGroom(g, EllipsoidShape()),
                           GroomConfig().linear_density_kg_per_m, HeadShape(), config, &model,
                           &why))
        << why;
    state = makeState(model, Pose(), Twist());
    SaturationCommand wet;
    wet.root_value = 0.2;
    wet.tip_value = 1.0;
    applySaturation(model, wet, Pose(), &state);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> jitter(-1.5e-3, 1.5e-3);
    for (Vec3& p : state.position) p += Vec3(jitter(rng), jitter(rng), jitter(rng));
  }
};

/// Runs the force stages of one substep on a block of `width` strands (lanes of S) and returns,
/// per strand, the sum of the forces over its particles and the largest single force.
template <typename S>
void forceSums(Scene& scene, std::vector<Vec3>* sums, std::vector<double>* largest) {
  const SolverPlan plan = planStep(scene.model, scene.config, 1e-3);
  StepStats stats;
  StrandFlags flags[kMaxStrandLanes];
  for (StrandFlags& f : flags) f.wet = true;
  const int width = kLaneWidth<S>;
  for (int first = 0; first < scene.model.strandCount(); first += width) {
    Block<S> blk(scene.model, scene.config, scene.inputs, plan, &scene.state,
                 &scene.state.scratch[0], &stats, 1e-3);
    initBlock(&blk, first, width, flags);
    const SubstepMotion motion = substepMotion(scene.inputs, 0.0, 1.0, 1e-3);
    rootsFramesTargets(blk, motion);
    elasticForces(blk);
    curlForces(blk);
    for (int l = 0; l < width; ++l) {
      Vec3 sum = Vec3::Zero();
      double big = 0.0;
      for (int i = 0; i < blk.n; ++i) {
        sum += lane(blk.a.f[i], l);
        big = std::max(big, lane(blk.a.f[i], l).norm());
      }
      sums->push_back(sum);
      largest->push_back(big);
    }
  }
}

template <typename S>
void expectNoNetInternalForce() {
  Scene scene;
  std::vector<Vec3> sums;
  std::vector<double> largest;
  forceSums<S>(scene, &sums, &largest);
  ASSERT_EQ(sums.size(), 4u);
  for (size_t s = 0; s < sums.size(); ++s) {
    // Stretch, bend, core and curl forces of a strand, with gravity off: each segment force is
    // applied +f and -f, so they cancel to round-off of the largest force.
    EXPECT_GT(largest[s], 1e-3) << "strand " << s << ": the springs must be loaded";
    EXPECT_LT(sums[s].norm(), 1e-12 * largest[s] * 24) << "strand " << s;
  }
}

}  // namespace

TEST(StrandBlock, InternalForcesCarryNoNetMomentumInOneLane) { expectNoNetInternalForce<double>(); }

TEST(StrandBlock, InternalForcesCarryNoNetMomentumInFourLanes) {
  expectNoNetInternalForce<LaneDouble4>();
}

TEST(StrandBlock, StrainRepairTriggersPastThreeTimesTheStrainLimit) {
  // The limiter runs last in every substep, so no finite step reaches the repair bound; the
  // check itself (what step() runs on every strand after a step) is held to 3x the limit here.
  Scene scene;
  const double limit = scene.config.stretch.strain_limit;
  scene.state = makeState(scene.model, Pose(), Twist());  // the rest pose: within every bound
  const int begin = scene.model.strandBegin(1), edge = 5;
  EXPECT_TRUE(strandStrainOk(scene.model, scene.config, 1, scene.state));
  auto stretchEdgeTo = [&](double strain) {
    // Moves every particle past the edge along it, so that only this edge changes length.
    Vec3* p = &scene.state.position[begin];
    const Vec3 e = p[edge + 1] - p[edge];
    const double rest = scene.model.rest_edge_m[begin + edge];
    const Vec3 shift = ((1.0 + strain) * rest / e.norm() - 1.0) * e;
    for (int i = edge + 1; i < scene.model.strandSize(1); ++i) p[i] += shift;
  };
  stretchEdgeTo(2.9 * limit);
  EXPECT_TRUE(strandStrainOk(scene.model, scene.config, 1, scene.state));
  stretchEdgeTo(3.1 * limit);
  EXPECT_FALSE(strandStrainOk(scene.model, scene.config, 1, scene.state));
  EXPECT_TRUE(strandStrainOk(scene.model, scene.config, 0, scene.state));  // other strands: no
}

/// The gather rounds each position into the lanes and keeps what rounding lost in the carry
/// (p_carry = lane - position): lane - carry is the position to double's resolution, and the
/// scatter gives it back exactly when nothing moved. The hair at rest, away from the world's
/// origin, so that float rounding loses something on every axis.
template <typename S>
void expectTheCarryKeepsDoublePositions() {
  Scene scene;
  scene.state = makeState(scene.model, Pose(), Twist());  // at rest: the limit moves nothing
  scene.inputs.head_start.translation = Vec3(0.37, -1.21, 0.83);
  scene.inputs.head_end = scene.inputs.head_start;
  for (Vec3& p : scene.state.position) p += scene.inputs.head_start.translation;
  const Vec3List before = scene.state.position;
  const SolverPlan plan = planStep(scene.model, scene.config, 1e-3);
  StepStats stats;
  StrandFlags flags[kMaxStrandLanes];
  const int width = std::min(kLaneWidth<S>, scene.model.strandCount());
  Block<S> blk(scene.model, scene.config, scene.inputs, plan, &scene.state, &scene.state.scratch[0],
               &stats, 1e-3);
  initBlock(&blk, 0, width, flags);
  double largest_carry = 0.0;
  for (int l = 0; l < width; ++l) {
    for (int i = 0; i < blk.n; ++i) {
      const Vec3 relative = before[blk.begin[l] + i] - blk.origin;
      const Vec3 carry = lane(blk.a.p_carry[i], l);
      largest_carry = std::max(largest_carry, carry.cwiseAbs().minCoeff());
      // Float holds the carry (~1e-8 m) to ~1e-15 m.
      EXPECT_LT((lane(blk.a.p[i], l) - carry - relative).norm(), 1e-14) << l << " " << i;
    }
  }
  // Float lanes: every axis of some particle lost something to rounding.
  EXPECT_GT(largest_carry, 1e-10);
  // Into the scratch, where the post-step check reads it, or, for the strands the scatter
  // checked itself (written), into the state.
  const uint32_t written = scatterBlock(blk);
  for (int l = 0; l < width; ++l) {
    const Vec3* out = written >> l & 1u ? &scene.state.position[blk.begin[l]]
                                        : &scene.state.scratch[0].step_position[size_t(l) * blk.n];
    for (int i = 0; i < blk.n; ++i) EXPECT_LT((out[i] - before[blk.begin[l] + i]).norm(), 1e-14);
  }
}

TEST(StrandBlock, TheCarryKeepsDoublePositionsInFloat16Lanes) {
  expectTheCarryKeepsDoublePositions<LaneFloat16>();
}
TEST(StrandBlock, TheCarryKeepsDoublePositionsInFloat8Lanes) {
  expectTheCarryKeepsDoublePositions<LaneFloat8>();
}

#if defined(__AVX512F__)
/// 20 strands of 24 particles (or `particles`) moved off the world's origin (to the step's origin)
/// and shaken by up to jitter_m per coordinate, with velocities of every size up to 3 m/s per axis
/// and, with random_saturation, saturations anywhere in [0, 1]: what the row gather and scatter
/// tests feed their two blocks (the first, and the last, partial one: ShakenBlock).
struct ShakenStrands {
  SolverConfig config;
  HairModel model;
  HairState state;
  StepInputs inputs;
  SolverPlan plan;
  StepStats stats;
  StrandFlags flags[kMaxStrandLanes];
  ShakenStrands(unsigned seed, double jitter_m, bool random_saturation, int particles = 24) {
    GroomConfig g;
    g.strands = 20;
    g.particles = particles;
    std::string why;
    EXPECT_TRUE(buildModel(generateGroom(g, EllipsoidShape()), g.linear_density_kg_per_m,
                           HeadShape(), config, &model, &why))
        << why;
    state = makeState(model, Pose(), Twist());
    inputs.head_start.translation = Vec3(0.37, -1.21, 0.83);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> jitter(-jitter_m, jitter_m), speed(-3.0, 3.0),
        wet(0.0, 1.0);
    for (size_t k = 0; k < state.position.size(); ++k) {
      state.position[k] +=
          inputs.head_start.translation + Vec3(jitter(rng), jitter(rng), jitter(rng));
      state.velocity[k] = Vec3(speed(rng), speed(rng), speed(rng));
      if (random_saturation) state.saturation[k] = wet(rng);
    }
    plan = planStep(model, config, 1e-3);
  }
};

/// The block of 16 float lanes of a ShakenStrands scene from strand `first` (active strands
/// there, the rest padding), gathered (initBlock).
struct ShakenBlock {
  int active;
  Block<LaneFloat16> blk;
  ShakenBlock(ShakenStrands& s, int first)
      : active(std::min(16, s.model.strandCount() - first)),
        blk(s.model, s.config, s.inputs, s.plan, &s.state, &s.state.scratch[0], &s.stats, 1e-3) {
    initBlock(&blk, first, active, s.flags);
  }
};

/// The row gather of 16 float lanes (gatherStateByRow, what gatherArrays runs on them) stores
/// what the lane-by-lane gather does, to the bit: positions relative to the origin and their
/// carry, velocities and saturations, on 20 strands moved off the world's origin and shaken,
/// with velocities and saturations of every size, for the first block and the last, partial one
/// (its padding lanes repeat the last strand).
TEST(StrandBlock, TheRowGatherStoresTheLaneGathersLanesToTheBit) {
  ShakenStrands scene(11, 2e-3, true);
  ASSERT_EQ(scene.model.strandCount(), 20) << "the groom must build";
  for (int first : {0, 16}) {
    ShakenBlock block(scene, first);
    Block<LaneFloat16>& blk = block.blk;
    const int active = block.active, n = blk.n;
    // What the row gather stored, then the lane gather over it.
    auto copy = [n](const auto* from, int per_particle) {
      const auto* bytes = reinterpret_cast<const unsigned char*>(from);
      return std::vector<unsigned char>(bytes, bytes + n * per_particle * sizeof(LaneFloat16));
    };
    const auto p = copy(blk.a.p, 3), carry = copy(blk.a.p_carry, 3), v = copy(blk.a.v, 3),
               sigma = copy(blk.a.sigma, 1);
    gatherStateByLane(blk);
    EXPECT_EQ(p, copy(blk.a.p, 3)) << "positions, block from strand " << first;
    EXPECT_EQ(carry, copy(blk.a.p_carry, 3)) << "carry, block from strand " << first;
    EXPECT_EQ(v, copy(blk.a.v, 3)) << "velocities, block from strand " << first;
    EXPECT_EQ(sigma, copy(blk.a.sigma, 1)) << "saturations, block from strand " << first;
    // The carry is not all zero: the comparison sees the rounding.
    double largest_carry = 0.0;
    for (int i = 0; i < n; ++i)
      for (int l = 0; l < active; ++l)
        largest_carry = std::max(largest_carry, std::abs(lane(blk.a.p_carry[i], l).x()));
    EXPECT_GT(largest_carry, 1e-10);
  }
}

/// The row scatter of 16 float lanes (scatterStateByRow, what scatterBlock runs on them) outputs
/// what the lane-by-lane scatter does, to the bit, output edge limit included, and its verdict on
/// each strand is the post-step check's (strandFinite and strandStrainOk on those values): a
/// healthy strand goes to the state, any other to its scratch run, the state left as it was. On
/// 20 strands off the world's origin, shaken far enough that the limit shortens edges, for the
/// first block and the last, partial one; a lane given a non-finite velocity, and one a
/// non-finite position, fail the check, and no other does. Strands of 24 particles (the copy
/// out of the rows takes eight at a time) and of 21 (five left over).
void expectTheRowScatterOutputsTheLaneScattersValuesAndTheCheckVerdict(int particles) {
  ShakenStrands scene(13, 3e-3, false, particles);
  ASSERT_EQ(scene.model.strandCount(), 20) << "the groom must build";
  ASSERT_EQ(scene.model.strandSize(0), particles);
  const SolverConfig& config = scene.config;
  const HairModel& model = scene.model;
  HairState& state = scene.state;
  auto same_bits = [](const Vec3& a, const Vec3& b) {
    for (int axis = 0; axis < 3; ++axis) {
      const double x = a[axis], y = b[axis];
      if (!(std::isnan(x) && std::isnan(y)) && std::memcmp(&x, &y, sizeof x) != 0) return false;
    }
    return true;
  };
  int limited = 0;
  for (int first : {0, 16}) {
    ShakenBlock block(scene, first);
    Block<LaneFloat16>& blk = block.blk;
    const int active = block.active, n = blk.n;
    if (first == 0) {
      setLaneValue(&blk.a.v[5].y, 3, std::numeric_limits<double>::quiet_NaN());
      setLaneValue(&blk.a.p[n - 1].z, 9, std::numeric_limits<double>::infinity());
    }
    // The lane-by-lane scatter first (it reads the lanes only), into vectors of our own.
    std::vector<Vec3List> lane_p(active, Vec3List(n)), lane_v(active, Vec3List(n));
    for (int l = 0; l < active; ++l) scatterLane(blk, l, lane_p[l].data(), lane_v[l].data());
    const Vec3List state_before = state.position, velocity_before = state.velocity;
    const uint32_t written = scatterStateByRow(blk);
    for (int l = 0; l < active; ++l) {
      uint64_t nonfinite = 0;
      const bool healthy = strandFinite(lane_p[l].data(), lane_v[l].data(), n, &nonfinite) &&
                           strandStrainOk(model, config, blk.strand[l], lane_p[l].data());
      EXPECT_EQ(healthy, (written >> l & 1u) != 0) << "strand " << first + l;
      EXPECT_EQ(healthy, !(first == 0 && (l == 3 || l == 9))) << "strand " << first + l;
      const int begin = blk.begin[l];
      const Vec3* p = healthy ? &state.position[begin] : &state.scratch[0].step_position[l * n];
      const Vec3* v = healthy ? &state.velocity[begin] : &state.scratch[0].step_velocity[l * n];
      for (int i = 0; i < n; ++i) {
        const Vec3 unlimited = (lane(blk.a.p[i], l) - lane(blk.a.p_carry[i], l)) + blk.origin;
        limited += (lane_p[l][i] - unlimited).norm() > 1e-9;
        EXPECT_TRUE(same_bits(p[i], lane_p[l][i])) << "strand " << first + l << " particle " << i;
        EXPECT_TRUE(same_bits(v[i], lane_v[l][i])) << "strand " << first + l << " particle " << i;
        if (!healthy) {
          EXPECT_EQ(state.position[begin + i], state_before[begin + i]);
          EXPECT_EQ(state.velocity[begin + i], velocity_before[begin + i]);
        }
      }
    }
  }
  EXPECT_GT(limited, 0) << "the shake must make the output edge limit act";
}

TEST(StrandBlock, TheRowScatterOutputsTheLaneScattersValuesAndTheCheckVerdictToTheBit) {
  expectTheRowScatterOutputsTheLaneScattersValuesAndTheCheckVerdict(24);
  expectTheRowScatterOutputsTheLaneScattersValuesAndTheCheckVerdict(21);
}
#endif

/// Particles in lanes of S wandering in and out of contact with a head with a neck, while the
/// head turns and moves: head collision with the distance cache and without it, on copies, makes
/// the same contacts and moves the particles the same to round-off (the two calls may contract
/// the same expressions into different fused operations), and the cache skips rows. The lanes of
/// a row start near each other, as neighbouring strands do.
template <typename S>
void expectTheHeadDistanceCacheChangesNothing() {
  HairModel model;
  model.head.capsules.push_back({"neck", Vec3(-0.01, 0, -0.06), Vec3(-0.02, 0, -0.25), 0.055});
  CollisionConfig config;
  StepInputs inputs;
  inputs.head_start.translation = Vec3(0.1, -0.2, 0.3);
  inputs.head_end.translation = Vec3(0.13, -0.18, 0.3);
  inputs.head_end.rotation = Quat(Eigen::AngleAxisd(0.6, Vec3(0.3, 1.0, 0.2).normalized()));
  const Vec3 origin = inputs.head_start.translation;
  constexpr int kRows = 24, kSubsteps = 60;
  const double h = 1.0 / 240.0;
  std::mt19937 rng(5);
  // Rows start from 3 % inside to 15 % outside the ellipsoid, their lanes within ~2 % of it.
  std::normal_distribution<double> direction, nearby(0.0, 0.02);
  std::uniform_real_distribution<double> shell(0.97, 1.15), walk(-1e-3, 1e-3), rest(0.0, 0.01);
  std::vector<V3<S>> p(kRows), v(kRows), anchor(kRows);
  std::vector<S> slack(kRows, splat<S>(-1.0)), rest_distance(kRows);
  for (int i = 0; i < kRows; ++i) {
    v[i] = zero3<S>();
    const Vec3 u = Vec3(direction(rng), direction(rng), direction(rng)).normalized();
    const double s = shell(rng);
    for (int l = 0; l < kLaneWidth<S>; ++l) {
      const Vec3 ul = (u + Vec3(nearby(rng), nearby(rng), nearby(rng))).normalized();
      const Vec3 x_head = (s + nearby(rng)) * model.head.ellipsoid.radii_m.cwiseProduct(ul);
      setLane(&p[i], l, Vec3(inputs.head_start.apply(x_head) - origin));
      setLaneValue(&rest_distance[i], l, rest(rng));
    }
  }
  std::vector<V3<S>> p_plain = p, v_plain = v;
  uint64_t skipped = 0, contacts = 0;
  for (int k = 0; k < kSubsteps; ++k) {
    const SubstepMotion motion =
        substepMotion(inputs, double(k) / kSubsteps, double(k + 1) / kSubsteps, h);
    const V3<S> t1 = splat3<S>(Vec3(motion.pose1.translation - origin));
    for (int i = 1; i < kRows; ++i) {
      skipped += !anyLane(
          distanceNeeded(splat33<S>(motion.r1_inverse) * (p[i] - t1), anchor[i], slack[i]));
    }
    uint64_t touched[kLaneWidth<S>] = {}, touched_plain[kLaneWidth<S>] = {};
    collideHeadParticles<S>(model, config, motion, origin, h, rest_distance.data(), anchor.data(),
                            slack.data(), p.data(), v.data(), kRows, touched);
    collideHeadParticles<S>(model, config, motion, origin, h, rest_distance.data(), nullptr,
                            nullptr, p_plain.data(), v_plain.data(), kRows, touched_plain);
    for (int l = 0; l < kLaneWidth<S>; ++l) {
      ASSERT_EQ(touched[l], touched_plain[l]) << "substep " << k << " lane " << l;
      contacts += touched[l];
      // Round-off: float holds a head-relative position to ~3e-8 m and a velocity (the motion
      // over h) to ~3e-8 / h.
      for (int i = 0; i < kRows; ++i) {
        ASSERT_LT((lane(p[i], l) - lane(p_plain[i], l)).norm(), 1e-7) << k << " " << l << " " << i;
        ASSERT_LT((lane(v[i], l) - lane(v_plain[i], l)).norm(), 1e-7 / h)
            << k << " " << l << " " << i;
      }
    }
    for (int i = 1; i < kRows; ++i) {  // the same random walk for both copies
      V3<S> dx;
      for (int l = 0; l < kLaneWidth<S>; ++l)
        setLane(&dx, l, Vec3(walk(rng), walk(rng), walk(rng)));
      p[i] += dx;
      p_plain[i] += dx;
    }
  }
  EXPECT_GT(contacts, uint64_t{kSubsteps});
  EXPECT_GT(skipped, uint64_t{kSubsteps * (kRows - 1) / 4}) << "the cache never helps";
}

TEST(StrandBlock, TheHeadDistanceCacheChangesNothingInFloat16Lanes) {
  expectTheHeadDistanceCacheChangesNothing<LaneFloat16>();
}
TEST(StrandBlock, TheHeadDistanceCacheChangesNothingInFloat8Lanes) {
  expectTheHeadDistanceCacheChangesNothing<LaneFloat8>();
}
TEST(StrandBlock, TheHeadDistanceCacheChangesNothingInOneLane) {
  expectTheHeadDistanceCacheChangesNothing<double>();
}

namespace {

/// Five edges of rest length 1 cm zigzagging along x and y (a projection along one edge leaves
/// the next one's length alone to first order), at `ratio[i]` times the strain limit's length
/// (1 + limit) rest, the same in every lane; limitStrainEdges once. Edges 2 and 4 lie 3e-6 past
/// the limit, edge 1 3e-6 short of it (in the margin the chain-free pass leaves to the chain):
/// the limit must project exactly the edges past it, and the strain before it is the largest
/// edge's, whichever pass took it.
template <typename S>
void expectTheLimitProjectsExactlyTheEdgesPastIt(const double (&ratio)[5]) {
  constexpr int kParticles = 6;
  constexpr double kLimit = 0.1, kRest = 0.01;
  S rest[kParticles - 1];
  V3<S> p[kParticles], v[kParticles];
  Vec3 x = Vec3(0.02, -0.01, 0.03);
  double largest = -1.0;
  for (int i = 0; i < kParticles; ++i) {
    for (int l = 0; l < kLaneWidth<S>; ++l) setLane(&p[i], l, x), setLane(&v[i], l, Vec3::Zero());
    if (i + 1 == kParticles) break;
    rest[i] = splat<S>(kRest);
    const double length = ratio[i] * (1.0 + kLimit) * kRest;
    largest = std::max(largest, length / kRest - 1.0);
    x += length * (i % 2 == 0 ? Vec3::UnitX() : Vec3::UnitY());
  }
  S max_strain = splat<S>(0.0);
  uint64_t projected[kLaneWidth<S>] = {};
  limitStrainEdges(rest, kLimit, true, 1e-3, p, v, kParticles, &max_strain, projected);
  int past = 0;
  for (double r : ratio) past += r > 1.0;
  for (int l = 0; l < kLaneWidth<S>; ++l) {
    EXPECT_EQ(projected[l], uint64_t(past)) << "lane " << l;
    EXPECT_NEAR(laneValue(max_strain, l), largest, 1e-6) << "lane " << l;
    for (int i = 0; i + 1 < kParticles; ++i) {
      const double length = (lane(p[i + 1], l) - lane(p[i], l)).norm();
      // Float lanes hold 1 cm edges to about 1e-9 m.
      EXPECT_LE(length, (1.0 + kLimit) * kRest * (1.0 + 2e-7)) << "lane " << l << ", edge " << i;
    }
  }
}

constexpr double kEdgesNearTheLimit[5] = {0.9, 1.0 - 3e-6, 1.0 + 3e-6, 0.5, 1.0 + 3e-6};
constexpr double kEdgesClearOfTheLimit[5] = {0.9, 0.95, 0.97, 0.5, 0.99};

}  // namespace

TEST(StrandBlock, TheStrainLimitProjectsExactlyTheEdgesPastItInFloat16Lanes) {
  expectTheLimitProjectsExactlyTheEdgesPastIt<LaneFloat16>(kEdgesNearTheLimit);
  expectTheLimitProjectsExactlyTheEdgesPastIt<LaneFloat16>(kEdgesClearOfTheLimit);
}
TEST(StrandBlock, TheStrainLimitProjectsExactlyTheEdgesPastItInFloat8Lanes) {
  expectTheLimitProjectsExactlyTheEdgesPastIt<LaneFloat8>(kEdgesNearTheLimit);
  expectTheLimitProjectsExactlyTheEdgesPastIt<LaneFloat8>(kEdgesClearOfTheLimit);
}
TEST(StrandBlock, TheStrainLimitProjectsExactlyTheEdgesPastItInOneLane) {
  expectTheLimitProjectsExactlyTheEdgesPastIt<double>(kEdgesNearTheLimit);
  expectTheLimitProjectsExactlyTheEdgesPastIt<double>(kEdgesClearOfTheLimit);
}
