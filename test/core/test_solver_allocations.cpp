// "No allocation in a step" (docs/performance.md): step() runs on the preallocated
// HairState only. This binary counts every call of the global operator new; after a warm-up
// (the cohesion grid may size its buffers on the first wet step), further steps of a wet,
// cohesive, nodding scene with an obstacle in reach must allocate nothing, for every integrator
// and for 1 and 2 threads.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"

namespace {
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

using namespace wet_curly_hair;

namespace {

/// Allocations made by `steps` steps of the scene after `warmup` steps.
long allocationsInSteps(const std::string& method, int threads, int warmup, int steps) {
  SolverConfig c;
  c.integrator.method = method;
  c.integrator.substep_s = method == "explicit" ? 2e-4 : 1.0 / 240;
  c.integrator.threads = threads;
  GroomConfig g;
  g.strands = 40;
  HairModel model;
  std::string why;
  EXPECT_TRUE(buildModel(generateGroom(g, EllipsoidShape()), 1e-4, HeadShape(), c, &model, &why))
      << why;
  Obstacles obstacles;
  AnalyticObstacle sphere;
  sphere.center_m = Vec3(-0.16, 0.0, -0.05);
  sphere.radius_m = 0.05;
  obstacles.analytic.push_back(sphere);
  HeadMotionConfig nod;
  nod.type = "nod";
  HairState state = makeState(model, headPose(nod, 0.0), headTwist(nod, 0.0));
  SaturationCommand wet;
  wet.root_value = 0.5;
  wet.tip_value = 1.0;
  applySaturation(model, wet, headPose(nod, 0.0), &state);
  const double frame = 1.0 / 60;
  long during = 0;
  uint64_t cohesion = 0, obstacle = 0;
  for (int f = 0; f < warmup + steps; ++f) {
    StepInputs in{headPose(nod, f * frame), headPose(nod, (f + 1) * frame), &obstacles};
    StepStats stats;
    const long before = g_allocations.load();
    step(model, c, in, frame, &state, &stats);
    if (f >= warmup) during += g_allocations.load() - before;
    cohesion += stats.cohesion_particles;
    obstacle += stats.obstacle_particle_substeps;
  }
  // The stages that could allocate ran: cohesion found neighbours, the obstacle was in reach.
  EXPECT_GT(cohesion, 0u) << method;
  EXPECT_GT(obstacle, 0u) << method;
  return during;
}

TEST(SolverAllocations, CountingWorks) {
  const long before = g_allocations.load();
  std::vector<double>* v = new std::vector<double>(10);
  delete v;
  EXPECT_GE(g_allocations.load() - before, 2);
}

TEST(SolverAllocations, AStepAllocatesNothing) {
  for (const char* method : {"explicit", "backward_euler", "theta", "midpoint"}) {
    for (int threads : {1, 2}) {
      EXPECT_EQ(allocationsInSteps(method, threads, 3, 10), 0) << method << ", " << threads
                                                                << " thread(s)";
    }
  }
}

}  // namespace
