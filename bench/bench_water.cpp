// What the water stage (core/water.h) costs against the dynamics: the built-in scene at each
// strand count under a shower over the head and a dryer around it, every frame timed twice in
// one run: step() (the dynamics) and stepWater() (sources, exchange, wicking and gravity flow,
// drip, evaporation) with applyWaterMass(), and stepWater() once more with the exchange off
// (restored after, so the run is the full stage's). Prints medians over the frames, the share of
// the dynamics, the CPU model and whether it has AVX-512. Pass the solver setting to measure with
// --set. usage: bench_water [--strands N,N,...] [--frames F] [--set name=value ...]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "bench_common.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/water.h"
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

double mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / v.size();
}

struct Options {
  std::vector<int> strands = {1000};
  int frames = 40;
  std::vector<std::string> sets;
};

bool parse(int argc, char** argv, Options* o, std::string* why) {
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (k + 1 >= argc) {
      *why = a + ": needs a value";
      return false;
    }
    const std::string v = argv[++k];
    if (a == "--strands") {
      o->strands.clear();
      std::stringstream list(v);
      std::string item;
      while (std::getline(list, item, ',')) o->strands.push_back(std::atoi(item.c_str()));
    } else if (a == "--frames") {
      o->frames = std::atoi(v.c_str());
    } else if (a == "--set") {
      o->sets.push_back(v);
    } else {
      *why = "unknown option " + a;
      return false;
    }
  }
  return o->frames > 0 && !o->strands.empty();
}

/// One strand count: medians of the per-frame wall seconds of step() and stepWater().
bool measure(const Options& o, int strands, std::string* why) {
  io::SceneConfig scene = io::builtinScene();
  scene.groom.strands = strands;
  for (const std::string& s : o.sets) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos ||
        !io::parseSceneYaml(io::dottedToYaml(s.substr(0, eq), s.substr(eq + 1)), &scene, why))
      return false;
  }
  WaterSource shower;
  shower.center_m = Vec3(0.0, 0.0, 0.5);
  shower.radius_m = 0.15;
  shower.rate_kg_s = 0.1;
  scene.water_sources.sources.push_back(shower);
  WaterDryer dryer;
  dryer.half_extents_m = Vec3(0.3, 0.3, 0.3);
  scene.water_sources.dryers.push_back(dryer);
  HairModel model;
  if (!io::buildSceneModel(scene, &model, why)) return false;
  HairState state = io::initialSceneState(scene, model);
  reconcileWater(model, scene.water, &state);
  WaterConfig no_exchange = scene.water;
  no_exchange.exchange_per_s = 0.0;
  const double frame = scene.run.frame_s;
  std::vector<double> dyn, water, water_no_exchange;
  for (int f = 0; f < o.frames; ++f) {
    const double t0 = f * frame;
    const std::vector<double> held = state.water_kg, sat = state.saturation;
    const WaterLedger ledger = state.water_ledger;
    const double exchange_until = state.water_scratch.exchange_until_s;
    double t = now();
    stepWater(model, no_exchange, scene.water_sources, scene.solver.gravity_m_s2, t0, frame, &state,
              nullptr);
    water_no_exchange.push_back(now() - t);
    state.water_kg = held;
    state.saturation = sat;
    state.water_ledger = ledger;
    state.water_scratch.exchange_until_s = exchange_until;
    t = now();
    stepWater(model, scene.water, scene.water_sources, scene.solver.gravity_m_s2, t0, frame, &state,
              nullptr);
    water.push_back(now() - t);
    StepInputs in;
    in.head_start = headPose(scene.motion, t0);
    in.head_end = headPose(scene.motion, t0 + frame);
    StepStats stats;
    t = now();
    step(model, scene.solver, in, frame, &state, &stats);
    dyn.push_back(now() - t);
  }
  // The exchange runs every water.exchange_interval_s, not every frame: the mean carries its
  // share, the median may not.
  const double d = median(dyn), w = median(water), wn = median(water_no_exchange);
  const double dm = mean(dyn), wm = mean(water);
  std::printf(
      "strands %d particles %d: dynamics %.3f ms/frame (mean %.3f), water %.3f ms/frame (mean "
      "%.3f; %.2f %% of the dynamics, means %.2f %%; without the exchange %.3f ms, %.2f %%), held "
      "%.4f kg\n",
      strands, model.particleCount(), 1e3 * d, 1e3 * dm, 1e3 * w, 1e3 * wm, 100.0 * w / d,
      100.0 * wm / dm, 1e3 * wn, 100.0 * wn / d, heldWater(state));
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  std::string why;
  if (!parse(argc, argv, &o, &why)) {
    std::fprintf(stderr,
                 "bench_water: %s\nusage: bench_water [--strands N,N,...] [--frames F] "
                 "[--set name=value ...]\n",
                 why.c_str());
    return 2;
  }
  std::printf("CPU: %s; medians over %d frames (the water stage on one thread)\n",
              cpuLine().c_str(), o.frames);
  for (int n : o.strands) {
    if (!measure(o, n, &why)) {
      std::fprintf(stderr, "bench_water: %s\n", why.c_str());
      return 1;
    }
  }
  return 0;
}
