#include "wet_curly_hair/io/offline_run.h"

#include <chrono>
#include <cstdio>
#include <sys/stat.h>

#include "wet_curly_hair/core/diagnostics.h"
#include "wet_curly_hair/core/metrics.h"
#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/io/hair_file.h"
#include "wet_curly_hair/io/json.h"
#include "wet_curly_hair/io/octomap_sdf.h"
#include "wet_curly_hair/io/scene_setup.h"

namespace wet_curly_hair {
namespace io {

std::string RunSummary::toJson() const {
  JsonObject o;
  o.add("strands", strands)
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
      .add("nonfinite_values", static_cast<unsigned long long>(nonfinite_values))
      .add("finite", finite)
      .add("max_speed_end_m_s", max_speed_end_m_s)
      .add("velocity_clamps", static_cast<unsigned long long>(velocity_clamps))
      .add("strain_limited_edges", static_cast<unsigned long long>(strain_limited_edges))
      .add("head_contacts", static_cast<unsigned long long>(head_contacts))
      .add("hair_frames_written", hair_frames_written)
      .add("clump_distance_m", clump_distance_m)
      .add("jitter", jitter_m)
      .add("tangles", tangles)
      .add("max_tangles", max_tangles)
      .add("tangles_sim", tangles_sim)
      .add("curl_radius_tip_m", curl_radius_tip_m)
      .add("curl_pitch_tip_m", curl_pitch_tip_m)
      .add("obstacle_contact_s", obstacle_contact_s)
      .add("max_strand_extension", max_strand_extension)
      .add("adhesion_active", static_cast<unsigned long long>(adhesion_active))
      .add("obstacle_contacts", static_cast<unsigned long long>(obstacle_contacts))
      .add("cohesion_particles", static_cast<unsigned long long>(cohesion_particles))
      .add("sdf_build_s", sdf_build_s)
      .add("max_obstacle_penetration_m", max_obstacle_penetration_m)
      .add("integrator", integrator)
      .add("threads", threads)
      .add("time_s", time_s)
      .add("energy", energy)
      .add("kinetic_energy", kinetic_energy)
      .add("max_speed_m_s", max_speed_m_s);
  JsonObject stages;
  for (size_t k = 0; k < stage_particles.size() && k < stage_cpu_s.size(); ++k) {
    JsonObject stage;
    stage.add("particles", static_cast<unsigned long long>(stage_particles[k]))
        .add("cpu_s", stage_cpu_s[k]);
    stages.addObject(stageName(static_cast<int>(k)), stage);
  }
  o.addObject("stages", stages);
  return o.str();
}

namespace {

double steadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

bool writeFrame(const std::string& dir, int frame, const HairModel& model, const HairState& state,
                std::string* why) {
  char name[64];
  std::snprintf(name, sizeof(name), "/frame_%05d.hair", frame);
  HairFileData data =
      groomPositionsToHair(model.strand_offsets, state.wet_position, &state.saturation);
  return writeHairFile(dir + name, data, why);
}

}  // namespace

bool runScene(const SceneConfig& scene, const RunOptions& options, RunSummary* out,
              std::string* why) {
  HairModel model;
  if (!buildSceneModel(scene, &model, why)) return false;
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
  RunSummary s;
  s.integrator = scene.solver.integrator.method;
  s.threads = scene.solver.integrator.threads;
  s.stage_particles.assign(kStageCount, 0);
  s.stage_cpu_s.assign(kStageCount, 0.0);
  const HeadMotionConfig& motion = scene.motion;
  HairState state = makeState(model, headPose(motion, 0.0), headTwist(motion, 0.0));
  if (scene.saturation.root > 0.0 || scene.saturation.tip > 0.0) {
    SaturationCommand wet;
    wet.root_value = scene.saturation.root;
    wet.tip_value = scene.saturation.tip;
    applySaturation(model, wet, headPose(motion, 0.0), &state);
  }
  Obstacles obstacles;
  obstacles.analytic = scene.obstacles;
  const double frame = scene.run.frame_s;
  const long frames = std::lround(scene.run.seconds / frame);
  if (!scene.obstacle_map.file.empty()) {
    // The field covers the box the hair can reach: every root over the scripted motion, grown by
    // the longest strand (buildSdfFromOctree adds the margin).
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
      const Pose pose = headPose(motion, f * frame);
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
    if (!buildSdfFromOctree(*tree, map_in_world, reach, build, sdf.get(), &obstacles.field.field_in_world,
                            &stats, &inner)) {
      if (why) *why = "obstacle_map: " + inner;
      return false;
    }
    obstacles.field.sdf = sdf;
    s.sdf_build_s = stats.total_s;
  }
  s.strands = model.strandCount();
  s.particles = model.particleCount();
  s.substep_s = frame / substepCount(scene.solver, frame);
  // Output positions in the head frame for the jitter (three frames kept, allocated once).
  Vec3List out_prev2(model.particleCount()), out_prev1(model.particleCount());
  double jitter_sum = 0.0;
  long jitter_count = 0;
  std::vector<double> contact_time(model.strandCount(), 0.0);
  NeighborGrid metric_grid;
  metric_grid.resize(model.particleCount(), model.strand_offsets);

  auto record = [&](long f, double t, const Pose& pose) {
    const EnergyParts e = energy(model, scene.solver, pose, &state);
    s.time_s.push_back(t);
    s.energy.push_back(e.total());
    s.kinetic_energy.push_back(e.kinetic);
    s.max_speed_m_s.push_back(maxSpeed(model, state));
    const StrainStats strain = edgeStrain(model, state);
    s.max_strain = std::max(s.max_strain, strain.max);
    s.mean_strain += strain.mean;
    s.max_penetration_m = std::max(s.max_penetration_m, maxHeadPenetration(model, state, pose));
    for (int st = 0; st < model.strandCount(); ++st) {
      const int b = model.strandBegin(st), n = model.strandSize(st);
      double arc = 0.0;
      bool touching = false;
      for (int i = b; i < b + n; ++i) {
        if (i + 1 < b + n) arc += (state.position[i + 1] - state.position[i]).norm();
        if (!obstacles.empty() && i > b) {
          Vec3 normal;
          const double dist = obstacles.distance(state.position[i], &normal);
          touching = touching || dist <= scene.solver.adhesion.radius_m;
          s.max_obstacle_penetration_m = std::max(s.max_obstacle_penetration_m, -dist);
        }
      }
      s.max_strand_extension = std::max(s.max_strand_extension, arc / model.strand_length_m[st] - 1.0);
      if (touching && f > 0) contact_time[st] += frame;
    }
    for (int i = 0; i < model.particleCount(); ++i) {
      const Vec3 x = pose.applyInverse(state.wet_position[i]);
      if (f >= 2) {
        jitter_sum += (x - 2.0 * out_prev1[i] + out_prev2[i]).squaredNorm();
        ++jitter_count;
      }
      out_prev2[i] = out_prev1[i];
      out_prev1[i] = x;
    }
    if (f % 10 == 0) {
      s.max_tangles = std::max(
          s.max_tangles, tangleCount(model, state.wet_position, scene.run.strand_radius_m, &metric_grid));
    }
  };
  if (options.measure) record(0, 0.0, headPose(motion, 0.0));
  if (options.on_frame) options.on_frame(0, state);
  if (!options.hair_frames_dir.empty()) {
    if (!writeFrame(options.hair_frames_dir, 0, model, state, why)) return false;
    ++s.hair_frames_written;
  }
  double wall = 0.0;
  for (long f = 0; f < frames; ++f) {
    StepInputs in;
    in.head_start = headPose(motion, f * frame);
    in.head_end = headPose(motion, (f + 1) * frame);
    in.obstacles = obstacles.empty() ? nullptr : &obstacles;
    in.clock = options.stage_timing ? &steadySeconds : nullptr;
    StepStats stats;
    const auto t0 = std::chrono::steady_clock::now();
    step(model, scene.solver, in, frame, &state, &stats);
    wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (int k = 0; k < kStageCount; ++k) {
      s.stage_particles[k] += stats.stage_particles[k];
      s.stage_cpu_s[k] += stats.stage_cpu_s[k];
    }
    s.max_strain_before_limit = std::max(s.max_strain_before_limit, stats.max_strain_before_limit);
    s.velocity_clamps += stats.velocity_clamps;
    s.strain_limited_edges += stats.strain_limited_edges;
    s.head_contacts += stats.head_contacts;
    s.adhesion_active += stats.adhesion_active;
    s.obstacle_contacts += stats.obstacle_contacts;
    s.cohesion_particles += stats.cohesion_particles;
    if (options.measure) record(f + 1, (f + 1) * frame, in.head_end);
    if (options.on_frame) options.on_frame(static_cast<int>(f + 1), state);
    if (!options.hair_frames_dir.empty() && (f + 1) % options.hair_stride == 0) {
      if (!writeFrame(options.hair_frames_dir, static_cast<int>(f + 1), model, state, why))
        return false;
      ++s.hair_frames_written;
    }
  }
  // max_penetration_m covers the head and the obstacles alike.
  s.max_penetration_m = std::max(s.max_penetration_m, s.max_obstacle_penetration_m);
  s.jitter_m = jitter_count ? std::sqrt(jitter_sum / jitter_count) : 0.0;
  s.clump_distance_m = clumpDistance(model, state.wet_position, state.saturation,
                                     scene.run.clump_search_m, &metric_grid);
  s.tangles = tangleCount(model, state.wet_position, scene.run.strand_radius_m, &metric_grid);
  s.max_tangles = std::max(s.max_tangles, s.tangles);
  s.tangles_sim = tangleCount(model, state.position, scene.run.strand_radius_m, &metric_grid);
  const CurlShape curl = tipCurlShape(model, state.position);
  s.curl_radius_tip_m = curl.radius_m;
  s.curl_pitch_tip_m = curl.pitch_m;
  double contact_sum = 0.0;
  int touched = 0;
  for (double c : contact_time)
    if (c > 0.0) contact_sum += c, ++touched;
  s.obstacle_contact_s = touched ? contact_sum / touched : 0.0;
  s.steps = state.step_count;
  s.sim_s = frames * frame;
  s.wall_s = wall;
  if (!s.time_s.empty()) s.mean_strain /= static_cast<double>(s.time_s.size());
  s.repairs = state.warnings.total();
  s.nonfinite_values = state.warnings.nonfinite_values;
  s.finite = state.warnings.nonfinite_repairs == 0;
  for (const Vec3& p : state.position) s.finite = s.finite && p.allFinite();
  s.max_speed_end_m_s = s.max_speed_m_s.empty() ? maxSpeed(model, state) : s.max_speed_m_s.back();
  *out = std::move(s);
  return true;
}

}  // namespace io
}  // namespace wet_curly_hair
