// The stage clock (src/io/stage_clock.cpp) against std::chrono::steady_clock, the independent
// reference it is scaled by: both measure the same wall time.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>

#include "wet_curly_hair/io/stage_clock.h"

using namespace wet_curly_hair;

namespace {

double steadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

/// Over 20-60 ms of sleep the two clocks advance alike, to the calibration's error (about 1e-5
/// of the interval) plus a read at each end of each (microseconds at most, here 2 % of 20 ms):
/// a rate off by 2 % or an origin off by any interval shows.
TEST(StageClock, AdvancesAsTheSteadyClockDoes) {
  io::stageClockSeconds();  // the rate measured first
  for (int ms : {20, 60}) {
    const double steady0 = steadySeconds(), stage0 = io::stageClockSeconds();
    std::this_thread::sleep_for(std::chrono::milliseconds(ms));
    const double steady1 = steadySeconds(), stage1 = io::stageClockSeconds();
    const double steady = steady1 - steady0, stage = stage1 - stage0;
    EXPECT_NEAR(stage, steady, 0.02 * steady) << ms << " ms";
    // The same origin: each clock's reading is the other's, not only their differences.
    EXPECT_NEAR(stage1, steady1, 0.02 * steady) << ms << " ms";
  }
}

/// It never runs backwards, read after read.
TEST(StageClock, NeverRunsBackwards) {
  double last = io::stageClockSeconds();
  for (int k = 0; k < 100000; ++k) {
    const double now = io::stageClockSeconds();
    ASSERT_GE(now, last) << "read " << k;
    last = now;
  }
}

/// On x86-64 machines with an invariant counter (every one this project runs on) it reads the
/// counter; the build's other machines take steady_clock.
TEST(StageClock, ReadsTheCounterWhereItIsInvariant) {
#if defined(__x86_64__)
  // /proc/cpuinfo names the same CPUID bit (constant_tsc and nonstop_tsc together).
  FILE* f = std::fopen("/proc/cpuinfo", "r");
  ASSERT_NE(f, nullptr);
  char line[8192];
  bool constant = false, nonstop = false;
  while (std::fgets(line, sizeof line, f)) {
    constant = constant || std::strstr(line, " constant_tsc") != nullptr;
    nonstop = nonstop || std::strstr(line, " nonstop_tsc") != nullptr;
  }
  std::fclose(f);
  EXPECT_EQ(io::stageClockUsesTsc(), constant && nonstop);
#else
  EXPECT_FALSE(io::stageClockUsesTsc());
#endif
}
