// The cohesion lattice's error against exact sums (docs/physics.md §7.3, "Node volumes"): the
// built-in scene (curly, wet toward the tips, nodding) with the sphere behind the head of
// bench_followers, --strands output strands at follow ratio --follow-ratio, the guides stepped at
// midpoint 1/360 s for --frames output frames. At every 5th frame of the second half the display
// pass runs on copies of the state: exact with the sums at every particle (the reference), and the
// lattice (3 nodes per radius) with the sums at --gather-at all|guides, with the particle volumes
// and with the node volumes (solver.cohesion.grid_node_volumes). Prints |p^w - p^w_exact| RMS and
// max over the wet particles of the simulated strands and of the followers, and exact's offset
// |p^w - p| RMS.
// usage: bench_lattice_error [--strands N] [--follow-ratio K] [--frames F] [--gather-at all|guides]
//                            [--threads T]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "bench_common.h"
#include "wet_curly_hair/core/cohesion.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/io/scene.h"

using namespace wet_curly_hair;

namespace {

struct Options {
  int strands = 10000;
  int follow_ratio = 100;
  int frames = 40;
  int threads = 2;
  std::string gather_at = "guides";
};

bool parse(int argc, char** argv, Options* o) {
  const bool read =
      bench::readOptionPairs(argc, argv, [o](const std::string& a, const std::string& value) {
        const int v = std::atoi(value.c_str());
        if (a == "--gather-at")
          o->gather_at = value;
        else if (a == "--strands")
          o->strands = v;
        else if (a == "--follow-ratio")
          o->follow_ratio = v;
        else if (a == "--frames")
          o->frames = v;
        else if (a == "--threads")
          o->threads = v;
        else
          return false;
        return true;
      });
  return read && o->strands > 0 && o->follow_ratio > 0 && o->frames >= 2 && o->threads > 0 &&
         (o->gather_at == "all" || o->gather_at == "guides");
}

/// Sums of squared and largest distances from the reference, for simulated strands [0] and
/// followers [1].
struct ErrorSums {
  double squared[2] = {}, largest[2] = {};
  long count[2] = {};
  void add(int kind, double d) {
    squared[kind] += d * d;
    largest[kind] = std::max(largest[kind], d);
    ++count[kind];
  }
  double rms(int kind) const { return count[kind] ? std::sqrt(squared[kind] / count[kind]) : 0.0; }
};

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, &o)) {
    std::fprintf(stderr,
                 "usage: bench_lattice_error [--strands N > 0] [--follow-ratio K > 0] "
                 "[--frames F >= 2] [--gather-at all|guides] [--threads T > 0]\n");
    return 2;
  }
  io::SceneConfig config = io::builtinScene();
  config.groom.strands = o.strands;
  config.groom.follow_ratio = o.follow_ratio;
  config.solver.integrator.threads = o.threads;
  config.solver.integrator.substep_s = 1.0 / 360.0;
  bench::NoddingRun run;
  if (!run.build(config, "bench_lattice_error")) return 1;
  const io::SceneConfig& scene = run.scene;
  const HairModel& model = run.model;
  const HairState& state = run.state;
  const int simulated_end = model.strandBegin(model.simulatedStrandCount());
  ErrorSums volumes[2];  // particle, node
  double offset_squared = 0.0;
  long wet_particles = 0;
  for (int f = 0; f < o.frames; ++f) {
    run.stepFrame(f);
    if (f < o.frames / 2 || f % 5 != 0) continue;
    CohesionConfig c = scene.solver.cohesion;
    c.refresh_period_s = 0.0;
    c.evaluation = "exact";
    c.gather_at = "all";
    HairState exact = state, lattice[2] = {state, state};
    computeDisplayCohesion(model, c, &exact, o.threads);
    c.evaluation = "grid";
    c.gather_at = o.gather_at;
    for (int v = 0; v < 2; ++v) {
      c.grid_node_volumes = v == 1;
      computeDisplayCohesion(model, c, &lattice[v], o.threads);
    }
    for (int i = 0; i < model.particleCount(); ++i) {
      if (state.saturation[i] <= 0.0) continue;
      const int kind = i < simulated_end ? 0 : 1;
      for (int v = 0; v < 2; ++v)
        volumes[v].add(kind, (displayPositions(lattice[v])[i] - displayPositions(exact)[i]).norm());
      offset_squared += (displayPositions(exact)[i] - state.position[i]).squaredNorm();
      ++wet_particles;
    }
  }
  std::printf("%d strands, K = %d, sums at %s, %d frames: |p^w - p^w_exact| over wet particles\n",
              o.strands, o.follow_ratio, o.gather_at.c_str(), o.frames);
  const char* name[2] = {"particle volumes", "node volumes"};
  for (int v = 0; v < 2; ++v)
    std::printf(
        "%s: simulated strands RMS %.4f mm, max %.3f mm; followers RMS %.4f mm, max %.3f mm\n",
        name[v], 1e3 * volumes[v].rms(0), 1e3 * volumes[v].largest[0], 1e3 * volumes[v].rms(1),
        1e3 * volumes[v].largest[1]);
  std::printf("exact offset |p^w - p| RMS %.4f mm\n",
              1e3 * std::sqrt(offset_squared / std::max(1L, wet_particles)));
  return 0;
}
