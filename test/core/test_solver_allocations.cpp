// "No allocation in a step" (docs/performance.md): step() runs on the preallocated
// HairState only. This binary replaces every way a C++ program gets heap memory and counts the
// calls: the C allocator (malloc, calloc, realloc, posix_memalign, aligned_alloc, memalign: Eigen's
// aligned_allocator behind Vec3List and Mat3List and libgomp use these) and every global operator
// new and delete (plain, array, nothrow, std::align_val_t, sized). The replacements forward to
// glibc's own allocator (__libc_*), so memory from either side is freed correctly. A positive
// control per entry point proves the counters see it; after a warm-up (the cohesion grid may size
// its buffers on the first wet step), further steps of a wet, cohesive, nodding scene with an
// obstacle in reach must allocate and free nothing, for every integrator and for 1 and 2 threads.
#include <gtest/gtest.h>
#include <malloc.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include "wet_curly_hair/core/followers.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"

extern "C" {
void* __libc_malloc(size_t size);
void* __libc_calloc(size_t count, size_t size);
void* __libc_realloc(void* p, size_t size);
void* __libc_memalign(size_t alignment, size_t size);
void __libc_free(void* p);
}

namespace {
std::atomic<long> g_allocations{0};
std::atomic<long> g_frees{0};

void countAllocation() { g_allocations.fetch_add(1, std::memory_order_relaxed); }
void countFree(void* p) {
  if (p != nullptr) g_frees.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

// ---------------------------------------------------------------- the C allocator
extern "C" {
void* malloc(size_t size) {
  countAllocation();
  return __libc_malloc(size);
}
void* calloc(size_t count, size_t size) {
  countAllocation();
  return __libc_calloc(count, size);
}
void* realloc(void* p, size_t size) {
  countAllocation();
  return __libc_realloc(p, size);
}
void free(void* p) {
  countFree(p);
  __libc_free(p);
}
void* memalign(size_t alignment, size_t size) {
  countAllocation();
  return __libc_memalign(alignment, size);
}
void* aligned_alloc(size_t alignment, size_t size) {
  countAllocation();
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, size_t alignment, size_t size) {
  countAllocation();
  if (alignment < sizeof(void*) || (alignment & (alignment - 1)) != 0) return EINVAL;
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
}  // extern "C"

// ---------------------------------------------------------------- operator new and delete
namespace {
void* newBytes(std::size_t size) {
  countAllocation();
  if (void* p = __libc_malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* newAligned(std::size_t size, std::align_val_t alignment) {
  countAllocation();
  if (void* p = __libc_memalign(static_cast<size_t>(alignment), size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void deleteBytes(void* p) noexcept {
  countFree(p);
  __libc_free(p);
}
}  // namespace

void* operator new(std::size_t n) { return newBytes(n); }
void* operator new[](std::size_t n) { return newBytes(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return newBytes(n);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void* operator new(std::size_t n, std::align_val_t a) { return newAligned(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return newAligned(n, a); }
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  try {
    return newAligned(n, a);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t& t) noexcept {
  return operator new(n, a, t);
}
void operator delete(void* p) noexcept { deleteBytes(p); }
void operator delete[](void* p) noexcept { deleteBytes(p); }
void operator delete(void* p, std::size_t) noexcept { deleteBytes(p); }
void operator delete[](void* p, std::size_t) noexcept { deleteBytes(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { deleteBytes(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { deleteBytes(p); }
void operator delete(void* p, std::align_val_t) noexcept { deleteBytes(p); }
void operator delete[](void* p, std::align_val_t) noexcept { deleteBytes(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { deleteBytes(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { deleteBytes(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { deleteBytes(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  deleteBytes(p);
}

using namespace wet_curly_hair;

namespace {

struct HeapCalls {
  long allocations = 0;
  long frees = 0;
};

/// Heap calls made while `f` runs (on any thread: OpenMP workers count too).
template <typename F>
HeapCalls heapCallsDuring(F&& f) {
  const long a = g_allocations.load(), d = g_frees.load();
  f();
  return {g_allocations.load() - a, g_frees.load() - d};
}

/// Keeps the optimiser from eliding an allocation whose result is otherwise unused (GCC removes
/// malloc/free and new/delete pairs it can see through).
void escape(void* p) { asm volatile("" : : "g"(p) : "memory"); }

/// Heap calls made by `steps` steps of the scene after `warmup` steps.
HeapCalls heapCallsInSteps(const std::string& method, int threads, int warmup, int steps,
                           int follow_ratio = 1, const std::string& wet_sums = "auto") {
  SolverConfig c;
  c.cohesion.grid_wet_sums = wet_sums;
  c.integrator.method = method;
  c.integrator.substep_s = method == "explicit" ? 2e-4 : 1.0 / 240;
  c.integrator.threads = threads;
  GroomConfig g;
  g.strands = 40;
  HairModel model;
  std::string why;
  EXPECT_TRUE(buildFollowerModel(generateGroom(g, EllipsoidShape()),
                                 GroomConfig().linear_density_kg_per_m, follow_ratio, HeadShape(),
                                 c, &model, &why))
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
  HeapCalls during;
  uint64_t cohesion = 0, obstacle = 0;
  for (int f = 0; f < warmup + steps; ++f) {
    StepInputs in{headPose(nod, f * frame), headPose(nod, (f + 1) * frame), &obstacles};
    StepStats stats;
    const HeapCalls calls = heapCallsDuring([&] { step(model, c, in, frame, &state, &stats); });
    if (f >= warmup) {
      during.allocations += calls.allocations;
      during.frees += calls.frees;
    }
    cohesion += stats.cohesion_particles;
    obstacle += stats.obstacle_particle_substeps;
  }
  // The stages that could allocate ran: cohesion found neighbours, the obstacle was in reach.
  EXPECT_GT(cohesion, 0u) << method;
  EXPECT_GT(obstacle, 0u) << method;
  return during;
}

// Positive controls: each way of getting memory, run between the same counters the steps use,
// is seen (an allocation and its free).
TEST(SolverAllocations, CountsTheCAllocator) {
  const auto once = [](auto allocate) {
    const HeapCalls calls = heapCallsDuring([&] {
      void* p = allocate();
      escape(p);
      free(p);
    });
    return calls.allocations == 1 && calls.frees == 1;
  };
  EXPECT_TRUE(once([] { return malloc(24); })) << "malloc";
  EXPECT_TRUE(once([] { return calloc(3, 8); })) << "calloc";
  EXPECT_TRUE(once([] { return realloc(nullptr, 24); })) << "realloc";
  EXPECT_TRUE(once([] { return memalign(64, 24); })) << "memalign";
  EXPECT_TRUE(once([] { return aligned_alloc(64, 64); })) << "aligned_alloc";
  int rc = -1;
  EXPECT_TRUE(once([&rc] {
    void* p = nullptr;
    rc = posix_memalign(&p, 64, 24);
    return p;
  })) << "posix_memalign";
  EXPECT_EQ(rc, 0);
}

TEST(SolverAllocations, CountsEveryOperatorNew) {
  struct alignas(64) Wide {
    double x[8];
  };
  const auto once = [](auto body) {
    const HeapCalls calls = heapCallsDuring(body);
    return calls.allocations == 1 && calls.frees == 1;
  };
  EXPECT_TRUE(once([] {
    double* p = new double(1.0);
    escape(p);
    delete p;
  })) << "new";
  EXPECT_TRUE(once([] {
    double* p = new double[4];
    escape(p);
    delete[] p;
  })) << "new[]";
  EXPECT_TRUE(once([] {
    double* p = new (std::nothrow) double(1.0);
    escape(p);
    delete p;
  })) << "new nothrow";
  EXPECT_TRUE(once([] {
    Wide* p = new Wide();
    escape(p);
    delete p;
  })) << "new align_val_t";
  EXPECT_TRUE(once([] {
    Wide* p = new Wide[3];
    escape(p);
    delete[] p;
  })) << "new[] align_val_t";
  EXPECT_TRUE(once([] {
    Wide* p = new (std::nothrow) Wide();
    escape(p);
    delete p;
  })) << "new align_val_t nothrow";
  EXPECT_TRUE(once([] {
    void* p = operator new(24, std::align_val_t(128), std::nothrow);
    escape(p);
    operator delete(p, std::align_val_t(128), std::nothrow);
  })) << "operator new/delete align_val_t nothrow";
}

TEST(SolverAllocations, SeesTemporaryContainersOfTheStateKinds) {
  // The containers HairState is made of: a std::vector and Eigen's aligned vectors.
  const HeapCalls plain = heapCallsDuring([] {
    std::vector<double> v(10);
    escape(v.data());
  });
  EXPECT_EQ(plain.allocations, 1);
  EXPECT_EQ(plain.frees, 1);
  const HeapCalls aligned = heapCallsDuring([] {
    Vec3List v(10, Vec3::Zero());
    Mat3List m(3, Mat3::Identity());
    escape(v.data());
    escape(m.data());
  });
  EXPECT_EQ(aligned.allocations, 2);
  EXPECT_EQ(aligned.frees, 2);
  // Growing one of the state's vectors inside a step would be seen the same way.
  HairState grown;
  grown.position.resize(4);
  const HeapCalls growth = heapCallsDuring([&] { grown.position.resize(64); });
  EXPECT_GE(growth.allocations, 1);
}

TEST(SolverAllocations, AStepAllocatesNothing) {
  for (const char* method : {"explicit", "backward_euler", "theta", "midpoint"}) {
    for (int threads : {1, 2}) {
      const HeapCalls calls = heapCallsInSteps(method, threads, 3, 10);
      EXPECT_EQ(calls.allocations, 0) << method << ", " << threads << " thread(s)";
      EXPECT_EQ(calls.frees, 0) << method << ", " << threads << " thread(s)";
    }
  }
}

// The lattice's sums convolved at its nodes (what `auto` takes on dense grooms; this one is
// sparse, so it takes the gathers above): their per-strand arrays live in the thread's scratch.
TEST(SolverAllocations, AStepWithTheNodeSumsAllocatesNothing) {
  for (int threads : {1, 2}) {
    const HeapCalls calls = heapCallsInSteps("midpoint", threads, 3, 10, 1, "nodes");
    EXPECT_EQ(calls.allocations, 0) << threads << " thread(s)";
    EXPECT_EQ(calls.frees, 0) << threads << " thread(s)";
  }
}

TEST(SolverAllocations, AStepWithFollowersAllocatesNothing) {
  for (int threads : {1, 2}) {
    const HeapCalls calls = heapCallsInSteps("midpoint", threads, 3, 10, 4);
    EXPECT_EQ(calls.allocations, 0) << threads << " thread(s)";
    EXPECT_EQ(calls.frees, 0) << threads << " thread(s)";
  }
}

}  // namespace
