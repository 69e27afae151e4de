// What the offline runner's own measurements cost against the stepping (docs/performance.md,
// "Measurements"): the built-in scene at each strand count, run `runs` times with the runner's
// default measurements, the wall seconds of the measurements (RunSummary::measure_wall_s) over the
// wall seconds of step() (wall_s), median over the runs, and the median seconds of each
// measurement. Then, on the last run's final state, the sampled clump distance and tangle count
// (RunOptions::sample_strands) against the exact ones. Prints the CPU model and whether it has
// AVX-512. The figures depend on the solver setting: pass the one to measure with --set.
// usage: bench_measurements [--strands N,N,...] [--seconds T] [--runs R] [--set name=value ...]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "bench_common.h"
#include "wet_curly_hair/core/metrics.h"
#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/io/scene_setup.h"
#include "wet_curly_hair/runner/offline_run.h"

using namespace wet_curly_hair;
using wet_curly_hair::bench::cpuLine;
using wet_curly_hair::bench::now;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0.0 : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

struct Options {
  std::vector<int> strands = {1000, 10000};
  double seconds = 1.0;
  int runs = 3;
  std::vector<std::pair<std::string, std::string>> sets;
};

bool parse(int argc, char** argv, Options* o, std::string* why) {
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (k + 1 >= argc) {
      *why =
          "usage: bench_measurements [--strands N,N,...] [--seconds T] [--runs R] "
          "[--set name=value ...]";
      return false;
    }
    const std::string v = argv[++k];
    if (a == "--strands") {
      o->strands.clear();
      std::stringstream list(v);
      std::string item;
      while (std::getline(list, item, ',')) o->strands.push_back(std::atoi(item.c_str()));
    } else if (a == "--seconds") {
      o->seconds = std::atof(v.c_str());
    } else if (a == "--runs") {
      o->runs = std::max(1, std::atoi(v.c_str()));
    } else if (a == "--set" && v.find('=') != std::string::npos) {
      o->sets.emplace_back(v.substr(0, v.find('=')), v.substr(v.find('=') + 1));
    } else {
      *why = "unknown option " + a;
      return false;
    }
  }
  return true;
}

/// One strand count: the runs, the medians, the sampled against the exact neighbour figures.
bool benchStrands(const Options& o, int strands, std::string* why) {
  io::SceneConfig scene = io::builtinScene();
  for (const auto& [name, value] : o.sets)
    if (!io::parseSceneYaml(io::dottedToYaml(name, value), &scene, why)) return false;
  scene.groom.strands = strands;
  scene.run.seconds = o.seconds;
  std::vector<double> fraction, step_s, measure_s;
  std::map<std::string, std::vector<double>> each;
  HairState last;
  io::RunSummary s;
  for (int r = 0; r < o.runs; ++r) {
    io::RunOptions options;
    options.on_frame = [&](int f, const HairState& state) {
      if (f == std::lround(o.seconds / scene.run.frame_s)) last = state;
    };
    if (!io::runScene(scene, options, &s, why)) return false;
    fraction.push_back(s.measure_wall_s / s.wall_s);
    step_s.push_back(s.wall_s);
    measure_s.push_back(s.measure_wall_s);
    for (size_t k = 0; k < s.measurements.size(); ++k)
      each[s.measurements[k]].push_back(s.measurement_s[k]);
  }
  std::printf(
      "%d strands x %d, %g s (%llu frames), %s, %d thread(s), %d runs: stepping %.3f s, "
      "measurements %.3f s = %.1f %% of stepping (median)\n",
      strands, scene.groom.particles, o.seconds, static_cast<unsigned long long>(s.steps),
      s.integrator.c_str(), s.threads, o.runs, median(step_s), median(measure_s),
      100.0 * median(fraction));
  for (const std::string& name : s.measurements)
    std::printf("  %-16s %8.4f s  %5.2f %%\n", name.c_str(), median(each[name]),
                100.0 * median(each[name]) / median(step_s));
  // The sampled figures of the last frame against the exact ones (timed on one thread each).
  HairModel model;
  if (!io::buildSceneModel(scene, &model, why)) return false;
  MetricScratch scratch;
  const int threads = scene.solver.integrator.threads;
  const double t0 = now();
  const int exact =
      tangleCount(model, displayPositions(last), scene.run.strand_radius_m, &scratch, threads);
  const double t1 = now();
  const double clump = clumpDistance(model, displayPositions(last), last.saturation,
                                     scene.run.clump_search_m, &scratch, threads);
  const double t2 = now();
  std::printf(
      "  sampled every %d-th strand (%d): tangles %d against %d exact (%+.2f %%, exact "
      "count %.3f s), clump distance %.4f mm against %.4f mm exact (%+.2f %%, exact %.3f "
      "s)\n",
      s.sample_stride, s.sampled_strands, s.tangles, exact,
      exact ? 100.0 * (double(s.tangles) / exact - 1.0) : 0.0, t1 - t0, 1e3 * s.clump_distance_m,
      1e3 * clump, clump > 0.0 ? 100.0 * (s.clump_distance_m / clump - 1.0) : 0.0, t2 - t1);
  std::fflush(stdout);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  std::string why;
  if (!parse(argc, argv, &o, &why)) {
    std::fprintf(stderr, "bench_measurements: %s\n", why.c_str());
    return 2;
  }
  std::printf("CPU: %s\n", cpuLine().c_str());
  for (int strands : o.strands) {
    if (!benchStrands(o, strands, &why)) {
      std::fprintf(stderr, "bench_measurements: %s\n", why.c_str());
      return 1;
    }
  }
  return 0;
}
