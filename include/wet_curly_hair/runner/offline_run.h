// The offline runner as a library: a scene run for a set simulated time under its scripted head
// motion, summarised as JSON. `wet_curly_hair_run` is a thin command line over this.
#pragma once

#include <cstdint>
#include <functional>
#include <istream>
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
  /// Skip the per-frame measurements (energy, strain, penetration, extension, obstacles,
  /// jitter, tangle series): only the step runs. The end-of-run ones follow their own flags.
  bool measure = true;
  /// The tangle count every tangle_series_stride frames (RunSummary::max_tangles); opt-in
  /// (runner --tangle-series N): one count costs about as much as a frame of stepping.
  bool tangle_series = false;
  int tangle_series_stride = 10;
  /// End of the run: clump distance (--no-clump-distance) and the two tangle counts
  /// (--no-tangles).
  bool clump_distance = true;
  bool tangles = true;
  /// Crossings (segment pairs of different strands passing through each other between two
  /// frames, crossingCount) every frame: with hair contact on unless --no-crossings; always with
  /// --crossings (crossings_always). About the cost of a tangle count per frame.
  bool crossings = true;
  bool crossings_always = false;
  /// The clump distance and the tangle counts (series included) measure every k-th strand,
  /// k = ceil(strands / sample_strands): exact up to that many strands, estimates beyond
  /// (clumpDistance, tangleCount; runner --sample-strands N). 0: every strand, exact at any
  /// size (a tangle count then costs about as much as several frames of stepping at 10,000
  /// strands on one scalp, and grows with the square of the strand count).
  int sample_strands = 500;
  /// Frames that are written hold the output positions (p^w under "ours" cohesion).
  /// Scripted saturation changes: each sets a root-to-tip ramp on every particle of every strand
  /// (applySaturation) before the first frame that starts at or after time_s (runner
  /// `--saturation-at T,ROOT,TIP`, repeatable; applied in time order).
  struct SaturationEvent {
    double time_s = 0.0;
    double root = 0.0;
    double tip = 0.0;
  };
  std::vector<SaturationEvent> saturation_events;
  /// The per-frame series (time_s, energy, kinetic_energy, max_speed_m_s) are measured every
  /// Nth frame (frame 0 and the last frame always); the other maxima are still taken at every
  /// frame. The energy costs about a tenth of a frame's stepping with the implicit methods, so
  /// the default samples it (every 0.1 s at 60 frames/s); 1 measures every frame.
  int series_stride = 6;
  /// Real-time factor per window of this much simulated time (realtime_factor_windows), s.
  double rtf_window_s = 60.0;
};

/// The runner's measurements, by the names RunSummary::measurements lists (docs/runner.md).
enum Measurement {
  kMeasureRigidMotion,      ///< before the run: rigid_*, head_peak_reach_speed, hair_mass
  kMeasureEnergy,           ///< energy, kinetic_energy, max_speed_m_s, time_s (series)
  kMeasureStrain,           ///< max_strain, mean_strain, max_strand_extension, their _start/_end
  kMeasureHeadPenetration,  ///< max_penetration_m, max_head_penetration_after_first_step_m
  kMeasureObstacles,        ///< obstacle penetration and obstacle_contact_s
  kMeasureJitter,           ///< jitter
  kMeasureTangleSeries,     ///< max_tangles over the sampled frames (opt-in)
  kMeasureClumpDistance,    ///< clump_distance_m (last frame)
  kMeasureTangles,          ///< tangles, tangles_sim (last frame)
  kMeasureCurlShape,        ///< curl_radius_tip_m, curl_pitch_tip_m (last frame)
  /// With the water stage on: water_held_series_kg, mean_tip_height_m, clump_distance_series_m
  kMeasureWater,
  kMeasureCrossings,     ///< crossings (every frame; with hair contact or --crossings)
  kMeasureHeadDistance,  ///< mean_head_distance_m, mean_head_distance_run_m (every frame)
  kMeasurementCount
};
const char* measurementName(Measurement m);

struct RunSummary {
  int strands = 0;          ///< output strands (guides and followers).
  int guide_strands = 0;    ///< strands simulated (groom.follow_ratio; all of them at 1).
  int strands_skipped = 0;  ///< strands of the groom file not simulated (HairImportReport).
  /// With groom_file.roots_on_scalp: strands moved onto the scalp, the longest move (m) and the
  /// non-root particles left inside the head's ellipsoid (HairImportReport::scalp_placement).
  int roots_moved = 0;
  double root_move_max_m = 0.0;
  int particles_inside_scalp = 0;
  /// Roots more than 0.1 mm inside the head's ellipsoid as imported, and the deepest (m): 0
  /// with roots_on_scalp (HairImportReport::roots_inside).
  int roots_inside_scalp = 0;
  double deepest_root_m = 0.0;
  /// Strands too coarse for the configured alpha_b or c_b, raised to the flutter bounds
  /// (HairModel::bend_stabilized_strands).
  int bend_stabilized_strands = 0;
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
  uint64_t rest_shape_repairs = 0;  ///< of those, strands given their rest shape (WarningStats)
  uint64_t head_jumps = 0;  ///< steps whose head motion was a jump (teleport) carrying the hair
  uint64_t nonfinite_values = 0;
  bool finite = true;
  double max_speed_end_m_s = 0.0;
  std::vector<double> time_s;  ///< per frame
  std::vector<double> energy;  ///< total energy per frame, J
  /// The simulated strands' total energy per frame, J: the guides' with followers (energy()'s
  /// first model.simulatedStrandCount() strands), the same as `energy` without them.
  std::vector<double> energy_simulated;
  std::vector<double> kinetic_energy;  ///< per frame, J
  std::vector<double> max_speed_m_s;   ///< per frame
  uint64_t velocity_clamps = 0;
  uint64_t strain_limited_edges = 0;
  uint64_t head_contacts = 0;
  uint64_t constraint_rounds = 0;  ///< extra collision + strain-limit rounds (solver.h)
  int hair_frames_written = 0;
  // Wet model measurements (docs/paper.md), taken on the output positions
  // (the cohesion display positions p^w when cohesion is "ours", else the simulated ones).
  double clump_distance_m =
      0.0;                ///< final frame: mean distance of a wet particle to another strand.
  double jitter_m = 0.0;  ///< RMS second difference per frame of output positions, head frame.
  int tangles = 0;        ///< final frame: touching segment pairs of different strands.
  int max_tangles = 0;    ///< the most at any sampled frame (tangle_series) and the last.
  int tangles_sim = 0;    ///< final frame, on the simulated positions (not p^w).
  /// Segment pairs of different strands that passed through each other, summed over the frames
  /// (simulated positions; crossingCount); -1 when not measured (RunOptions::crossings).
  long long crossings = -1;
  /// The groom's volume as a length: mean distance of the particles from the head surface at the
  /// last frame, and its mean over the frames (meanHeadDistance), m.
  double mean_head_distance_m = 0.0;
  double mean_head_distance_run_m = 0.0;
  long long max_crossings_per_frame = -1;  ///< the most in one frame; -1 when not measured.
  std::vector<double> crossings_series;    ///< per frame from frame 1 (when measured).
  /// Hair contact: touching sphere pairs at the last substep of the run, the most strands with
  /// a contact force at a substep's end of any frame, and Verlet list builds over the run.
  unsigned long long hair_contacts = 0;
  unsigned long long hair_contact_strands_max = 0;
  unsigned long long hair_contact_list_builds = 0;
  /// Substeps that ran without contact forces: the pair list would not fit (WarningStats).
  unsigned long long hair_contact_overflows = 0;
  unsigned long long hair_contact_listed_pairs_max = 0;  ///< the longest Verlet list of the run.
  double curl_radius_tip_m = 0.0;  ///< final frame, tip third (simulated positions).
  double curl_pitch_tip_m = 0.0;
  double obstacle_contact_s = 0.0;  ///< mean over strands that touched: time within the band.
  double obstacle_contact_strand_s = 0.0;  ///< the same summed over the strands (strand-seconds).
  int obstacle_contact_strands = 0;        ///< strands that were ever within the band.
  double max_strand_extension = 0.0;       ///< largest arc length / rest length - 1 of any strand.
  uint64_t adhesion_active = 0;
  uint64_t obstacle_contacts = 0;
  uint64_t cohesion_particles = 0;          ///< summed over steps.
  double sdf_build_s = 0.0;                 ///< OctoMap -> signed distance field build time, s.
  double max_obstacle_penetration_m = 0.0;  ///< deepest penetration into an obstacle, any frame.
  /// The same maxima over the frames after the first solver step (frame >= 1): a groom that
  /// starts inside the head or an obstacle is pushed out during the first step.
  double max_penetration_after_first_step_m = 0.0;
  double max_head_penetration_after_first_step_m = 0.0;
  double max_obstacle_penetration_after_first_step_m = 0.0;
  /// What the scripted motion can put into the hair: the groom carried rigidly by the head.
  /// Kinetic energy of the non-root particles moving with the head's frame-to-frame rigid
  /// motion ((pose(t+frame) - pose(t)) x / frame; a teleport counts as a one-frame move), the
  /// largest over the frames, J; and the largest rise of their gravitational energy above its
  /// value at t = 0, J.
  double rigid_kinetic_energy_max_j = 0.0;
  double rigid_potential_rise_max_j = 0.0;
  /// Largest speed a point of a strand can have when the hair is carried rigidly in any shape:
  /// |v_head origin| + |omega| (|root - origin| + strand length), over the frames, m/s.
  double head_peak_reach_speed_m_s = 0.0;
  double hair_mass_kg = 0.0;  ///< non-root particles.
  /// The same three for the simulated strands only (the guides with followers; equal to the
  /// above without them): what the motion can put into them.
  double rigid_potential_rise_simulated_max_j = 0.0;
  double head_peak_reach_speed_simulated_m_s = 0.0;
  double hair_mass_simulated_kg = 0.0;
  /// Strand length drift: edge strain and strand extension at the first and the last frame.
  double max_strain_start = 0.0, max_strain_end = 0.0;
  double mean_strain_start = 0.0, mean_strain_end = 0.0;
  /// Arc length / rest length - 1, signed: the largest over the strands and their mean.
  double max_strand_extension_start = 0.0, max_strand_extension_end = 0.0;
  double mean_strand_extension_start = 0.0, mean_strand_extension_end = 0.0;
  int saturation_changes = 0;  ///< RunOptions::saturation_events applied.
  /// The water stage (SceneConfig::waterActive, docs/water.md): totals at the end, kg (the
  /// scene's initial saturation and every command's change count as added, or as removed when
  /// a command dried hair): added - removed = held + dripped + evaporated to round-off.
  bool water = false;
  double water_added_kg = 0.0, water_removed_kg = 0.0, water_held_kg = 0.0;
  double water_dripped_kg = 0.0, water_evaporated_kg = 0.0;
  uint64_t water_drips = 0;   ///< particle-steps that dripped.
  double water_wall_s = 0.0;  ///< wall seconds of the water stage (not in wall_s).
  /// Per series frame (as time_s): the mean saturation over the particles (every run); with the
  /// water stage on also the held water (kg), the mean height of the strand tips (world z, m) and
  /// the clump distance (m, as clump_distance_m).
  std::vector<double> mean_saturation;
  std::vector<double> water_held_series_kg;
  std::vector<double> mean_tip_height_m;
  std::vector<double> clump_distance_series_m;
  /// Memory (/proc/self/status, kB): resident set before the model is built and at the end,
  /// and the peak (VmHWM) at the end.
  long rss_start_kb = 0, rss_end_kb = 0, rss_peak_kb = 0;
  int series_stride = 6;
  /// Strands the clump distance and tangle counts ran on: every sample_stride-th strand
  /// (RunOptions::sample_strands); sample_stride 1 is exact, above 1 they are estimates.
  int sample_stride = 1, sampled_strands = 0;
  double rtf_window_s = 60.0;
  /// Simulated / wall time of step() per window of rtf_window_s simulated seconds (the last,
  /// partial window included when it holds at least one frame).
  std::vector<double> realtime_factor_windows;
  std::string integrator;  ///< solver.integrator.method
  /// The strain limit's velocity rule that ran: "inelastic" or "displacement" ("auto" resolved,
  /// SolverConfig::inelasticStrainLimit).
  std::string limit_velocity;
  /// solver.integrator.lane_layout, or "off" when strands run one at a time (strand_lanes).
  std::string lane_layout;
  int threads = 1;  ///< solver.integrator.threads
  std::string cpu;  ///< the machine's CPU (describeCpu), named beside every figure of the run
  /// The cohesion display pass that ran: "off", "exact" or "grid<nodes per radius>" (mode
  /// "ours"; the baselines' mode otherwise), where its sums ran (solver.cohesion.gather_at), how
  /// often its offsets were refreshed (refresh_period_s; 0: every step) and whether the lattice
  /// took its volumes at its nodes (grid_node_volumes), where the lattice's sums of eq. (10) ran
  /// (grid_wet_sums: "particles" or "nodes"; "" without the lattice), and the float lanes of its
  /// vectors (kCohesionFloatLanes, set by the build's CPU; 0 unless the lattice ran in float).
  std::string cohesion;
  std::string cohesion_gather_at;
  double cohesion_refresh_period_s = 0.0;
  bool cohesion_node_volumes = false;
  std::string cohesion_wet_sums;
  int cohesion_float_lanes = 0;
  /// Per solver stage (stageName order), summed over the run: particles it ran on and CPU
  /// seconds (all threads).
  std::vector<uint64_t> stage_particles;
  std::vector<double> stage_cpu_s;
  /// The measurements that ran (measurementName, in Measurement order), the wall seconds each
  /// took over the run, and their sum (compare with wall_s, the stepping).
  std::vector<std::string> measurements;
  std::vector<double> measurement_s;
  double measure_wall_s = 0.0;
  std::string toJson() const;
};

/// The CPU a figure was measured on, from /proc/cpuinfo's text: the first "model name", its
/// "cpu family" and "model" numbers, and whether the flags list avx512f, as in "AMD EPYC (family
/// 23, model 1), no avx512f". The numbers tell apart generations that share a name: that Zen 1
/// EPYC (AVX2 on 128-bit units) ran the 10,000-strand runs at about half the speed of the "AMD
/// EPYC" measured before it. "unknown CPU" when the text has no model name.
std::string describeCpu(std::istream& cpuinfo);
/// describeCpu of this machine's /proc/cpuinfo.
std::string describeThisCpu();

/// The scene's groom on the head at t = 0, wet as its `saturation` section says.
HairState initialSceneState(const SceneConfig& scene, const HairModel& model);

/// Whether a run ended finite: every position finite and no strand restored from a non-finite
/// value on the way (a repair hides the NaN from the positions, not from the run).
bool runStayedFinite(const HairState& state);

/// The runner's exit status for a finished run: 0, or 1 when it did not stay finite (a bad
/// option or scene exits 2 before any run).
int runExitCode(const RunSummary& summary);

/// Runs the scene. False (with a reason) on a bad scene or an unwritable output.
bool runScene(const SceneConfig& scene, const RunOptions& options, RunSummary* summary,
              std::string* why);

}  // namespace io
}  // namespace wet_curly_hair
