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
  scatterBlock(blk);
  for (int l = 0; l < width; ++l)
    for (int i = 0; i < blk.n; ++i)
      EXPECT_LT((scene.state.position[blk.begin[l] + i] - before[blk.begin[l] + i]).norm(), 1e-14);
}

TEST(StrandBlock, TheCarryKeepsDoublePositionsInFloat16Lanes) {
  expectTheCarryKeepsDoublePositions<LaneFloat16>();
}
TEST(StrandBlock, TheCarryKeepsDoublePositionsInFloat8Lanes) {
  expectTheCarryKeepsDoublePositions<LaneFloat8>();
}
