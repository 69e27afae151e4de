// The offline runner as a library: summary fields, frames written, bad scenes refused.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "wet_curly_hair/core/cohesion_grid.h"
#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/metrics.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/io/hair_file.h"
#include "wet_curly_hair/io/scene_setup.h"
#include "wet_curly_hair/runner/offline_run.h"

using namespace wet_curly_hair;
using namespace wet_curly_hair::io;

TEST(OfflineRun, SummaryOfAShortNod) {
  SceneConfig scene = builtinScene();
  scene.groom.strands = 10;
  scene.run.seconds = 0.5;
  RunOptions options;
  options.hair_frames_dir = WCH_BINARY_DIR "/test_offline_run_frames";
  options.hair_stride = 10;
  RunSummary s;
  std::string why;
  ASSERT_TRUE(runScene(scene, options, &s, &why)) << why;
  EXPECT_EQ(s.strands, 10);
  EXPECT_EQ(s.particles, 320);
  EXPECT_EQ(s.steps, 30u);
  EXPECT_NEAR(s.sim_s, 0.5, 1e-12);
  EXPECT_LE(s.substep_s, scene.solver.integrator.substep_s);
  EXPECT_TRUE(s.finite);
  EXPECT_EQ(s.repairs, 0u);
  EXPECT_LE(s.max_strain, scene.solver.stretch.strain_limit + 1e-9);
  EXPECT_EQ(s.energy.size(), 6u);  // frames 0, 6, ..., 30: the energy is sampled by default
  EXPECT_EQ(s.energy_simulated, s.energy);  // every strand simulated: the same series
  EXPECT_EQ(s.hair_frames_written, 4);      // frames 0, 10, 20, 30
  HairFileData frame;
  ASSERT_TRUE(readHairFile(options.hair_frames_dir + "/frame_00030.hair", &frame, &why)) << why;
  EXPECT_EQ(frame.strandCount(), 10);
  const std::string json = s.toJson();
  for (const char* key : {"\"strands\"",
                          "\"particles\"",
                          "\"steps\"",
                          "\"substep_s\"",
                          "\"wall_s\"",
                          "\"sim_s\"",
                          "\"max_strain\"",
                          "\"mean_strain\"",
                          "\"max_penetration_m\"",
                          "\"repairs\"",
                          "\"energy\"",
                          "\"finite\"",
                          "\"cpu\"",
                          "\"cohesion_float_lanes\"",
                          "\"cohesion_wet_sums\"",
                          "\"limit_velocity\"",
                          "\"energy_simulated\"",
                          "\"hair_mass_simulated_kg\"",
                          "\"rigid_potential_rise_simulated_max_j\"",
                          "\"head_peak_reach_speed_simulated_m_s\""})
    EXPECT_NE(json.find(key), std::string::npos) << key;
  EXPECT_EQ(s.cpu, describeThisCpu());
  EXPECT_EQ(s.limit_velocity, "inelastic");  // "auto" without hair contact
  // The built-in scene's lattice runs in float, in the lanes the build chose for its CPU.
  EXPECT_EQ(s.cohesion_float_lanes, kCohesionFloatLanes);
  EXPECT_EQ(s.cohesion_wet_sums, "particles");
}

TEST(OfflineRun, TheDefaultsAreStableOnTheChartsNodAndShake) {
  // The bench's nod_shake scene (50 dry strands, the head shaking 0.35 rad at 2 Hz, 1 s), which
  // set the default substep: the chart calls a run stable when it stays finite, repairs nothing
  // and no edge stretches past twice the strain limit before the limit acts
  // (wet_curly_hair_bench.cpp). The default substep (1e-3 s) holds that with the default strain
  // limit velocity, "auto", here "inelastic" (measured: 9.2 %); with "displacement" it did not
  // (10.8 %: docs/physics.md §3), so the two defaults stand or fall together.
  SceneConfig scene = builtinScene();
  scene.groom.strands = 50;
  scene.saturation.root = scene.saturation.tip = 0.0;
  scene.run.seconds = 1.0;
  scene.motion = HeadMotionConfig();
  std::string why;
  ASSERT_TRUE(parseMotionSpec("shake:freq_hz=2,amplitude_rad=0.35", &scene.motion, &why)) << why;
  RunSummary s;
  ASSERT_TRUE(runScene(scene, RunOptions(), &s, &why)) << why;
  EXPECT_TRUE(s.finite);
  EXPECT_EQ(s.repairs, 0u);
  EXPECT_LE(s.max_strain_before_limit, 2.0 * scene.solver.stretch.strain_limit);
  EXPECT_GT(s.strain_limited_edges, 0u);  // the limit acts: the scene tests its velocity rule
}

TEST(OfflineRun, TheCpuIsNamedWithItsFamilyModelAndAvx512) {
  // Two processors of a Zen 1 EPYC as /proc/cpuinfo lists them: the first one's values count.
  std::istringstream zen1(
      "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 23\nmodel\t\t: 1\n"
      "model name\t: AMD EPYC\nstepping\t: 2\nflags\t\t: fpu sse2 avx2 fma\n\n"
      "processor\t: 1\ncpu family\t: 25\nmodel\t\t: 17\nmodel name\t: Other\n");
  EXPECT_EQ(describeCpu(zen1), "AMD EPYC (family 23, model 1), no avx512f");
  // The name before the number, and avx512f as a whole flag, last on its line.
  std::istringstream xeon(
      "model name\t: Intel(R) Xeon(R) Processor\ncpu family\t: 6\nmodel\t\t: 143\n"
      "flags\t\t: avx2 avx512f\n");
  EXPECT_EQ(describeCpu(xeon), "Intel(R) Xeon(R) Processor (family 6, model 143), avx512f");
  // avx512fp16 alone is not avx512f.
  std::istringstream fp16_only("model name\t: X\nflags\t\t: avx512fp16 avx2\n");
  EXPECT_EQ(describeCpu(fp16_only), "X, no avx512f");
  std::istringstream empty("");
  EXPECT_EQ(describeCpu(empty), "unknown CPU, no avx512f");
}

TEST(OfflineRun, FollowRatioReportsOutputAndGuideStrandsAndWritesEveryStrand) {
  SceneConfig scene = builtinScene();
  scene.groom.strands = 40;
  scene.groom.follow_ratio = 3;  // ceil(40 / 3) = 14 guides
  scene.run.seconds = 0.25;
  scene.saturation.root = 0.5;
  scene.saturation.tip = 1.0;
  RunOptions options;
  options.hair_frames_dir = WCH_BINARY_DIR "/test_offline_run_follow_frames";
  options.hair_stride = 15;
  RunSummary s;
  std::string why;
  ASSERT_TRUE(runScene(scene, options, &s, &why)) << why;
  EXPECT_EQ(s.strands, 40);
  EXPECT_EQ(s.guide_strands, 14);
  EXPECT_EQ(s.particles, 40 * 32);
  EXPECT_TRUE(s.finite);
  EXPECT_GT(s.clump_distance_m, 0.0);
  // The head penetration is measured on every output strand, followers too.
  EXPECT_LE(s.max_head_penetration_after_first_step_m, 1e-9);
  // The guides' energy, a series of its own beside every strand's (the hard cases judge it).
  ASSERT_GT(s.energy.size(), 1u);
  ASSERT_EQ(s.energy_simulated.size(), s.energy.size());
  for (size_t f = 0; f < s.energy.size(); ++f) {
    EXPECT_TRUE(std::isfinite(s.energy_simulated[f])) << f;
    EXPECT_NE(s.energy_simulated[f], s.energy[f]) << f;
  }
  HairFileData frame;
  ASSERT_TRUE(readHairFile(options.hair_frames_dir + "/frame_00015.hair", &frame, &why)) << why;
  EXPECT_EQ(frame.strandCount(), 40);
  const std::string json = s.toJson();
  EXPECT_NE(json.find("\"guide_strands\": 14"), std::string::npos) << json.substr(0, 300);
}

TEST(OfflineRun, ReportsStrandsTooCoarseForTheBendingSmoothingAndRefusesAnUnstableExplicitStep) {
  // 16 particles on 25 cm: 17 mm edges, and alpha_b = 48 mm is under 4 of them on every strand;
  // 32 particles: 8 mm edges, none. The explicit bound shrinks with the edge (2.3e-4 s at 32,
  // about 1.2e-4 s at 64): 2e-4 s is refused at 64 with the field named, and nothing runs. The
  // implicit default runs its configured substep at every resolution.
  for (int particles : {16, 32, 64}) {
    SceneConfig scene = builtinScene();
    scene.solver.integrator.method = "explicit";
    scene.solver.integrator.substep_s = 2e-4;
    scene.groom.strands = 6;
    scene.groom.particles = particles;
    scene.run.seconds = 0.1;
    RunSummary s;
    std::string why;
    if (particles == 64) {
      EXPECT_FALSE(runScene(scene, RunOptions(), &s, &why));
      EXPECT_NE(why.find("solver.integrator.substep_s"), std::string::npos) << why;
      EXPECT_NE(why.find("stability bound"), std::string::npos) << why;
      continue;
    }
    ASSERT_TRUE(runScene(scene, RunOptions(), &s, &why)) << why;
    EXPECT_EQ(s.bend_stabilized_strands, particles == 16 ? 6 : 0) << particles;
    EXPECT_TRUE(s.finite);
  }
  SceneConfig scene = builtinScene();
  scene.groom.strands = 6;
  scene.groom.particles = 64;
  scene.run.seconds = 0.1;
  RunSummary s;
  std::string why;
  ASSERT_TRUE(runScene(scene, RunOptions(), &s, &why)) << why;
  EXPECT_LE(s.substep_s, scene.solver.integrator.substep_s);
  EXPECT_GT(s.substep_s, 0.9 * scene.solver.integrator.substep_s);  // a frame in equal parts
}

TEST(OfflineRun, BadSceneIsRefused) {
  SceneConfig scene = builtinScene();
  scene.groom.particles = 1;
  RunSummary s;
  std::string why;
  EXPECT_FALSE(runScene(scene, RunOptions(), &s, &why));
  EXPECT_NE(why.find("groom.particles"), std::string::npos);
  scene = builtinScene();
  scene.groom_file.file = "/nonexistent/hair.hair";
  EXPECT_FALSE(runScene(scene, RunOptions(), &s, &why));
  EXPECT_NE(why.find("/nonexistent/hair.hair"), std::string::npos);
}

namespace {

/// The built-in scene with sintel_lite.hair (228 strands, Blender units: scale 0.01 to metres,
/// y up) as its groom, moved down onto the built-in head, 24 particles per strand.
SceneConfig sintelOnTheBuiltInHead() {
  SceneConfig scene = builtinScene();
  scene.groom_file.file = WCH_SOURCE_DIR "/../shared/data/sintel_lite.hair";
  scene.groom_file.scale = 0.01;
  scene.groom_file.up_axis = "y";
  scene.groom_file.offset_m = Vec3(0.0, 0.0, -0.35);
  scene.groom_file.resample_particles = 24;
  return scene;
}

}  // namespace

TEST(OfflineRun, RealHairFromAnotherTool) {
  SceneConfig scene = sintelOnTheBuiltInHead();
  struct stat st;
  ASSERT_EQ(stat(scene.groom_file.file.c_str(), &st), 0)
      << scene.groom_file.file << " not present (shared/data/ lies beside the package)";
  scene.solver.collision.head_enabled = false;  // the Sintel head is not our ellipsoid
  scene.run.seconds = 0.25;
  RunSummary s;
  std::string why;
  ASSERT_TRUE(runScene(scene, RunOptions(), &s, &why)) << why;
  EXPECT_EQ(s.strands, 228);
  EXPECT_EQ(s.particles, 228 * 24);
  EXPECT_TRUE(s.finite);
}

TEST(OfflineRun, RealHairFromAnotherHeadSitsOnThisOneWithRootsOnTheScalp) {
  // Sintel's groom on the built-in head, its collision on: Sintel's roots lie from about 1 cm
  // inside the ellipsoid to 2 cm outside it. The kinematic roots inside hold each strand's first
  // edge against the head's projection; moved onto the scalp, nothing is held inside.
  SceneConfig scene = sintelOnTheBuiltInHead();
  struct stat st;
  ASSERT_EQ(stat(scene.groom_file.file.c_str(), &st), 0)
      << scene.groom_file.file << " not present (shared/data/ lies beside the package)";
  scene.run.seconds = 0.25;
  const RunOptions options;
  RunSummary as_authored, on_scalp;
  std::string why;
  ASSERT_TRUE(runScene(scene, options, &as_authored, &why)) << why;
  scene.groom_file.roots_on_scalp = true;
  ASSERT_TRUE(runScene(scene, options, &on_scalp, &why)) << why;
  EXPECT_EQ(as_authored.roots_moved, 0);
  EXPECT_GT(as_authored.roots_inside_scalp, 0);
  EXPECT_GT(as_authored.deepest_root_m, 5.0 * scene.solver.collision.offset_m);
  EXPECT_EQ(on_scalp.roots_moved, 228);
  EXPECT_EQ(on_scalp.roots_inside_scalp, 0);
  EXPECT_GT(on_scalp.root_move_max_m, 0.005);
  // As authored, roots sit 1 cm inside the head and the first edges are stretched to the limit.
  const double offset = scene.solver.collision.offset_m, limit = scene.solver.stretch.strain_limit;
  EXPECT_GT(as_authored.max_head_penetration_after_first_step_m, 5.0 * offset);
  EXPECT_GE(as_authored.max_strain_end, limit * (1.0 - 1e-9));
  // On the scalp: no particle deeper than the collision's offset after the first step, and no
  // edge held at the strain limit.
  EXPECT_LT(on_scalp.max_head_penetration_after_first_step_m, offset);
  EXPECT_LT(on_scalp.max_strain_end, 0.5 * limit);
  EXPECT_TRUE(on_scalp.finite);
  EXPECT_EQ(on_scalp.repairs, 0);
}

#include <octomap/octomap.h>

namespace {

/// An OctoMap of a sphere (occupied where the voxel centre is inside), free around it.
std::string writeSphereOctomap(const std::string& name, double radius, double res) {
  octomap::OcTree tree(res);
  const int n = static_cast<int>(std::ceil(2.0 * radius / res)) + 4;
  for (int k = -n; k <= n; ++k)
    for (int j = -n; j <= n; ++j)
      for (int i = -n; i <= n; ++i) {
        const Vec3 c = res * Vec3(i + 0.5, j + 0.5, k + 0.5);
        tree.updateNode(octomap::point3d(c.x(), c.y(), c.z()), c.norm() < radius, true);
      }
  tree.updateInnerOccupancy();
  const std::string path = std::string(WCH_BINARY_DIR) + "/" + name;
  EXPECT_TRUE(tree.writeBinary(path));
  return path;
}

}  // namespace

TEST(OfflineRun, HairBrushingAnOctomapSphereStaysOutAndWetHairAdheres) {
  // The head slides sideways under a sphere known only as an OctoMap (5 mm voxels).
  SceneConfig scene;
  std::string why;
  ASSERT_TRUE(loadSceneFile(WCH_SOURCE_DIR "/config/paper/adhesion.yaml", &scene, &why)) << why;
  scene.obstacles.clear();
  scene.obstacle_map.file = writeSphereOctomap("sphere_r6cm.bt", 0.06, 0.005);
  scene.obstacle_map.offset_m = Vec3(0.0, 0.25, 0.25);
  scene.groom.strands = 30;
  scene.run.seconds = 1.5;
  RunSummary dry, wet;
  ASSERT_TRUE(runScene(scene, RunOptions(), &dry, &why)) << why;
  scene.saturation = {1.0, 1.0};
  ASSERT_TRUE(runScene(scene, RunOptions(), &wet, &why)) << why;
  EXPECT_GT(dry.sdf_build_s, 0.0);
  EXPECT_GT(dry.obstacle_contacts, 0u) << "the hair reaches the sphere";
  // Kept out to within the field's accuracy (half a voxel) beyond the collision offset.
  for (const RunSummary* s : {&dry, &wet}) {
    EXPECT_LE(s->max_obstacle_penetration_m, 0.0025 + 1e-9);
    EXPECT_TRUE(s->finite);
  }
  EXPECT_GT(wet.adhesion_active, 0u);
  EXPECT_EQ(dry.adhesion_active, 0u);
  EXPECT_GT(wet.obstacle_contact_s, dry.obstacle_contact_s) << "wet strands stay on longer";
}

TEST(OfflineRun, BadObstacleMapIsRefused) {
  SceneConfig scene = builtinScene();
  scene.run.seconds = 0.1;
  scene.obstacle_map.file = std::string(WCH_BINARY_DIR) + "/not_an_octomap.bt";
  { std::ofstream(scene.obstacle_map.file) << "garbage, not an octree\n"; }
  RunSummary s;
  std::string why;
  EXPECT_FALSE(runScene(scene, RunOptions(), &s, &why));
  EXPECT_NE(why.find("obstacle_map"), std::string::npos) << why;
}

TEST(OfflineRun, ScriptedSaturationChangesSeriesStrideAndHardCaseKeys) {
  SceneConfig scene = builtinScene();
  scene.groom.strands = 6;
  scene.run.seconds = 1.0;
  scene.saturation = SaturationInit();  // dry start
  scene.motion.type = "spin";
  scene.motion.rate_hz = 1.0;
  scene.motion.stop_s = 0.5;
  RunOptions options;
  options.saturation_events = {{0.5, 0.0, 0.0}, {0.25, 1.0, 1.0}};  // applied in time order
  options.series_stride = 10;
  options.rtf_window_s = 0.25;
  RunSummary s;
  std::string why;
  ASSERT_TRUE(runScene(scene, options, &s, &why)) << why;
  EXPECT_EQ(s.saturation_changes, 2);
  EXPECT_EQ(s.energy.size(), 7u);  // frames 0, 10, ..., 60
  EXPECT_NEAR(s.time_s.back(), 1.0, 1e-12);
  EXPECT_EQ(s.realtime_factor_windows.size(), 4u);
  // Carried rigidly at 1 rev/s, a point at radius r moves at 2 pi r: the reach speed covers the
  // strand at full extension from its root; the groom's own rigid energy is below that bound.
  EXPECT_GT(s.head_peak_reach_speed_m_s, 2.0 * M_PI * scene.groom.length_m);
  EXPECT_LT(s.head_peak_reach_speed_m_s, 2.0 * M_PI * (0.11 + 1.2 * scene.groom.length_m));
  EXPECT_GT(s.rigid_kinetic_energy_max_j, 0.0);
  EXPECT_LE(s.rigid_kinetic_energy_max_j,
            0.5 * s.hair_mass_kg * s.head_peak_reach_speed_m_s * s.head_peak_reach_speed_m_s);
  EXPECT_NEAR(s.rigid_potential_rise_max_j, 0.0, 1e-12);  // a spin about z lifts nothing
  {
    // Lumped masses: every strand weighs rho times its length less the root's half edge.
    HairModel model;
    ASSERT_TRUE(io::buildSceneModel(scene, &model, &why)) << why;
    double mass = 0.0;
    for (int st = 0; st < model.strandCount(); ++st) {
      const int b = model.strandBegin(st);
      const Vec3 root_edge = model.rest_position_head[b + 1] - model.rest_position_head[b];
      mass += scene.groom.linear_density_kg_per_m *
              (model.strand_length_m[st] - 0.5 * root_edge.norm());
    }
    EXPECT_NEAR(s.hair_mass_kg, mass, 1e-12);
  }
  EXPECT_EQ(s.max_strain_start, 0.0);
  EXPECT_LE(s.max_penetration_after_first_step_m, s.max_penetration_m);
  EXPECT_GT(s.rss_end_kb, 0);
  EXPECT_GE(s.rss_peak_kb, s.rss_end_kb);
  const std::string json = s.toJson();
  for (const char* key :
       {"\"max_penetration_after_first_step_m\"", "\"rigid_kinetic_energy_max_j\"",
        "\"head_peak_reach_speed_m_s\"", "\"saturation_changes\"", "\"rss_end_kb\"",
        "\"realtime_factor_windows\"", "\"mean_strain_end\"", "\"mean_strand_extension_end\""})
    EXPECT_NE(json.find(key), std::string::npos) << key;
  // A saturation outside [0, 1] is refused with the option named.
  options.saturation_events = {{0.1, 1.5, 0.0}};
  EXPECT_FALSE(runScene(scene, options, &s, &why));
  EXPECT_NE(why.find("--saturation-at"), std::string::npos) << why;
}

TEST(OfflineRun, StrandsStartingInsideAnObstacleArePushedOutInTheFirstStep) {
  // A sphere over the crown where the standing curls are at t = 0 (config/hard/inside_obstacle).
  SceneConfig scene = builtinScene();
  scene.groom.strands = 12;
  scene.run.seconds = 0.25;
  scene.motion.type = "still";
  AnalyticObstacle sphere;
  std::string why;
  ASSERT_TRUE(AnalyticObstacle::parse("sphere:x=-0.04,y=0,z=0.25,r=0.06", &sphere, &why)) << why;
  scene.obstacles = {sphere};
  RunSummary s;
  ASSERT_TRUE(runScene(scene, RunOptions(), &s, &why)) << why;
  EXPECT_GT(s.max_obstacle_penetration_m, 0.01);  // frame 0: deep inside
  EXPECT_LE(s.max_obstacle_penetration_after_first_step_m, scene.solver.obstacle.offset_m);
}

TEST(OfflineRun, ANonFiniteRunExitsOne) {
  // A velocity gone NaN: step() restores the strand and counts it; the run did not stay finite
  // although every position is finite again, and the runner exits 1. A healthy run exits 0.
  GroomConfig g;
  g.strands = 3;
  g.particles = 12;
  SolverConfig config;
  HairModel model;
  std::string why;
  ASSERT_TRUE(buildModel(generateGroom(g, EllipsoidShape()), GroomConfig().linear_density_kg_per_m,
                         HeadShape(), config, &model, &why))
      << why;
  HairState state = makeState(model, Pose(), Twist());
  const StepInputs still{Pose(), Pose()};
  step(model, config, still, 1.0 / 60, &state, nullptr);
  EXPECT_TRUE(runStayedFinite(state));
  RunSummary summary;
  summary.finite = runStayedFinite(state);
  EXPECT_EQ(runExitCode(summary), 0);
  state.velocity[model.strandBegin(1) + 4].x() = std::nan("");
  step(model, config, still, 1.0 / 60, &state, nullptr);
  EXPECT_EQ(state.warnings.nonfinite_repairs, 1u);
  for (const Vec3& p : state.position) ASSERT_TRUE(p.allFinite());
  EXPECT_FALSE(runStayedFinite(state));
  summary.finite = runStayedFinite(state);
  EXPECT_EQ(runExitCode(summary), 1);
}

TEST(OfflineRun, MeasurementsAreNamedTimedAndFollowTheirFlags) {
  SceneConfig scene = builtinScene();
  scene.groom.strands = 8;
  scene.run.seconds = 0.25;
  RunSummary s;
  std::string why;
  ASSERT_TRUE(runScene(scene, RunOptions(), &s, &why)) << why;
  std::vector<std::string> defaults = {
      "rigid_motion", "energy",         "strain",  "head_penetration", "obstacles",
      "jitter",       "clump_distance", "tangles", "curl_shape",       "head_distance"};
  EXPECT_EQ(s.measurements, defaults);
  EXPECT_EQ(s.crossings, -1);  // hair contact off: not measured
  EXPECT_GT(s.mean_head_distance_m, 0.0);
  {
    // Hair contact on: crossings are measured every frame (the series has one per frame).
    SceneConfig contact = scene;
    contact.solver.hair_contact.enabled = true;
    RunSummary c;
    ASSERT_TRUE(runScene(contact, RunOptions(), &c, &why)) << why;
    std::vector<std::string> with = defaults;
    with.insert(with.end() - 1, "crossings");
    EXPECT_EQ(c.measurements, with);
    EXPECT_GE(c.crossings, 0);
    EXPECT_EQ(c.crossings_series.size(), 15u);    // 0.25 s at 60 Hz
    EXPECT_EQ(c.limit_velocity, "displacement");  // "auto" with hair contact
  }
  ASSERT_EQ(s.measurement_s.size(), defaults.size());
  double sum = 0.0;
  for (double t : s.measurement_s) {
    EXPECT_GE(t, 0.0);
    sum += t;
  }
  EXPECT_DOUBLE_EQ(s.measure_wall_s, sum);
  EXPECT_EQ(s.sample_stride, 1);  // 8 strands: every strand, exact
  EXPECT_EQ(s.sampled_strands, 8);
  const std::string json = s.toJson();
  EXPECT_NE(json.find("\"measurements\": [\"rigid_motion\", \"energy\""), std::string::npos)
      << json;
  EXPECT_NE(json.find("\"measurement_s\""), std::string::npos);
  EXPECT_NE(json.find("\"measure_wall_s\""), std::string::npos);

  // Everything optional off: what still runs is listed, nothing else.
  RunOptions off;
  off.measure = false;
  off.clump_distance = false;
  off.tangles = false;
  ASSERT_TRUE(runScene(scene, off, &s, &why)) << why;
  EXPECT_EQ(s.measurements, (std::vector<std::string>{"rigid_motion", "curl_shape"}));
  EXPECT_TRUE(s.energy.empty());
  EXPECT_EQ(s.sampled_strands, 0);

  // The opt-in tangle series, and sampling: every 3rd strand of 40 when 14 are asked for. The
  // runner's counts are those of the sampled measurement on the last frame's positions (thick
  // strands, so that they touch).
  RunOptions sampled;
  sampled.tangle_series = true;
  sampled.tangle_series_stride = 5;
  sampled.sample_strands = 14;
  HairState last;
  sampled.on_frame = [&](int, const HairState& state) { last = state; };
  scene.groom.strands = 40;
  scene.run.strand_radius_m = 0.003;
  ASSERT_TRUE(runScene(scene, sampled, &s, &why)) << why;
  EXPECT_NE(std::find(s.measurements.begin(), s.measurements.end(), "tangle_series"),
            s.measurements.end());
  EXPECT_EQ(s.sample_stride, 3);
  EXPECT_EQ(s.sampled_strands, 14);
  HairModel model;
  ASSERT_TRUE(buildSceneModel(scene, &model, &why)) << why;
  MetricScratch scratch;
  const double r = scene.run.strand_radius_m, search = scene.run.clump_search_m;
  const int exact = tangleCount(model, displayPositions(last), r, &scratch, 1, 1);
  const int estimate = tangleCount(model, displayPositions(last), r, &scratch, 1, 3);
  ASSERT_GT(exact, 0);
  ASSERT_NE(estimate, exact) << "the check below must tell the estimate from the exact count";
  EXPECT_EQ(s.tangles, estimate);
  EXPECT_EQ(s.tangles_sim, tangleCount(model, last.position, r, &scratch, 1, 3));
  EXPECT_EQ(s.clump_distance_m,
            clumpDistance(model, displayPositions(last), last.saturation, search, &scratch, 1, 3));
  EXPECT_NE(s.clump_distance_m,
            clumpDistance(model, displayPositions(last), last.saturation, search, &scratch, 1, 1));
  EXPECT_GE(s.max_tangles, s.tangles);

  sampled.sample_strands = -1;
  EXPECT_FALSE(runScene(scene, sampled, &s, &why));
  EXPECT_NE(why.find("--sample-strands"), std::string::npos) << why;
}

/// The rigid-motion figures of a run of `scene`, against the sum over its particles frame by
/// frame.
/// The rigid-motion input of strands [0, strands), summed particle by particle.
struct RigidMotionSums {
  double ke_max = 0.0, rise_max = 0.0, reach_max = 0.0, mass = 0.0;
};
RigidMotionSums rigidMotionOfParticles(const SceneConfig& scene, const HairModel& model,
                                       int strands) {
  const double frame = scene.run.frame_s;
  const long frames = std::lround(scene.run.seconds / frame);
  auto potential = [&](const Pose& pose) {
    double u = 0.0;
    for (int st = 0; st < strands; ++st)
      for (int i = model.strandBegin(st) + 1; i < model.strandBegin(st) + model.strandSize(st); ++i)
        u -= model.mass_kg[i] *
             scene.solver.gravity_m_s2.dot(pose.apply(model.rest_position_head[i]));
    return u;
  };
  RigidMotionSums r;
  const double u0 = potential(headPose(scene.motion, 0.0));
  for (long f = 0; f < frames; ++f) {
    const Pose a = headPose(scene.motion, f * frame), b = headPose(scene.motion, (f + 1) * frame);
    double ke = 0.0;
    r.mass = 0.0;
    for (int st = 0; st < strands; ++st) {
      const int begin = model.strandBegin(st);
      for (int i = begin + 1; i < begin + model.strandSize(st); ++i) {
        const Vec3 v =
            (b.apply(model.rest_position_head[i]) - a.apply(model.rest_position_head[i])) / frame;
        ke += 0.5 * model.mass_kg[i] * v.squaredNorm();
        r.mass += model.mass_kg[i];
      }
      const double w = Eigen::AngleAxisd(b.rotation * a.rotation.conjugate()).angle() / frame;
      const double rr = (a.apply(model.rest_position_head[begin]) - a.translation).norm();
      r.reach_max = std::max(r.reach_max, (b.translation - a.translation).norm() / frame +
                                              std::abs(w) * (rr + model.strand_length_m[st]));
    }
    r.ke_max = std::max(r.ke_max, ke);
    r.rise_max = std::max(r.rise_max, potential(b) - u0);
  }
  return r;
}

void expectRigidMotionOfParticles(const SceneConfig& scene) {
  RunOptions options;
  options.measure = false;
  RunSummary s;
  std::string why;
  ASSERT_TRUE(runScene(scene, options, &s, &why)) << why;
  HairModel model;
  ASSERT_TRUE(buildSceneModel(scene, &model, &why)) << why;
  const RigidMotionSums all = rigidMotionOfParticles(scene, model, model.strandCount());
  ASSERT_GT(all.ke_max, 0.0);
  ASSERT_GT(all.rise_max, 0.0);
  EXPECT_NEAR(s.rigid_kinetic_energy_max_j, all.ke_max, 1e-9 * all.ke_max) << scene.motion.type;
  EXPECT_NEAR(s.rigid_potential_rise_max_j, all.rise_max, 1e-9 * all.rise_max) << scene.motion.type;
  EXPECT_NEAR(s.head_peak_reach_speed_m_s, all.reach_max, 1e-12 * all.reach_max)
      << scene.motion.type;
  EXPECT_NEAR(s.hair_mass_kg, all.mass, 1e-12 * all.mass);
  // The same for the simulated strands (the guides first, with followers), which the hard
  // cases' energy criterion judges with energy_simulated.
  const RigidMotionSums sim = rigidMotionOfParticles(scene, model, model.simulatedStrandCount());
  EXPECT_NEAR(s.rigid_potential_rise_simulated_max_j, sim.rise_max, 1e-9 * sim.rise_max)
      << scene.motion.type;
  EXPECT_NEAR(s.head_peak_reach_speed_simulated_m_s, sim.reach_max, 1e-12 * sim.reach_max)
      << scene.motion.type;
  EXPECT_NEAR(s.hair_mass_simulated_kg, sim.mass, 1e-12 * sim.mass);
  if (model.simulatedStrandCount() < model.strandCount())
    EXPECT_LT(s.hair_mass_simulated_kg, s.hair_mass_kg);
  else
    EXPECT_EQ(s.hair_mass_simulated_kg, s.hair_mass_kg);
}

TEST(OfflineRun, RigidMotionFromMassMomentsEqualsTheSumOverParticles) {
  SceneConfig scene = builtinScene();
  scene.groom.strands = 10;
  scene.run.seconds = 0.5;
  scene.motion.type = "nod";  // a turn that lifts the hair
  scene.motion.freq_hz = 1.5;
  scene.motion.amplitude_rad = 0.4;
  expectRigidMotionOfParticles(scene);
  scene.motion.type = "linear";  // a climb
  scene.motion.speed_m_s = 0.7;
  scene.motion.axis = Vec3(1.0, 0.0, 1.0).normalized();
  expectRigidMotionOfParticles(scene);
  scene.groom.follow_ratio = 3;  // 4 guides of 10: their own input
  expectRigidMotionOfParticles(scene);
}

TEST(OfflineRun, JitterIsTheRmsSecondDifferenceForAnyThreadCount) {
  SceneConfig scene = builtinScene();
  scene.groom.strands = 12;
  scene.run.seconds = 0.2;
  // The second difference of the output positions in the head frame, from the frames.
  std::vector<Vec3List> frames;
  RunOptions options;
  options.on_frame = [&](int f, const HairState& state) {
    const Pose pose = headPose(scene.motion, f * scene.run.frame_s);
    Vec3List x(displayPositions(state).size());
    for (size_t i = 0; i < x.size(); ++i) x[i] = pose.applyInverse(displayPositions(state)[i]);
    frames.push_back(x);
  };
  RunSummary one, two;
  std::string why;
  ASSERT_TRUE(runScene(scene, options, &one, &why)) << why;
  double sum = 0.0;
  long count = 0;
  for (size_t f = 2; f < frames.size(); ++f)
    for (size_t i = 0; i < frames[f].size(); ++i, ++count)
      sum += (frames[f][i] - 2.0 * frames[f - 1][i] + frames[f - 2][i]).squaredNorm();
  ASSERT_GT(sum, 0.0);
  EXPECT_NEAR(one.jitter_m, std::sqrt(sum / count), 1e-9 * one.jitter_m);
  scene.solver.integrator.threads = 2;
  options.on_frame = nullptr;
  ASSERT_TRUE(runScene(scene, options, &two, &why)) << why;
  EXPECT_EQ(two.jitter_m, one.jitter_m);
}

TEST(OfflineRun, ObstacleFiguresOnThreadsEqualThoseOfTheFrames) {
  // Wet hair of a shaking head brushing a sphere at its side: strands touch for different
  // times, some not at all.
  SceneConfig scene = builtinScene();
  scene.groom.strands = 24;
  scene.run.seconds = 0.5;
  scene.motion.type = "shake";
  scene.motion.freq_hz = 2.0;
  scene.motion.amplitude_rad = 0.5;
  scene.saturation.root = scene.saturation.tip = 1.0;
  scene.solver.integrator.threads = 2;
  AnalyticObstacle sphere;
  std::string why;
  ASSERT_TRUE(AnalyticObstacle::parse("sphere:x=0,y=0.16,z=0.02,r=0.06", &sphere, &why)) << why;
  scene.obstacles = {sphere};
  HairModel model;
  ASSERT_TRUE(buildSceneModel(scene, &model, &why)) << why;
  Obstacles obstacles;
  obstacles.analytic = scene.obstacles;
  double worst = 0.0;
  std::vector<double> contact(model.strandCount(), 0.0);
  RunOptions options;
  options.on_frame = [&](int f, const HairState& state) {
    for (int st = 0; st < model.strandCount(); ++st) {
      bool touching = false;
      for (int i = model.strandBegin(st) + 1; i < model.strandBegin(st) + model.strandSize(st);
           ++i) {
        Vec3 n;
        const double d = obstacles.distance(state.position[i], &n);
        touching = touching || d <= scene.solver.adhesion.radius_m;
        worst = std::max(worst, -d);
      }
      if (touching && f > 0) contact[st] += scene.run.frame_s;
    }
  };
  RunSummary s;
  ASSERT_TRUE(runScene(scene, options, &s, &why)) << why;
  double sum = 0.0;
  int touched = 0;
  for (double c : contact)
    if (c > 0.0) sum += c, ++touched;
  ASSERT_GT(touched, 0);
  ASSERT_LT(touched, model.strandCount());
  ASSERT_NE(*std::min_element(contact.begin(), contact.end()),
            *std::max_element(contact.begin(), contact.end()));
  ASSERT_GT(worst, 0.0);
  EXPECT_EQ(s.max_obstacle_penetration_m, worst);
  EXPECT_EQ(s.obstacle_contact_s, sum / touched);
  EXPECT_EQ(s.obstacle_contact_strand_s, sum);
  EXPECT_EQ(s.obstacle_contact_strands, touched);
}

// The water stage in a run: a shower then a dryer; the JSON's totals balance, the series follow
// the water (rising under the shower, falling under the dryer), and a run without water keeps
// its totals at zero.
TEST(OfflineRun, WaterTotalsBalanceAndTheSeriesFollowTheWater) {
  SceneConfig scene = builtinScene();
  scene.groom.strands = 20;
  scene.run.seconds = 1.0;
  scene.motion.type = "still";
  std::string why;
  ASSERT_TRUE(
      parseSceneYaml("water: {sources: ['shower:x=0,y=0,z=0.5,r=0.3,rate_kg_s=0.05,stop_s=0.5'], "
                     "dryers: ['box:hx=1,hy=1,hz=1,rate_per_s=2,start_s=0.5']}",
                     &scene, &why))
      << why;
  RunSummary s;
  ASSERT_TRUE(runScene(scene, RunOptions(), &s, &why)) << why;
  EXPECT_TRUE(s.water);
  const double initial = s.water_added_kg - 0.05 * 0.5;  // the scene's wet tips
  EXPECT_GT(initial, 0.0);
  EXPECT_NEAR(s.water_added_kg - s.water_removed_kg,
              s.water_held_kg + s.water_dripped_kg + s.water_evaporated_kg,
              1e-12 * s.water_added_kg);
  ASSERT_EQ(s.mean_saturation.size(), s.time_s.size());
  ASSERT_EQ(s.water_held_series_kg.size(), s.time_s.size());
  ASSERT_EQ(s.mean_tip_height_m.size(), s.time_s.size());
  ASSERT_EQ(s.clump_distance_series_m.size(), s.time_s.size());
  const size_t half = s.time_s.size() / 2;  // t = 0.5 s
  EXPECT_GT(s.water_held_series_kg[half], s.water_held_series_kg.front());
  EXPECT_LT(s.water_held_series_kg.back(), s.water_held_series_kg[half]);
  EXPECT_GT(s.mean_saturation[half], s.mean_saturation.front());
  EXPECT_NE(std::find(s.measurements.begin(), s.measurements.end(), "water"), s.measurements.end());
  const std::string json = s.toJson();
  for (const char* key : {"\"water_added_kg\"", "\"water_held_kg\"", "\"water_dripped_kg\"",
                          "\"water_evaporated_kg\"", "\"mean_saturation\""})
    EXPECT_NE(json.find(key), std::string::npos) << key;

  SceneConfig dry = builtinScene();
  dry.groom.strands = 5;
  dry.run.seconds = 0.1;
  ASSERT_TRUE(runScene(dry, RunOptions(), &s, &why)) << why;
  EXPECT_FALSE(s.water);
  EXPECT_EQ(s.water_added_kg, 0.0);
  EXPECT_TRUE(s.water_held_series_kg.empty());
  EXPECT_EQ(s.mean_saturation.size(), s.time_s.size());
}
