// Small helpers shared by the benchmark programs of bench/.
#pragma once

#include <chrono>
#include <fstream>
#include <string>

namespace wet_curly_hair {
namespace bench {

/// The first "model name" line of /proc/cpuinfo, and whether the flags list avx512f: named
/// beside every figure.
inline std::string cpuLine() {
  std::ifstream in("/proc/cpuinfo");
  std::string line, model = "unknown CPU";
  bool avx512 = false;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0 && model == "unknown CPU")
      model = line.substr(line.find(':') + 2);
    if (line.rfind("flags", 0) == 0 && line.find(" avx512f") != std::string::npos) avx512 = true;
  }
  return model + (avx512 ? ", avx512f" : ", no avx512f");
}

/// Monotonic wall seconds (the benches time; the core never reads a clock).
inline double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace bench
}  // namespace wet_curly_hair
