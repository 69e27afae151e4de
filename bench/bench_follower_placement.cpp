// The follower placement alone (updateFollowers, followers.h), or with --stage display the
// cohesion display pass alone (computeDisplayCohesion, cohesion.h; --gather-at all or guides,
// --node-volumes: solver.cohesion.grid_node_volumes):
// the built-in scene (curly, wet toward the tips, nodding) with the sphere behind the head of
// bench_followers, at --strands output strands and follow ratio --follow-ratio, stepped
// --warm-frames output frames so that the guides have moved; then the same frame's stage timed
// --runs times on --threads threads. Prints the median and the fastest wall time per follower
// particle (placement) or per output particle (display), with the CPU, and a hash of the stage's
// output (FNV-1a of the bytes of every particle's position, or display position with --stage
// display): the same for any thread count, and the check that a change meant to move no output
// moved none (run both builds at the same options). The saturation
// does not change between the runs, so after the first the followers' exaggerated rest shapes
// are the state's held copies, as on every frame of a scene without water or commands. The
// machines of docs/followers.md vary by tens of % from minute to minute: compare two builds by
// running each one's own binary alternately, several times each (another commit built in a git
// worktree beside this one; swapping only the libraries with LD_LIBRARY_PATH is wrong once
// HairState's layout differs between the two).
// usage: bench_follower_placement [--strands N] [--follow-ratio K] [--warm-frames F] [--runs R]
//                                 [--threads T] [--stage placement|display] [--gather-at
//                                 all|guides] [--node-volumes true|false]
//                                 [--wet-sums auto|particles|nodes] [--cells 2..16]
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench_common.h"
#include "wet_curly_hair/core/cohesion.h"
#include "wet_curly_hair/core/cohesion_grid.h"
#include "wet_curly_hair/core/followers.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/io/scene_setup.h"

using namespace wet_curly_hair;

namespace {

struct Options {
  int strands = 10000;
  int follow_ratio = 100;
  int warm_frames = 20;
  int runs = 31;
  int threads = 1;
  std::string stage = "placement";
  std::string gather_at = CohesionConfig().gather_at;  ///< the default unless --gather-at
  /// solver.cohesion.grid_node_volumes: the default unless --node-volumes.
  std::string node_volumes = CohesionConfig().grid_node_volumes ? "true" : "false";
  std::string wet_sums = CohesionConfig().grid_wet_sums;  ///< the default unless --wet-sums
  int cells = CohesionConfig().grid_cells_per_radius;     ///< the default unless --cells
};

/// FNV-1a (64 bits) of the bytes of positions: equal positions to the bit give equal hashes.
uint64_t positionHash(const Vec3List& positions) {
  uint64_t hash = 1469598103934665603ull;
  const unsigned char* byte = reinterpret_cast<const unsigned char*>(positions.data());
  for (size_t k = 0; k < positions.size() * sizeof(Vec3); ++k) {
    hash ^= byte[k];
    hash *= 1099511628211ull;
  }
  return hash;
}

bool parse(int argc, char** argv, Options* o) {
  const bool read =
      bench::readOptionPairs(argc, argv, [o](const std::string& a, const std::string& value) {
        const int v = std::atoi(value.c_str());
        if (a == "--stage")
          o->stage = value;
        else if (a == "--gather-at")
          o->gather_at = value;
        else if (a == "--node-volumes")
          o->node_volumes = value;
        else if (a == "--wet-sums")
          o->wet_sums = value;
        else if (a == "--cells")
          o->cells = v;
        else if (a == "--strands")
          o->strands = v;
        else if (a == "--follow-ratio")
          o->follow_ratio = v;
        else if (a == "--warm-frames")
          o->warm_frames = v;
        else if (a == "--runs")
          o->runs = v;
        else if (a == "--threads")
          o->threads = v;
        else
          return false;
        return true;
      });
  return read && o->strands > 0 && o->follow_ratio > 1 && o->warm_frames >= 0 && o->runs > 0 &&
         o->threads > 0 && (o->stage == "placement" || o->stage == "display") &&
         (o->gather_at == "all" || o->gather_at == "guides") &&
         (o->node_volumes == "true" || o->node_volumes == "false") &&
         (o->wet_sums == "auto" || o->wet_sums == "particles" || o->wet_sums == "nodes") &&
         o->cells >= 2 && o->cells <= 16;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, &o)) {
    std::fprintf(stderr,
                 "usage: bench_follower_placement [--strands N > 0] [--follow-ratio K > 1] "
                 "[--warm-frames F >= 0] [--runs R > 0] [--threads T > 0] "
                 "[--stage placement|display] [--gather-at all|guides] "
                 "[--node-volumes true|false] [--wet-sums auto|particles|nodes] [--cells 2..16]\n");
    return 2;
  }
  io::SceneConfig config = io::builtinScene();
  config.groom.strands = o.strands;
  config.groom.follow_ratio = o.follow_ratio;
  config.solver.integrator.threads = o.threads;
  config.solver.cohesion.gather_at = o.gather_at;
  config.solver.cohesion.grid_node_volumes = o.node_volumes == "true";
  config.solver.cohesion.grid_wet_sums = o.wet_sums;
  config.solver.cohesion.grid_cells_per_radius = o.cells;
  bench::NoddingRun run;
  if (!run.build(config, "bench_follower_placement")) return 1;
  for (int f = 0; f < o.warm_frames; ++f) run.stepFrame(f);
  const io::SceneConfig& scene = run.scene;
  const HairModel& model = run.model;
  HairState& state = run.state;
  const double frame = scene.run.frame_s;
  const Pose pose = headPose(scene.motion, o.warm_frames * frame);
  const bool display = o.stage == "display";
  const int timed = display
                        ? model.particleCount()
                        : model.particleCount() -
                              static_cast<int>(model.strandBegin(model.followers.guide_strands));
  std::vector<double> ns;
  for (int r = 0; r < o.runs; ++r) {
    const double t0 = bench::now();
    if (display)
      computeDisplayCohesion(model, scene.solver.cohesion, &state, o.threads);
    else
      updateFollowers(model, scene.solver, pose, &run.obstacles, frame, o.threads, &state);
    ns.push_back((bench::now() - t0) / timed * 1e9);
  }
  std::sort(ns.begin(), ns.end());
  // The lattice the display pass ran (grid_wet_sums "auto" resolved for this groom).
  const CohesionLattice lattice = cohesionLattice(model, scene.solver.cohesion);
  const std::string pass = "display pass, sums at " + o.gather_at + ", " + o.wet_sums + ": " +
                           (lattice.node_sums ? "at the nodes" : "at the particles") + ", " +
                           std::to_string(lattice.cells_per_radius) + " nodes per radius";
  std::printf(
      "%s\n%d strands, K = %d (%d %s particles), %s, %d thread(s), %d runs: "
      "median %.1f ns, fastest %.1f ns per particle\n",
      bench::cpuLine().c_str(), o.strands, o.follow_ratio, timed, display ? "output" : "follower",
      display ? pass.c_str() : "placement", o.threads, o.runs, ns[ns.size() / 2], ns.front());
  std::printf("output hash %016llx (%s)\n",
              static_cast<unsigned long long>(
                  positionHash(display ? displayPositions(state) : state.position)),
              display ? "display positions" : "positions");
  return 0;
}
