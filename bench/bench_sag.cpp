// Sag-free start (docs/physics.md §8): how far the built-in scene's hair moves from its groom
// with and without solver.sag_free.
//
// Cases, each with the option off and on, on the built-in scene (200 curly strands, soft
// springs, head ellipsoid and neck): "dry still" (saturation 0, still head: pure sag), "wet still"
// (the scene's wetting, curl exaggeration on: the wet curls are meant to tighten), "dry nod then
// still" (the scene's nod for one period, 2 s, then the head stops at its start pose: does the
// hair come back?). Figures after `seconds` (default 2 s; 4 s for the nod case): RMS and max
// particle distance to the groom / strand length, the tip third's curl radius
// (tipCurlShape) against the groom's, head contacts, repairs.
// usage: bench_sag [--scene FILE.yaml] [--seconds T] [--set name=value ...]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/metrics.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/io/scene_setup.h"
#include "wet_curly_hair/runner/offline_run.h"

using namespace wet_curly_hair;

namespace {

struct Result {
  double rms = 0, max = 0, tip_radius_m = 0, groom_tip_radius_m = 0;
  uint64_t head_contacts = 0, repairs = 0;
};

bool runCase(io::SceneConfig scene, bool sag_free, double seconds, Result* r, std::string* why) {
  scene.solver.sag_free = sag_free;
  HairModel model;
  if (!io::buildSceneModel(scene, &model, why)) return false;
  const HeadMotionConfig& motion = scene.motion;
  HairState state = io::initialSceneState(scene, model);
  const double frame = scene.run.frame_s;
  const long frames = std::lround(seconds / frame);
  for (long f = 0; f < frames; ++f) {
    StepInputs in{headPose(motion, f * frame), headPose(motion, (f + 1) * frame)};
    StepStats stats;
    step(model, scene.solver, in, frame, &state, &stats);
    r->head_contacts += stats.head_contacts;
    r->repairs += stats.repaired_strands;
  }
  const Pose head = headPose(motion, frames * frame);
  Vec3List in_head(state.position.size());
  for (size_t i = 0; i < in_head.size(); ++i) in_head[i] = head.applyInverse(state.position[i]);
  double sum = 0.0;
  long count = 0;
  for (int s = 0; s < model.strandCount(); ++s) {
    for (int i = model.strandBegin(s) + 1; i < model.strandBegin(s) + model.strandSize(s); ++i) {
      const double d = (in_head[i] - model.rest_position_head[i]).norm() / model.strand_length_m[s];
      sum += d * d;
      ++count;
      r->max = std::max(r->max, d);
    }
  }
  r->rms = std::sqrt(sum / count);
  r->tip_radius_m = tipCurlShape(model, in_head).radius_m;
  r->groom_tip_radius_m = tipCurlShape(model, model.rest_position_head).radius_m;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  io::SceneConfig base = io::builtinScene();
  double seconds = 2.0;
  std::vector<std::string> names;
  std::vector<double> values;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    std::string why;
    if (a == "--scene" && k + 1 < argc) {
      if (!io::loadSceneFile(argv[++k], &base, &why)) {
        std::fprintf(stderr, "bench_sag: %s\n", why.c_str());
        return 2;
      }
    } else if (a == "--seconds" && k + 1 < argc) {
      seconds = std::atof(argv[++k]);
    } else if (a == "--set" && k + 1 < argc) {
      const std::string kv = argv[++k];
      const size_t eq = kv.find('=');
      if (eq == std::string::npos) {
        std::fprintf(stderr, "bench_sag: --set takes name=value\n");
        return 2;
      }
      names.push_back(kv.substr(0, eq));
      values.push_back(std::atof(kv.c_str() + eq + 1));
    } else {
      std::fprintf(stderr,
                   "usage: bench_sag [--scene FILE.yaml] [--seconds T] [--set name=value ...]\n");
      return 2;
    }
  }
  std::string why;
  if (!io::applyParameters(names, values, &base, nullptr, &why)) {
    std::fprintf(stderr, "bench_sag: %s\n", why.c_str());
    return 2;
  }
  struct Case {
    const char* name;
    bool wet;
    bool nod;
  };
  const Case cases[] = {{"dry, still head", false, false},
                        {"wet (scene's saturation), still head", true, false},
                        {"dry, nod 2 s then still", false, true}};
  std::printf(
      "| case | sag_free | t (s) | RMS dist / length | max dist / length | tip curl radius "
      "(groom) mm | change | head contacts | repairs |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    io::SceneConfig scene = base;
    if (!c.wet) scene.saturation.root = scene.saturation.tip = 0.0;
    double t = seconds;
    if (c.nod) {
      scene.motion.type = "nod";
      scene.motion.start_s = 0.0;
      scene.motion.stop_s = 1.0 / scene.motion.freq_hz;  // one period: back at the start pose
      t = std::max(seconds, scene.motion.stop_s + 2.0);
    } else {
      scene.motion.type = "still";
    }
    for (bool on : {false, true}) {
      Result r;
      if (!runCase(scene, on, t, &r, &why)) {
        std::fprintf(stderr, "bench_sag: %s\n", why.c_str());
        return 1;
      }
      std::printf("| %s | %s | %.3g | %.3g | %.3g | %.2f (%.2f) | %+.1f %% | %llu | %llu |\n",
                  c.name, on ? "on" : "off", t, r.rms, r.max, 1e3 * r.tip_radius_m,
                  1e3 * r.groom_tip_radius_m, 100.0 * (r.tip_radius_m / r.groom_tip_radius_m - 1.0),
                  static_cast<unsigned long long>(r.head_contacts),
                  static_cast<unsigned long long>(r.repairs));
      std::fflush(stdout);
    }
  }
  return 0;
}
