// Small helpers shared by the benchmark programs of bench/.
#pragma once

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/obstacles.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/io/scene_setup.h"
#include "wet_curly_hair/runner/offline_run.h"

namespace wet_curly_hair {
namespace bench {

/// The CPU, named beside every figure (io::describeCpu: its name, family and model numbers, and
/// whether it has avx512f).
inline std::string cpuLine() { return io::describeThisCpu(); }

/// Monotonic wall seconds (the benches time; the core never reads a clock).
inline double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Creates the output directory `dir` with its parents where missing. False, with a message on
/// stderr naming the directory and the reason, when it cannot (a file in the way, no permission):
/// without it every table and chart the bench writes there would be lost without a word.
inline bool makeOutputDirectory(const std::string& program, const std::string& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (!error && std::filesystem::is_directory(dir, error)) return true;
  std::fprintf(stderr, "%s: cannot use --out %s as a directory: %s\n", program.c_str(), dir.c_str(),
               error ? error.message().c_str() : "not a directory");
  return false;
}

/// Reads `--key value` pairs: take(key, value) for each, false on a key it does not know. False
/// (nothing more read) on a key without a value or an unknown key.
template <typename Take>
bool readOptionPairs(int argc, char** argv, Take take) {
  for (int i = 1; i < argc; i += 2) {
    if (i + 1 >= argc || !take(std::string(argv[i]), std::string(argv[i + 1]))) return false;
  }
  return true;
}

/// The sphere behind the head that the nodding hair swings into (bench_followers,
/// bench_follower_placement, bench_lattice_error).
inline AnalyticObstacle sphereBehindTheHead() {
  AnalyticObstacle sphere;
  sphere.center_m = Vec3(-0.16, 0.0, -0.05);
  sphere.radius_m = 0.05;
  return sphere;
}

/// A scene's model run with its motion and sphereBehindTheHead from the state at t = 0, wetted
/// by the scene's root-to-tip ramp, one output frame (run.frame_s) per step.
struct NoddingRun {
  io::SceneConfig scene;
  HairModel model;
  Obstacles obstacles;
  HairState state;
  /// False, with the reason printed after `program`, on a scene the model builder refuses.
  bool build(const io::SceneConfig& config, const char* program) {
    scene = config;
    std::string why;
    if (!io::buildSceneModel(scene, &model, &why)) {
      std::fprintf(stderr, "%s: %s\n", program, why.c_str());
      return false;
    }
    obstacles.analytic.push_back(sphereBehindTheHead());
    const HeadMotionConfig& motion = scene.motion;
    state = makeState(model, headPose(motion, 0.0), headTwist(motion, 0.0));
    SaturationCommand wet;
    wet.root_value = scene.saturation.root;
    wet.tip_value = scene.saturation.tip;
    applySaturation(model, wet, headPose(motion, 0.0), &state);
    return true;
  }
  /// Output frame f, from t = f frame_s to (f + 1) frame_s.
  void stepFrame(int f) {
    const double frame = scene.run.frame_s;
    const StepInputs in{headPose(scene.motion, f * frame), headPose(scene.motion, (f + 1) * frame),
                        &obstacles};
    step(model, scene.solver, in, frame, &state, nullptr);
  }
};

}  // namespace bench
}  // namespace wet_curly_hair
