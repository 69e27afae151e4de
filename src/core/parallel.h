// Loops over strands, particles or lattice nodes shared among the solver's threads (OpenMP),
// and a plain loop for one thread: libgomp allocates and frees a team for every parallel region
// of one thread, and a step allocates nothing (test_solver_allocations). Private to the core.
#pragma once

#include <cstdint>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace wet_curly_hair {
namespace detail {

/// The calling thread's index in the current team (0 outside a parallel region).
inline int threadIndex() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

enum class Schedule { kStatic, kDynamic };

/// body(i) for i in [0, count) on `threads` threads with the given schedule (chunk 0: OpenMP's
/// default static partition), or in order on this thread when threads <= 1.
template <typename Index, typename Body>
void parallelFor(int threads, Schedule schedule, int chunk, Index count, Body&& body) {
  if (threads <= 1) {
    for (Index i = 0; i < count; ++i) body(i);
    return;
  }
  if (schedule == Schedule::kDynamic) {
#pragma omp parallel for num_threads(threads) schedule(dynamic, chunk)
    for (Index i = 0; i < count; ++i) body(i);
  } else if (chunk > 0) {
#pragma omp parallel for num_threads(threads) schedule(static, chunk)
    for (Index i = 0; i < count; ++i) body(i);
  } else {
#pragma omp parallel for num_threads(threads) schedule(static)
    for (Index i = 0; i < count; ++i) body(i);
  }
}

/// The sum of body(i) (integers: the same for any thread count), dynamic schedule.
template <typename Index, typename Body>
int64_t parallelSum(int threads, int chunk, Index count, Body&& body) {
  int64_t total = 0;
  if (threads <= 1) {
    for (Index i = 0; i < count; ++i) total += body(i);
    return total;
  }
#pragma omp parallel for num_threads(threads) schedule(dynamic, chunk) reduction(+ : total)
  for (Index i = 0; i < count; ++i) total += body(i);
  return total;
}

/// body(thread, team) once on each of `threads` threads (body(0, 1) on this one when
/// threads <= 1).
template <typename Body>
void parallelRegion(int threads, Body&& body) {
  if (threads <= 1) {
    body(0, 1);
    return;
  }
#pragma omp parallel num_threads(threads)
  {
#ifdef _OPENMP
    body(omp_get_thread_num(), omp_get_num_threads());
#else
    body(0, 1);
#endif
  }
}

}  // namespace detail
}  // namespace wet_curly_hair
