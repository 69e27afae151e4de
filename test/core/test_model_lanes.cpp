// The model's constants laid once in the stepper's lanes (HairModel::lanes,
// src/core/model_lanes.cpp): a step that reads them is the step that gathers them, to the bit, in
// every lane layout; every core function that changes the constants lays them again.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <utility>

#include "wet_curly_hair/core/followers.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/sag_free.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/water.h"

using namespace wet_curly_hair;

namespace {

Groom curlyGroom(int strands) {
  GroomConfig c;
  c.strands = strands;
  c.particles = 24;
  c.jitter = 0.1;
  return generateGroom(c, EllipsoidShape());
}

SolverConfig configFor(const std::string& layout) {
  SolverConfig c;
  c.integrator.method = "theta";
  c.integrator.substep_s = 1.0 / 240;
  c.integrator.lane_layout = layout;
  return c;
}

HairModel built(const Groom& groom, const SolverConfig& c) {
  HairModel m;
  std::string why;
  EXPECT_TRUE(buildModel(groom, GroomConfig().linear_density_kg_per_m, HeadShape(), c, &m, &why))
      << why;
  return m;
}

int laidBlocks(const HairModel& m) {
  int laid = 0;
  for (int64_t offset : m.lanes.block_offset) laid += offset >= 0;
  return laid;
}

/// Wet toward the tips, nodding, a sphere the hair falls onto: 12 frames of 1/60 s.
HairState run(const HairModel& model, const SolverConfig& c) {
  HeadMotionConfig nod;
  nod.type = "nod";
  nod.freq_hz = 1.5;
  HairState state = makeState(model, headPose(nod, 0.0), headTwist(nod, 0.0));
  SaturationCommand wet;
  wet.root_value = 0.3;
  wet.tip_value = 1.0;
  applySaturation(model, wet, headPose(nod, 0.0), &state);
  Obstacles obstacles;
  AnalyticObstacle sphere;
  sphere.center_m = state.position[model.strandSize(0) - 1] - Vec3(0.0, 0.0, 0.045);
  sphere.radius_m = 0.04;
  obstacles.analytic.push_back(sphere);
  const double frame = 1.0 / 60;
  for (int f = 0; f < 12; ++f) {
    StepInputs in{headPose(nod, f * frame), headPose(nod, (f + 1) * frame), &obstacles};
    step(model, c, in, frame, &state, nullptr);
  }
  return state;
}

bool sameBits(const Vec3List& a, const Vec3List& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

/// model.lanes is what laying them afresh from the model's arrays gives, byte for byte.
::testing::AssertionResult laidAfresh(const HairModel& model) {
  HairModel fresh = model;
  relayModelLanes(&fresh);
  const ModelLanes &a = model.lanes, &b = fresh.lanes;
  if (a.width != b.width || a.block_offset != b.block_offset ||
      a.block_particles != b.block_particles || a.chunks.size() != b.chunks.size())
    return ::testing::AssertionFailure() << "the blocks differ";
  if (std::memcmp(a.chunks.data(), b.chunks.data(), a.chunks.size() * sizeof(ModelLanes::Chunk)))
    return ::testing::AssertionFailure() << "the laid constants are stale";
  return ::testing::AssertionSuccess();
}

}  // namespace

TEST(ModelLanes, AStepOnTheLaidConstantsIsTheStepThatGathersThem) {
  // 37 strands: full blocks in every layout, and a last block that runs at full width in float8
  // and double8 (5 strands: laid, the padding lanes repeating the last strand), at half width in
  // float16 (5 of 16: gathered in float8) and alone in double4 (1 strand: one at a time).
  const Groom groom = curlyGroom(37);
  const std::pair<std::string, int> layouts[] = {
      {"float16", 2}, {"float8", 5}, {"double8", 5}, {"double4", 9}};
  for (const auto& [layout, blocks] : layouts) {
    const SolverConfig c = configFor(layout);
    const HairModel laid = built(groom, c);
    ASSERT_EQ(laid.lanes.width, c.integrator.laneWidth()) << layout;
    EXPECT_EQ(laidBlocks(laid), blocks) << layout;
    HairModel gathered = laid;
    gathered.lanes = ModelLanes{};
    const HairState a = run(laid, c), b = run(gathered, c);
    EXPECT_TRUE(sameBits(a.position, b.position)) << layout;
    EXPECT_TRUE(sameBits(a.velocity, b.velocity)) << layout;
    // and the hair moved: the comparison is not of two resting states
    EXPECT_GT((a.position.back() - laid.rest_position_head.back()).norm(), 1e-3) << layout;
  }
}

TEST(ModelLanes, AModelLaidForAnotherLayoutIsGathered) {
  const Groom groom = curlyGroom(20);
  const SolverConfig float16 = configFor("float16"), float8 = configFor("float8");
  const HairModel laid16 = built(groom, float16);
  HairModel gathered = laid16;
  gathered.lanes = ModelLanes{};
  EXPECT_TRUE(sameBits(run(laid16, float8).position, run(gathered, float8).position));
  SolverConfig off = float16;
  off.integrator.strand_lanes = false;
  EXPECT_EQ(built(groom, off).lanes.width, 0);  // one strand at a time: nothing to lay
}

TEST(ModelLanes, EveryCoreFunctionThatChangesTheConstantsLaysThemAgain) {
  const Groom groom = curlyGroom(40);
  SolverConfig c = configFor("float8");
  HairModel model = built(groom, c);
  ASSERT_GT(laidBlocks(model), 0);
  EXPECT_TRUE(laidAfresh(model)) << "buildModel";

  SolverConfig stiffer = c;
  stiffer.stretch.axial_stiffness_n *= 2.0;
  stiffer.stretch.damping_n_s *= 3.0;
  std::string why;
  const std::vector<double> k_before = model.stretch_k;
  ASSERT_TRUE(updateSpringConstants(stiffer, &model, &why)) << why;
  ASSERT_NE(model.stretch_k, k_before);
  EXPECT_TRUE(laidAfresh(model)) << "updateSpringConstants";
  // A parameter request that changes the layout (the node's ~set_parameters without a rebuild)
  // lays the lanes in the new one.
  stiffer.integrator.lane_layout = "float16";
  ASSERT_TRUE(updateSpringConstants(stiffer, &model, &why)) << why;
  EXPECT_EQ(model.lanes.width, 16);
  EXPECT_TRUE(laidAfresh(model)) << "updateSpringConstants, float16";

  const std::vector<double> rest_before = model.rest_edge_m;
  makeSagFree(stiffer, Vec3(0.0, 0.0, -9.81), &model, nullptr);
  ASSERT_NE(model.rest_edge_m, rest_before);
  EXPECT_TRUE(laidAfresh(model)) << "makeSagFree";

  HairState state = makeState(model, Pose(), Twist());
  for (size_t i = 0; i < state.water_kg.size(); ++i) state.water_kg[i] = 1e-7 * double(i % 7);
  const std::vector<double> mass_before = model.mass_kg;
  applyWaterMass(state, &model);
  ASSERT_NE(model.mass_kg, mass_before);
  EXPECT_TRUE(laidAfresh(model)) << "applyWaterMass";

  HairModel followed;
  ASSERT_TRUE(buildFollowerModel(groom, GroomConfig().linear_density_kg_per_m, 4, HeadShape(), c,
                                 &followed, &why))
      << why;
  ASSERT_EQ(followed.simulatedStrandCount(), 10);
  EXPECT_EQ(followed.lanes.block_offset.size(), 2u);  // the guides' blocks only
  EXPECT_TRUE(laidAfresh(followed)) << "buildFollowerModel";
}
