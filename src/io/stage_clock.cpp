#include "wet_curly_hair/io/stage_clock.h"

#include <chrono>
#include <cstdint>

#if defined(__x86_64__)
#include <cpuid.h>
#include <immintrin.h>
#endif

namespace wet_curly_hair {
namespace io {
namespace {

double steadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// The counter's origin and rate against steady_clock; seconds_per_tick 0 when not used.
struct TscScale {
  uint64_t tick0 = 0;
  double seconds0 = 0.0;
  double seconds_per_tick = 0.0;
};

#if defined(__x86_64__)
/// CPUID leaf 0x80000007, EDX bit 8: the counter ticks at a constant rate in every power state.
bool invariantTsc() {
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  if (__get_cpuid(0x80000000u, &eax, &ebx, &ecx, &edx) == 0 || eax < 0x80000007u) return false;
  if (__get_cpuid(0x80000007u, &eax, &ebx, &ecx, &edx) == 0) return false;
  return (edx >> 8) & 1u;
}
#endif

/// Counts ticks over 5 ms of steady_clock (both read back to back at each end, so the rate is
/// good to the reads' cost over 5 ms, about 1e-5).
TscScale measureTscScale() {
  TscScale scale;
#if defined(__x86_64__)
  if (!invariantTsc()) return scale;
  const double s0 = steadySeconds();
  const uint64_t t0 = __rdtsc();
  double s1 = s0;
  while (s1 - s0 < 5e-3) s1 = steadySeconds();
  const uint64_t t1 = __rdtsc();
  if (t1 <= t0) return scale;
  scale.tick0 = t0;
  scale.seconds0 = s0;
  scale.seconds_per_tick = (s1 - s0) / static_cast<double>(t1 - t0);
#endif
  return scale;
}

const TscScale& tscScale() {
  static const TscScale scale = measureTscScale();
  return scale;
}

}  // namespace

double stageClockSeconds() {
  const TscScale& scale = tscScale();
#if defined(__x86_64__)
  if (scale.seconds_per_tick > 0.0)
    return scale.seconds0 + static_cast<double>(static_cast<int64_t>(__rdtsc() - scale.tick0)) *
                                scale.seconds_per_tick;
#endif
  return steadySeconds();
}

bool stageClockUsesTsc() { return tscScale().seconds_per_tick > 0.0; }

}  // namespace io
}  // namespace wet_curly_hair
