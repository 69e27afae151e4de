// The clock the runner and the node give the solver for its stage laps (StepInputs::clock).
#pragma once

namespace wet_curly_hair {
namespace io {

/// Seconds on a monotonic clock, for the solver's stage laps: about 8 reads per block of strands
/// and substep. Where the CPU's time-stamp counter runs at a constant rate (x86 with an
/// invariant TSC), its ticks scaled by a rate measured against std::chrono::steady_clock once,
/// at the first call (5 ms): a read cost 10 ns against steady_clock's 29 on an Intel Xeon under
/// KVM, where the laps took 2-3 % of a step. Elsewhere, steady_clock itself. Stage times only:
/// what must be a wall time (the real-time factor) reads steady_clock.
double stageClockSeconds();

/// Whether stageClockSeconds reads the time-stamp counter on this machine.
bool stageClockUsesTsc();

}  // namespace io
}  // namespace wet_curly_hair
