// The offline runner as a library: a scene run for a set simulated time under its scripted head
// motion, summarised as JSON. `wet_curly_hair_run` is a thin command line over this.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/io/scene.h"

namespace wet_curly_hair {
namespace io {

struct RunOptions {
  std::string hair_frames_dir;  ///< when set, frame_%05d.hair is written every hair_stride frames.
  int hair_stride = 1;
  /// Time every solver stage (StepInputs::clock); the figures land in RunSummary::stage_cpu_s.
  bool stage_timing = true;
  /// Called after every output frame (frame 0 is the initial state) with the state: benchmarks
  /// read the output positions here. Not timed.
  std::function<void(int frame, const HairState& state)> on_frame;
  /// Skip the per-frame measurements (energy, strain, tangles, jitter...): only the step runs.
  bool measure = true;
  /// Frames that are written hold the output positions (p^w under "ours" cohesion).
};

struct RunSummary {
  int strands = 0;
  int particles = 0;
  uint64_t steps = 0;
  double substep_s = 0.0;
  double wall_s = 0.0;
  double sim_s = 0.0;
  double max_strain = 0.0;               ///< largest edge strain seen at any frame.
  double mean_strain = 0.0;              ///< mean absolute edge strain over the frames.
  double max_strain_before_limit = 0.0;  ///< largest strain before the limiter projected it.
  double max_penetration_m = 0.0;        ///< deepest penetration into the head at any frame.
  uint64_t repairs = 0;
  uint64_t nonfinite_values = 0;
  bool finite = true;
  double max_speed_end_m_s = 0.0;
  std::vector<double> time_s;            ///< per frame
  std::vector<double> energy;            ///< total energy per frame, J
  std::vector<double> kinetic_energy;    ///< per frame, J
  std::vector<double> max_speed_m_s;     ///< per frame
  uint64_t velocity_clamps = 0;
  uint64_t strain_limited_edges = 0;
  uint64_t head_contacts = 0;
  int hair_frames_written = 0;
  // Wet model measurements (README "Reproducing the paper"), taken on the output positions
  // (the cohesion display positions p^w when cohesion is "ours", else the simulated ones).
  double clump_distance_m = 0.0;  ///< final frame: mean distance of a wet particle to another strand.
  double jitter_m = 0.0;          ///< RMS second difference per frame of output positions, head frame.
  int tangles = 0;                ///< final frame: touching segment pairs of different strands.
  int max_tangles = 0;            ///< the most at any sampled frame (every 10th).
  int tangles_sim = 0;            ///< final frame, on the simulated positions (not p^w).
  double curl_radius_tip_m = 0.0; ///< final frame, tip third (simulated positions).
  double curl_pitch_tip_m = 0.0;
  double obstacle_contact_s = 0.0;  ///< mean over strands that touched: time within the band.
  double max_strand_extension = 0.0;///< largest arc length / rest length - 1 of any strand.
  uint64_t adhesion_active = 0;
  uint64_t obstacle_contacts = 0;
  uint64_t cohesion_particles = 0;  ///< summed over steps.
  double sdf_build_s = 0.0;         ///< OctoMap -> signed distance field build time, s.
  double max_obstacle_penetration_m = 0.0;  ///< deepest penetration into an obstacle, any frame.
  std::string integrator;                   ///< solver.integrator.method
  int threads = 1;                          ///< solver.integrator.threads
  /// Per solver stage (stageName order), summed over the run: particles it ran on and CPU
  /// seconds (all threads).
  std::vector<uint64_t> stage_particles;
  std::vector<double> stage_cpu_s;
  std::string toJson() const;
};

/// Runs the scene. False (with a reason) on a bad scene or an unwritable output.
bool runScene(const SceneConfig& scene, const RunOptions& options, RunSummary* summary,
              std::string* why);

}  // namespace io
}  // namespace wet_curly_hair
