#include "wet_curly_hair/runner/offline_run.h"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>

#include "wet_curly_hair/core/cohesion_grid.h"
#include "wet_curly_hair/core/diagnostics.h"
#include "wet_curly_hair/core/metrics.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/water.h"
#include "wet_curly_hair/io/hair_file.h"
#include "wet_curly_hair/io/json.h"
#include "wet_curly_hair/io/octomap_sdf.h"
#include "wet_curly_hair/io/scene_setup.h"
#include "wet_curly_hair/io/stage_clock.h"

namespace wet_curly_hair {
namespace io {

std::string describeCpu(std::istream& cpuinfo) {
  auto trim = [](const std::string& text) {
    const size_t first = text.find_first_not_of(" \t");
    if (first == std::string::npos) return std::string();
    return text.substr(first, text.find_last_not_of(" \t") - first + 1);
  };
  std::string line, model, family, number;
  bool avx512 = false;
  while (std::getline(cpuinfo, line)) {
    // "key<tabs>: value": "model\t\t: 1" is the model number, "model name\t: ..." the name.
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = trim(line.substr(0, colon)), value = trim(line.substr(colon + 1));
    if (key == "model name" && model.empty()) model = value;
    if (key == "cpu family" && family.empty()) family = value;
    if (key == "model" && number.empty()) number = value;
    if (key == "flags" && (" " + value + " ").find(" avx512f ") != std::string::npos) avx512 = true;
  }
  if (model.empty()) model = "unknown CPU";
  if (!family.empty() && !number.empty()) model += " (family " + family + ", model " + number + ")";
  return model + (avx512 ? ", avx512f" : ", no avx512f");
}

std::string describeThisCpu() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  return describeCpu(cpuinfo);
}

std::string RunSummary::toJson() const {
  JsonObject o;
  o.add("strands", strands)
      .add("guide_strands", guide_strands)
      .add("strands_skipped", strands_skipped)
      .add("roots_moved", roots_moved)
      .add("root_move_max_m", root_move_max_m)
      .add("particles_inside_scalp", particles_inside_scalp)
      .add("roots_inside_scalp", roots_inside_scalp)
      .add("deepest_root_m", deepest_root_m)
      .add("bend_stabilized_strands", bend_stabilized_strands)
      .add("particles", particles)
      .add("steps", static_cast<unsigned long long>(steps))
      .add("substep_s", substep_s)
      .add("wall_s", wall_s)
      .add("sim_s", sim_s)
      .add("realtime_factor", wall_s > 0.0 ? sim_s / wall_s : 0.0)
      .add("max_strain", max_strain)
      .add("mean_strain", mean_strain)
      .add("max_strain_before_limit", max_strain_before_limit)
      .add("max_penetration_m", max_penetration_m)
      .add("repairs", static_cast<unsigned long long>(repairs))
      .add("rest_shape_repairs", static_cast<unsigned long long>(rest_shape_repairs))
      .add("head_jumps", static_cast<unsigned long long>(head_jumps))
      .add("nonfinite_values", static_cast<unsigned long long>(nonfinite_values))
      .add("finite", finite)
      .add("max_speed_end_m_s", max_speed_end_m_s)
      .add("velocity_clamps", static_cast<unsigned long long>(velocity_clamps))
      .add("strain_limited_edges", static_cast<unsigned long long>(strain_limited_edges))
      .add("head_contacts", static_cast<unsigned long long>(head_contacts))
      .add("constraint_rounds", static_cast<unsigned long long>(constraint_rounds))
      .add("hair_frames_written", hair_frames_written)
      .add("clump_distance_m", clump_distance_m)
      .add("jitter", jitter_m)
      .add("tangles", tangles)
      .add("max_tangles", max_tangles)
      .add("tangles_sim", tangles_sim)
      .add("crossings", crossings)
      .add("mean_head_distance_m", mean_head_distance_m)
      .add("mean_head_distance_run_m", mean_head_distance_run_m)
      .add("max_crossings_per_frame", max_crossings_per_frame)
      .add("crossings_series", crossings_series)
      .add("hair_contacts", hair_contacts)
      .add("hair_contact_strands_max", hair_contact_strands_max)
      .add("hair_contact_list_builds", hair_contact_list_builds)
      .add("hair_contact_overflows", hair_contact_overflows)
      .add("hair_contact_listed_pairs_max", hair_contact_listed_pairs_max)
      .add("curl_radius_tip_m", curl_radius_tip_m)
      .add("curl_pitch_tip_m", curl_pitch_tip_m)
      .add("obstacle_contact_s", obstacle_contact_s)
      .add("obstacle_contact_strand_s", obstacle_contact_strand_s)
      .add("obstacle_contact_strands", obstacle_contact_strands)
      .add("max_strand_extension", max_strand_extension)
      .add("adhesion_active", static_cast<unsigned long long>(adhesion_active))
      .add("obstacle_contacts", static_cast<unsigned long long>(obstacle_contacts))
      .add("cohesion_particles", static_cast<unsigned long long>(cohesion_particles))
      .add("sdf_build_s", sdf_build_s)
      .add("max_obstacle_penetration_m", max_obstacle_penetration_m)
      .add("max_penetration_after_first_step_m", max_penetration_after_first_step_m)
      .add("max_head_penetration_after_first_step_m", max_head_penetration_after_first_step_m)
      .add("max_obstacle_penetration_after_first_step_m",
           max_obstacle_penetration_after_first_step_m)
      .add("rigid_kinetic_energy_max_j", rigid_kinetic_energy_max_j)
      .add("rigid_potential_rise_max_j", rigid_potential_rise_max_j)
      .add("head_peak_reach_speed_m_s", head_peak_reach_speed_m_s)
      .add("hair_mass_kg", hair_mass_kg)
      .add("rigid_potential_rise_simulated_max_j", rigid_potential_rise_simulated_max_j)
      .add("head_peak_reach_speed_simulated_m_s", head_peak_reach_speed_simulated_m_s)
      .add("hair_mass_simulated_kg", hair_mass_simulated_kg)
      .add("max_strain_start", max_strain_start)
      .add("max_strain_end", max_strain_end)
      .add("mean_strain_start", mean_strain_start)
      .add("mean_strain_end", mean_strain_end)
      .add("max_strand_extension_start", max_strand_extension_start)
      .add("max_strand_extension_end", max_strand_extension_end)
      .add("mean_strand_extension_start", mean_strand_extension_start)
      .add("mean_strand_extension_end", mean_strand_extension_end)
      .add("saturation_changes", saturation_changes)
      .add("water", water)
      .add("water_added_kg", water_added_kg)
      .add("water_removed_kg", water_removed_kg)
      .add("water_held_kg", water_held_kg)
      .add("water_dripped_kg", water_dripped_kg)
      .add("water_evaporated_kg", water_evaporated_kg)
      .add("water_drips", static_cast<unsigned long long>(water_drips))
      .add("water_wall_s", water_wall_s)
      .add("rss_start_kb", static_cast<long long>(rss_start_kb))
      .add("rss_end_kb", static_cast<long long>(rss_end_kb))
      .add("rss_peak_kb", static_cast<long long>(rss_peak_kb))
      .add("series_stride", series_stride)
      .add("sample_stride", sample_stride)
      .add("sampled_strands", sampled_strands)
      .add("rtf_window_s", rtf_window_s)
      .add("realtime_factor_windows", realtime_factor_windows)
      .add("integrator", integrator)
      .add("limit_velocity", limit_velocity)
      .add("lane_layout", lane_layout)
      .add("threads", threads)
      .add("cpu", cpu)
      .add("cohesion", cohesion)
      .add("cohesion_gather_at", cohesion_gather_at)
      .add("cohesion_refresh_period_s", cohesion_refresh_period_s)
      .add("cohesion_node_volumes", cohesion_node_volumes)
      .add("cohesion_wet_sums", cohesion_wet_sums)
      .add("cohesion_float_lanes", cohesion_float_lanes)
      .add("time_s", time_s)
      .add("energy", energy)
      .add("energy_simulated", energy_simulated)
      .add("kinetic_energy", kinetic_energy)
      .add("max_speed_m_s", max_speed_m_s)
      .add("mean_saturation", mean_saturation)
      .add("water_held_series_kg", water_held_series_kg)
      .add("mean_tip_height_m", mean_tip_height_m)
      .add("clump_distance_series_m", clump_distance_series_m);
  JsonObject stages;
  for (size_t k = 0; k < stage_particles.size() && k < stage_cpu_s.size(); ++k) {
    JsonObject stage;
    stage.add("particles", static_cast<unsigned long long>(stage_particles[k]))
        .add("cpu_s", stage_cpu_s[k]);
    stages.addObject(stageName(static_cast<int>(k)), stage);
  }
  o.addObject("stages", stages);
  o.add("measurements", measurements);
  JsonObject spent;
  for (size_t k = 0; k < measurements.size() && k < measurement_s.size(); ++k)
    spent.add(measurements[k], measurement_s[k]);
  o.addObject("measurement_s", spent);
  o.add("measure_wall_s", measure_wall_s);
  return o.str();
}

const char* measurementName(Measurement m) {
  static const char* const kNames[kMeasurementCount] = {
      "rigid_motion", "energy",        "strain",         "head_penetration", "obstacles",
      "jitter",       "tangle_series", "clump_distance", "tangles",          "curl_shape",
      "water",        "crossings",     "head_distance"};
  return m >= 0 && m < kMeasurementCount ? kNames[m] : "";
}

namespace {

/// A "VmRSS:"-style line of /proc/self/status, kB (0 when unreadable, e.g. not Linux).
long procStatusKb(const char* key) {
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (!f) return 0;
  char line[256];
  long kb = 0;
  const size_t n = std::strlen(key);
  while (std::fgets(line, sizeof(line), f)) {
    if (std::strncmp(line, key, n) == 0) {
      kb = std::strtol(line + n, nullptr, 10);
      break;
    }
  }
  std::fclose(f);
  return kb;
}

double steadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

bool writeFrame(const std::string& dir, int frame, const HairModel& model, const HairState& state,
                std::string* why) {
  char name[64];
  std::snprintf(name, sizeof(name), "/frame_%05d.hair", frame);
  HairFileData data =
      groomPositionsToHair(model.strand_offsets, displayPositions(state), &state.saturation);
  return writeHairFile(dir + name, data, why);
}

/// The options that runScene checks before it builds anything, and the saturation events in
/// time order. The hair frames folder is created here.
bool checkOptions(const RunOptions& options, const HairModel& model,
                  std::vector<RunOptions::SaturationEvent>* events, std::string* why) {
  if (options.series_stride < 1) {
    if (why) *why = "--series-stride: must be at least 1";
    return false;
  }
  if (options.sample_strands < 0) {
    if (why) *why = "--sample-strands: must be at least 0";
    return false;
  }
  if (options.tangle_series && options.tangle_series_stride < 1) {
    if (why) *why = "--tangle-series: must be at least 1";
    return false;
  }
  if (!(options.rtf_window_s > 0.0)) {
    if (why) *why = "--rtf-window: must be positive";
    return false;
  }
  *events = options.saturation_events;
  for (const RunOptions::SaturationEvent& e : *events) {
    SaturationCommand c;
    c.root_value = e.root;
    c.tip_value = e.tip;
    if (!std::isfinite(e.time_s) || e.time_s < 0.0) {
      if (why) *why = "--saturation-at: time must be finite and >= 0";
      return false;
    }
    std::string inner;
    if (!validateSaturationCommand(c, model, &inner)) {
      if (why) *why = "--saturation-at: " + inner;
      return false;
    }
  }
  std::stable_sort(events->begin(), events->end(),
                   [](const RunOptions::SaturationEvent& a, const RunOptions::SaturationEvent& b) {
                     return a.time_s < b.time_s;
                   });
  if (!options.hair_frames_dir.empty()) {
    mkdir(options.hair_frames_dir.c_str(), 0755);
    struct stat st;
    if (stat(options.hair_frames_dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
      if (why) *why = "--hair-frames: cannot create directory " + options.hair_frames_dir;
      return false;
    }
    if (options.hair_stride < 1) {
      if (why) *why = "--hair-stride: must be at least 1";
      return false;
    }
  }
  return true;
}

/// The lattice the cohesion runs (grid_wet_sums "auto" resolved for the model): the summary's
/// cohesion "grid<nodes per radius>" and where its sums ran.
void describeLattice(const CohesionConfig& c, const HairModel& model, RunSummary* s) {
  if (c.mode != "ours" || c.evaluation != "grid") return;
  const CohesionLattice lattice = cohesionLattice(model, c);
  s->cohesion = "grid" + std::to_string(lattice.cells_per_radius);
  s->cohesion_wet_sums = lattice.node_sums ? "nodes" : "particles";
}

/// The summary's description of the run (what it is, not what it measured).
RunSummary startSummary(const SceneConfig& scene, const RunOptions& options, long rss_start_kb) {
  RunSummary s;
  s.rss_start_kb = rss_start_kb;
  s.series_stride = options.series_stride;
  s.rtf_window_s = options.rtf_window_s;
  s.integrator = scene.solver.integrator.method;
  s.limit_velocity = scene.solver.inelasticStrainLimit() ? "inelastic" : "displacement";
  s.lane_layout = scene.solver.integrator.strand_lanes
                      ? std::string(scene.solver.integrator.resolvedLaneLayout())
                      : std::string("off");
  s.threads = scene.solver.integrator.resolvedThreads();
  s.cpu = describeThisCpu();
  const CohesionConfig& c = scene.solver.cohesion;
  s.cohesion = c.mode != "ours"         ? c.mode
               : c.evaluation == "grid" ? "grid" + std::to_string(c.grid_cells_per_radius)
                                        : c.evaluation;
  s.cohesion_gather_at = c.gather_at;
  s.cohesion_refresh_period_s = c.refresh_period_s;
  s.cohesion_node_volumes = c.mode == "ours" && c.evaluation == "grid" && c.grid_node_volumes;
  s.cohesion_float_lanes = c.mode == "ours" && c.evaluation == "grid" && c.grid_single_precision
                               ? kCohesionFloatLanes
                               : 0;
  s.stage_particles.assign(kStageCount, 0);
  s.stage_cpu_s.assign(kStageCount, 0.0);
  return s;
}

/// The signed distance field of the scene's OctoMap, over the box the hair can reach: every root
/// over the scripted motion, grown by the longest strand (buildSdfFromOctree adds the margin).
bool buildObstacleField(const SceneConfig& scene, const HairModel& model, long frames,
                        Obstacles* obstacles, double* build_s, std::string* why) {
  std::unique_ptr<octomap::OcTree> tree;
  std::string inner;
  if (!loadOctreeFile(scene.obstacle_map.file, &tree, &inner)) {
    if (why) *why = "obstacle_map.file: " + inner;
    return false;
  }
  double longest = 0.0;
  for (double l : model.strand_length_m) longest = std::max(longest, l);
  Eigen::AlignedBox3d reach;
  for (long f = 0; f <= frames; ++f) {
    const Pose pose = headPose(scene.motion, f * scene.run.frame_s);
    for (int st = 0; st < model.strandCount(); ++st)
      reach.extend(pose.apply(model.rest_position_head[model.strandBegin(st)]));
  }
  reach.min() -= Vec3::Constant(longest);
  reach.max() += Vec3::Constant(longest);
  SdfBuildConfig build;
  build.resolution_m = scene.obstacle_map.resolution_m;
  build.margin_m = scene.obstacle_map.margin_m;
  build.unknown_is_occupied = scene.obstacle_map.unknown_is_occupied;
  Pose map_in_world;
  map_in_world.translation = scene.obstacle_map.offset_m;
  auto sdf = std::make_shared<DenseSdf>();
  SdfBuildStats stats;
  if (!buildSdfFromOctree(*tree, map_in_world, reach, build, sdf.get(),
                          &obstacles->field.field_in_world, &stats, &inner)) {
    if (why) *why = "obstacle_map: " + inner;
    return false;
  }
  obstacles->field.sdf = sdf;
  *build_s = stats.total_s;
  return true;
}

/// What the motion can put into strands [0, strands): carried rigidly by the head.
struct RigidMotion {
  double mass_kg = 0.0, kinetic_max_j = 0.0, potential_rise_max_j = 0.0, reach_speed_m_s = 0.0;
};

/// RigidMotion of strands [0, strands) (RunSummary's rigid_kinetic_energy_max_j,
/// rigid_potential_rise_max_j, head_peak_reach_speed_m_s and hair_mass_kg for every strand).
/// From their mass moments in the head frame (mass M, first moment mu, second moment S of the
/// non-root particles), so each frame costs O(1) whatever the groom: carried from pose a to pose
/// b, a particle at x moves by A x + d (A = R_b - R_a, d = t_b - t_a), and
/// sum m |A x + d|^2 = tr(A S A^T) + 2 d . A mu + M |d|^2; the gravitational energy at a pose is
/// -g . (R mu + M t).
RigidMotion rigidMotion(const SceneConfig& scene, const HairModel& model, int strands,
                        long frames) {
  const HeadMotionConfig& motion = scene.motion;
  const double frame = scene.run.frame_s;
  const Vec3& g = scene.solver.gravity_m_s2;
  RigidMotion r;
  double reach = 0.0;
  Vec3 mu = Vec3::Zero();
  Mat3 second = Mat3::Zero();
  for (int st = 0; st < strands; ++st) {
    for (int i = model.strandBegin(st) + 1; i < model.strandBegin(st) + model.strandSize(st); ++i) {
      const Vec3& x = model.rest_position_head[i];
      r.mass_kg += model.mass_kg[i];
      mu += model.mass_kg[i] * x;
      second += model.mass_kg[i] * x * x.transpose();
    }
    // |R root| = |root|: a strand point carried rigidly is at most |root| + length from the
    // head's origin.
    reach = std::max(
        reach, model.rest_position_head[model.strandBegin(st)].norm() + model.strand_length_m[st]);
  }
  auto potential = [&](const Pose& pose) {
    return -g.dot(pose.rotation * mu + r.mass_kg * pose.translation);
  };
  const double u0 = potential(headPose(motion, 0.0));
  for (long f = 0; f < frames; ++f) {
    const Pose a = headPose(motion, f * frame), b = headPose(motion, (f + 1) * frame);
    const Mat3 A = b.rotation.toRotationMatrix() - a.rotation.toRotationMatrix();
    const Vec3 d = b.translation - a.translation;
    const double sum_m_v2 =
        (A * second * A.transpose()).trace() + 2.0 * d.dot(A * mu) + r.mass_kg * d.squaredNorm();
    r.kinetic_max_j = std::max(r.kinetic_max_j, 0.5 * sum_m_v2 / (frame * frame));
    // Fastest point a strand can reach when carried rigidly: |v_origin| + |w| (|root - o| + L).
    const Eigen::AngleAxisd turn(b.rotation * a.rotation.conjugate());
    const double w = std::abs(turn.angle()) / frame;
    const double v_origin = d.norm() / frame;
    r.reach_speed_m_s = std::max(r.reach_speed_m_s, v_origin + w * reach);
    r.potential_rise_max_j = std::max(r.potential_rise_max_j, potential(b) - u0);
  }
  return r;
}

/// RunSummary's rigid-motion fields: for every strand, and for the simulated strands (the guides
/// with followers, whose energy energy_simulated holds).
void measureRigidMotion(const SceneConfig& scene, const HairModel& model, long frames,
                        RunSummary* s) {
  const RigidMotion all = rigidMotion(scene, model, model.strandCount(), frames);
  s->hair_mass_kg = all.mass_kg;
  s->rigid_kinetic_energy_max_j = all.kinetic_max_j;
  s->rigid_potential_rise_max_j = all.potential_rise_max_j;
  s->head_peak_reach_speed_m_s = all.reach_speed_m_s;
  const RigidMotion simulated =
      model.simulatedStrandCount() < model.strandCount()
          ? rigidMotion(scene, model, model.simulatedStrandCount(), frames)
          : all;
  s->hair_mass_simulated_kg = simulated.mass_kg;
  s->rigid_potential_rise_simulated_max_j = simulated.potential_rise_max_j;
  s->head_peak_reach_speed_simulated_m_s = simulated.reach_speed_m_s;
}

/// The per-frame measurements (energy, strain, penetration, extension, jitter, tangles) and the
/// final-frame ones, with the buffers they need allocated once, each timed (wall seconds) under
/// its name (RunSummary::measurements).
class FrameMeasurements {
 public:
  FrameMeasurements(const SceneConfig& scene, const HairModel& model, const Obstacles& obstacles,
                    const RunOptions& options, long frames)
      : scene_(scene),
        model_(model),
        obstacles_(obstacles),
        options_(options),
        frames_(frames),
        threads_(scene.solver.integrator.resolvedThreads()),
        sample_stride_(options.sample_strands > 0 && model.strandCount() > options.sample_strands
                           ? (model.strandCount() + options.sample_strands - 1) /
                                 options.sample_strands
                           : 1),
        out_prev2_(model.particleCount()),
        out_prev1_(model.particleCount()),
        contact_time_(model.strandCount(), 0.0),
        jitter_strand_(model.strandCount(), 0.0) {}

  /// Runs fn as measurement m, timed.
  template <typename Fn>
  void timed(Measurement m, Fn fn) {
    const double t0 = steadySeconds();
    fn();
    spent_s_[m] += steadySeconds() - t0;
    ran_[m] = true;
  }

  /// Frame f (0: the initial state) at time t, the head at pose.
  void record(long f, double t, const Pose& pose, HairState* state, RunSummary* s) {
    ++recorded_frames_;
    if (f % options_.series_stride == 0 || f == frames_) {
      timed(kMeasureEnergy, [&] {
        // The simulated strands' parts come from the same pass (they are the first strands).
        EnergyParts simulated;
        const int guides = model_.simulatedStrandCount();
        const EnergyParts e = energy(model_, scene_.solver, pose, state, guides, &simulated);
        s->time_s.push_back(t);
        s->energy.push_back(e.total());
        s->energy_simulated.push_back(guides < model_.strandCount() ? simulated.total()
                                                                    : e.total());
        s->kinetic_energy.push_back(e.kinetic);
        s->max_speed_m_s.push_back(maxSpeed(model_, *state));
        s->mean_saturation.push_back(meanSaturation(*state));
      });
      if (scene_.waterActive()) timed(kMeasureWater, [&] { measureWater(*state, s); });
    }
    // Strain and extension are one pass over the edges (lengthStats), timed as "strain".
    timed(kMeasureStrain, [&] {
      const LengthStats lengths = lengthStats(model_, state->position, &scratch_, threads_);
      recordStrain(f, lengths, s);
      recordExtension(f, lengths, s);
    });
    timed(kMeasureHeadPenetration, [&] {
      const double head_pen = headPenetration(model_, state->position, pose, threads_);
      s->max_penetration_m = std::max(s->max_penetration_m, head_pen);
      if (f >= 1)
        s->max_head_penetration_after_first_step_m =
            std::max(s->max_head_penetration_after_first_step_m, head_pen);
    });
    timed(kMeasureObstacles, [&] { measureObstacles(f, *state, s); });
    timed(kMeasureJitter, [&] { measureJitter(f, *state, pose); });
    timed(kMeasureHeadDistance, [&] {
      const double d = meanHeadDistance(model_, state->position, pose);
      s->mean_head_distance_m = d;  // the last frame's
      head_distance_sum_ += d;
      s->mean_head_distance_run_m = head_distance_sum_ / recorded_frames_;
    });
    if (measureCrossings()) timed(kMeasureCrossings, [&] { recordCrossings(f, *state, s); });
    if (options_.tangle_series && f % options_.tangle_series_stride == 0) {
      timed(kMeasureTangleSeries, [&] {
        s->max_tangles = std::max(s->max_tangles, tangleCount(model_, displayPositions(*state),
                                                              scene_.run.strand_radius_m, &scratch_,
                                                              threads_, sample_stride_));
      });
    }
  }

  bool measureCrossings() const {
    return options_.crossings_always || (options_.crossings && scene_.solver.hair_contact.enabled);
  }

  /// Crossings between the last frame and this one (simulated positions).
  void recordCrossings(long f, const HairState& state, RunSummary* s) {
    if (f == 0) {
      s->crossings = s->max_crossings_per_frame = 0;
    } else {
      const int64_t n =
          crossingCount(model_, previous_position_, state.position, &scratch_, threads_);
      s->crossings += n;
      s->max_crossings_per_frame = std::max<long long>(s->max_crossings_per_frame, n);
      s->crossings_series.push_back(static_cast<double>(n));
    }
    previous_position_ = state.position;
  }

  /// The water series of one frame: held water, mean tip height, clump distance.
  void measureWater(const HairState& state, RunSummary* s) {
    s->water_held_series_kg.push_back(heldWater(state));
    double z = 0.0;
    for (int k = 0; k < model_.strandCount(); ++k)
      z += state.position[model_.strandBegin(k) + model_.strandSize(k) - 1].z();
    s->mean_tip_height_m.push_back(model_.strandCount() ? z / model_.strandCount() : 0.0);
    s->clump_distance_series_m.push_back(clumpDistance(model_, displayPositions(state),
                                                       state.saturation, scene_.run.clump_search_m,
                                                       &scratch_, threads_, sample_stride_));
  }

  /// The measurements of the last frame and the means over the run.
  void finish(const HairState& state, RunSummary* s) {
    // max_penetration_m covers the head and the obstacles alike.
    s->max_penetration_m = std::max(s->max_penetration_m, s->max_obstacle_penetration_m);
    s->max_penetration_after_first_step_m = std::max(
        s->max_head_penetration_after_first_step_m, s->max_obstacle_penetration_after_first_step_m);
    s->jitter_m = jitter_count_ ? std::sqrt(jitter_sum_ / jitter_count_) : 0.0;
    if (options_.clump_distance)
      timed(kMeasureClumpDistance, [&] {
        s->clump_distance_m =
            clumpDistance(model_, displayPositions(state), state.saturation,
                          scene_.run.clump_search_m, &scratch_, threads_, sample_stride_);
      });
    if (options_.tangles)
      timed(kMeasureTangles, [&] {
        const double r = scene_.run.strand_radius_m;
        const Vec3List& shown = displayPositions(state);
        s->tangles = tangleCount(model_, shown, r, &scratch_, threads_, sample_stride_);
        // Without display cohesion the output positions are the simulated ones: count once.
        s->tangles_sim =
            &shown == &state.position || shown == state.position
                ? s->tangles
                : tangleCount(model_, state.position, r, &scratch_, threads_, sample_stride_);
      });
    if (ran_[kMeasureTangles] || ran_[kMeasureTangleSeries])
      s->max_tangles = std::max(s->max_tangles, s->tangles);
    if (ran_[kMeasureTangles] || ran_[kMeasureTangleSeries] || ran_[kMeasureClumpDistance]) {
      s->sample_stride = sample_stride_;
      s->sampled_strands = (model_.strandCount() + sample_stride_ - 1) / sample_stride_;
    }
    timed(kMeasureCurlShape, [&] {
      const CurlShape curl = tipCurlShape(model_, state.position);
      s->curl_radius_tip_m = curl.radius_m;
      s->curl_pitch_tip_m = curl.pitch_m;
    });
    double contact_sum = 0.0;
    int touched = 0;
    for (double c : contact_time_)
      if (c > 0.0) contact_sum += c, ++touched;
    s->obstacle_contact_s = touched ? contact_sum / touched : 0.0;
    s->obstacle_contact_strand_s = contact_sum;
    s->obstacle_contact_strands = touched;
    if (recorded_frames_ > 0) s->mean_strain /= static_cast<double>(recorded_frames_);
    for (int m = 0; m < kMeasurementCount; ++m) {
      if (!ran_[m]) continue;
      s->measurements.push_back(measurementName(static_cast<Measurement>(m)));
      s->measurement_s.push_back(spent_s_[m]);
      s->measure_wall_s += spent_s_[m];
    }
  }

 private:
  void recordStrain(long f, const LengthStats& l, RunSummary* s) {
    s->max_strain = std::max(s->max_strain, l.max_strain);
    s->mean_strain += l.mean_strain;
    if (f == 0) {
      s->max_strain_start = l.max_strain;
      s->mean_strain_start = l.mean_strain;
    }
    s->max_strain_end = l.max_strain;
    s->mean_strain_end = l.mean_strain;
  }

  void recordExtension(long f, const LengthStats& l, RunSummary* s) {
    s->max_strand_extension = std::max(s->max_strand_extension, l.max_extension);
    if (f == 0) {
      s->max_strand_extension_start = l.max_extension;
      s->mean_strand_extension_start = l.mean_extension;
    }
    s->max_strand_extension_end = l.max_extension;
    s->mean_strand_extension_end = l.mean_extension;
  }

  /// Per strand: the deepest obstacle penetration and the time within the adhesion band of an
  /// obstacle.
  /// Strands on the solver's threads (each writes its own contact time; the maximum is the same
  /// in any order).
  void measureObstacles(long f, const HairState& state, RunSummary* s) {
    if (obstacles_.empty()) return;
    auto strand = [&](int st) {
      const int b = model_.strandBegin(st), n = model_.strandSize(st);
      bool touching = false;
      double worst = 0.0;
      for (int i = b + 1; i < b + n; ++i) {
        Vec3 normal;
        const double dist = obstacles_.distance(state.position[i], &normal);
        touching = touching || dist <= scene_.solver.adhesion.radius_m;
        worst = std::max(worst, -dist);
      }
      if (touching && f > 0) contact_time_[st] += scene_.run.frame_s;
      return worst;
    };
    double pen = 0.0;
    const int strands = model_.strandCount();
    if (threads_ <= 1) {
      for (int st = 0; st < strands; ++st) pen = std::max(pen, strand(st));
    } else {
#pragma omp parallel for num_threads(threads_) schedule(static) reduction(max : pen)
      for (int st = 0; st < strands; ++st) pen = std::max(pen, strand(st));
    }
    s->max_obstacle_penetration_m = std::max(s->max_obstacle_penetration_m, pen);
    if (f >= 1)
      s->max_obstacle_penetration_after_first_step_m =
          std::max(s->max_obstacle_penetration_after_first_step_m, pen);
  }

  /// Output positions in the head frame, three frames kept: RMS second difference. Strands on
  /// the solver's threads, each summing its own particles; the strand sums are added in strand
  /// order, so any thread count gives the same value.
  void measureJitter(long f, const HairState& state, const Pose& pose) {
    const Mat3 to_head = pose.rotation.conjugate().toRotationMatrix();
    const Vec3List& shown = displayPositions(state);
    auto strand = [&](int st) {
      double sum = 0.0;
      for (int i = model_.strandBegin(st); i < model_.strandBegin(st) + model_.strandSize(st);
           ++i) {
        const Vec3 x = to_head * (shown[i] - pose.translation);
        if (f >= 2) sum += (x - 2.0 * out_prev1_[i] + out_prev2_[i]).squaredNorm();
        out_prev2_[i] = out_prev1_[i];
        out_prev1_[i] = x;
      }
      jitter_strand_[st] = sum;
    };
    const int strands = model_.strandCount();
    if (threads_ <= 1) {
      for (int st = 0; st < strands; ++st) strand(st);
    } else {
#pragma omp parallel for num_threads(threads_) schedule(static)
      for (int st = 0; st < strands; ++st) strand(st);
    }
    if (f < 2) return;
    for (double v : jitter_strand_) jitter_sum_ += v;
    jitter_count_ += model_.particleCount();
  }

  const SceneConfig& scene_;
  const HairModel& model_;
  const Obstacles& obstacles_;
  const RunOptions& options_;
  const long frames_;
  const int threads_;
  const int sample_stride_;
  Vec3List out_prev2_, out_prev1_;
  Vec3List previous_position_;  ///< the last frame's simulated positions (crossings)
  double head_distance_sum_ = 0.0;
  double jitter_sum_ = 0.0;
  long jitter_count_ = 0;
  std::vector<double> contact_time_;
  std::vector<double> jitter_strand_;  ///< this frame's sum per strand
  MetricScratch scratch_;
  long recorded_frames_ = 0;
  double spent_s_[kMeasurementCount] = {};
  bool ran_[kMeasurementCount] = {};
};

/// The solver's counters of one step, added to the summary.
void addStepStats(const StepStats& stats, RunSummary* s) {
  for (int k = 0; k < kStageCount; ++k) {
    s->stage_particles[k] += stats.stage_particles[k];
    s->stage_cpu_s[k] += stats.stage_cpu_s[k];
  }
  s->max_strain_before_limit = std::max(s->max_strain_before_limit, stats.max_strain_before_limit);
  s->velocity_clamps += stats.velocity_clamps;
  s->strain_limited_edges += stats.strain_limited_edges;
  s->head_contacts += stats.head_contacts;
  s->constraint_rounds += stats.constraint_rounds;
  s->adhesion_active += stats.adhesion_active;
  s->obstacle_contacts += stats.obstacle_contacts;
  s->cohesion_particles += stats.cohesion_particles;
  s->hair_contacts = stats.hair_contacts;
  s->hair_contact_strands_max =
      std::max<unsigned long long>(s->hair_contact_strands_max, stats.hair_contact_strands);
  s->hair_contact_list_builds += stats.hair_contact_list_builds;
  s->hair_contact_listed_pairs_max = std::max<unsigned long long>(s->hair_contact_listed_pairs_max,
                                                                  stats.hair_contact_listed_pairs);
}

/// Wall time of the steps: the total and the real-time factor per rtf_window_s of simulated time.
class StepClock {
 public:
  StepClock(double window_s, double frame_s, long frames)
      : window_s_(window_s), frame_s_(frame_s), frames_(frames) {}
  /// Frame f took step_wall seconds.
  void add(long f, double step_wall, RunSummary* s) {
    wall_ += step_wall;
    window_wall_ += step_wall;
    window_sim_ += frame_s_;
    if ((f + 1) * frame_s_ >= (s->realtime_factor_windows.size() + 1) * window_s_ - 1e-9 ||
        f + 1 == frames_) {
      s->realtime_factor_windows.push_back(window_wall_ > 0.0 ? window_sim_ / window_wall_ : 0.0);
      window_wall_ = window_sim_ = 0.0;
    }
  }
  double wall() const { return wall_; }

 private:
  double window_s_, frame_s_;
  long frames_;
  double wall_ = 0.0, window_wall_ = 0.0, window_sim_ = 0.0;
};

/// The water stage of frame [t0, t0 + frame): commands since the last frame booked, then one
/// water step and the particle masses with their water (timed on its own: the step's wall time
/// stays the dynamics').
void stepSceneWater(const SceneConfig& scene, double t0, double frame, HairModel* model,
                    HairState* state, RunSummary* s) {
  const auto t = std::chrono::steady_clock::now();
  reconcileWater(*model, scene.water, state);
  stepWater(*model, scene.water, scene.water_sources, scene.solver.gravity_m_s2, t0, frame, state,
            nullptr);
  if (scene.water.adds_mass) applyWaterMass(*state, model);
  s->water_wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

/// The run's end state: steps, times, warnings, finiteness, memory.
void finishSummary(const HairModel& model, const HairState& state, double sim_s, double wall_s,
                   RunSummary* s) {
  s->steps = state.step_count;
  s->sim_s = sim_s;
  s->wall_s = wall_s;
  s->repairs = state.warnings.total();
  s->rest_shape_repairs = state.warnings.rest_shape_repairs;
  s->head_jumps = state.warnings.head_jumps;
  s->hair_contact_overflows = state.warnings.hair_contact_overflows;
  s->nonfinite_values = state.warnings.nonfinite_values;
  s->finite = runStayedFinite(state);
  s->max_speed_end_m_s =
      s->max_speed_m_s.empty() ? maxSpeed(model, state) : s->max_speed_m_s.back();
  s->rss_end_kb = procStatusKb("VmRSS:");
  s->rss_peak_kb = procStatusKb("VmHWM:");
}

}  // namespace

HairState initialSceneState(const SceneConfig& scene, const HairModel& model) {
  const HeadMotionConfig& motion = scene.motion;
  HairState state = makeState(model, headPose(motion, 0.0), headTwist(motion, 0.0));
  if (scene.saturation.root > 0.0 || scene.saturation.tip > 0.0) {
    SaturationCommand wet;
    wet.root_value = scene.saturation.root;
    wet.tip_value = scene.saturation.tip;
    applySaturation(model, wet, headPose(motion, 0.0), &state);
  }
  return state;
}

bool runStayedFinite(const HairState& state) {
  if (state.warnings.nonfinite_repairs > 0) return false;
  for (const Vec3& p : state.position)
    if (!p.allFinite()) return false;
  return true;
}

int runExitCode(const RunSummary& summary) { return summary.finite ? 0 : 1; }

bool runScene(const SceneConfig& scene, const RunOptions& options, RunSummary* out,
              std::string* why) {
  const long rss_start_kb = procStatusKb("VmRSS:");
  HairModel model;
  HairImportReport import_report;
  if (!buildSceneModel(scene, &model, why, &import_report)) return false;
  if (!import_report.skipped.empty())
    std::fprintf(stderr, "groom_file.file: %s: %s\n", scene.groom_file.file.c_str(),
                 import_report.warning().c_str());
  if (!import_report.scalpSummary().empty())
    std::fprintf(stderr, "groom_file.%s\n", import_report.scalpSummary().c_str());
  if (!import_report.rootsInsideWarning().empty())
    std::fprintf(stderr, "groom_file.file: %s: %s\n", scene.groom_file.file.c_str(),
                 import_report.rootsInsideWarning().c_str());
  std::vector<RunOptions::SaturationEvent> events;
  if (!checkOptions(options, model, &events, why)) return false;
  RunSummary s = startSummary(scene, options, rss_start_kb);
  HairState state = initialSceneState(scene, model);
  const double frame = scene.run.frame_s;
  const long frames = std::lround(scene.run.seconds / frame);
  Obstacles obstacles;
  obstacles.analytic = scene.obstacles;
  if (!scene.obstacle_map.file.empty() &&
      !buildObstacleField(scene, model, frames, &obstacles, &s.sdf_build_s, why))
    return false;
  describeLattice(scene.solver.cohesion, model, &s);
  s.strands = model.strandCount();
  s.guide_strands = model.simulatedStrandCount();
  s.strands_skipped = static_cast<int>(import_report.skipped.size());
  s.roots_moved = import_report.scalp_placement.strands_moved;
  s.root_move_max_m = import_report.scalp_placement.largest_move_m;
  s.particles_inside_scalp = import_report.scalp_placement.particles_inside;
  s.roots_inside_scalp = import_report.roots_inside.count;
  s.deepest_root_m = import_report.roots_inside.deepest_m;
  s.bend_stabilized_strands = model.bend_stabilized_strands;
  s.particles = model.particleCount();
  s.substep_s = frame / substepCount(scene.solver, frame);
  FrameMeasurements measurements(scene, model, obstacles, options, frames);
  measurements.timed(kMeasureRigidMotion, [&] { measureRigidMotion(scene, model, frames, &s); });
  s.water = scene.waterActive();
  if (s.water) reconcileWater(model, scene.water, &state);  // the initial water is added

  // Frame f is done: measured, handed to on_frame, written every hair_stride frames.
  auto frameDone = [&](long f, const Pose& pose) {
    if (options.measure) measurements.record(f, f * frame, pose, &state, &s);
    if (options.on_frame) options.on_frame(static_cast<int>(f), state);
    if (options.hair_frames_dir.empty() || f % options.hair_stride != 0) return true;
    if (!writeFrame(options.hair_frames_dir, static_cast<int>(f), model, state, why)) return false;
    ++s.hair_frames_written;
    return true;
  };
  if (!frameDone(0, headPose(scene.motion, 0.0))) return false;
  if (options.stage_timing) stageClockSeconds();  // its rate measured before the first step
  StepClock clock(options.rtf_window_s, frame, frames);
  size_t next_event = 0;
  for (long f = 0; f < frames; ++f) {
    StepInputs in;
    in.head_start = headPose(scene.motion, f * frame);
    in.head_end = headPose(scene.motion, (f + 1) * frame);
    for (; next_event < events.size() && events[next_event].time_s <= f * frame + 1e-9;
         ++next_event) {
      SaturationCommand c;
      c.root_value = events[next_event].root;
      c.tip_value = events[next_event].tip;
      applySaturation(model, c, in.head_start, &state);
      ++s.saturation_changes;
    }
    if (s.water) stepSceneWater(scene, f * frame, frame, &model, &state, &s);
    in.obstacles = obstacles.empty() ? nullptr : &obstacles;
    in.clock = options.stage_timing ? &stageClockSeconds : nullptr;
    StepStats stats;
    const auto t0 = std::chrono::steady_clock::now();
    step(model, scene.solver, in, frame, &state, &stats);
    clock.add(f, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), &s);
    addStepStats(stats, &s);
    if (!frameDone(f + 1, in.head_end)) return false;
  }
  measurements.finish(state, &s);
  finishSummary(model, state, frames * frame, clock.wall(), &s);
  const WaterLedger& ledger = state.water_ledger;
  s.water_added_kg = ledger.added_kg;
  s.water_removed_kg = ledger.removed_kg;
  s.water_held_kg = s.water ? heldWater(state) : 0.0;
  s.water_dripped_kg = ledger.dripped_kg;
  s.water_evaporated_kg = ledger.evaporated_kg;
  s.water_drips = ledger.drips;
  *out = std::move(s);
  return true;
}

}  // namespace io
}  // namespace wet_curly_hair
