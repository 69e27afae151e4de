// Scene YAML, the parameter table and its all-or-nothing updates.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "wet_curly_hair/io/hair_file.h"
#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/io/scene_setup.h"

using namespace wet_curly_hair;
using namespace wet_curly_hair::io;

namespace {

void expectRefused(const std::string& yaml, const std::string& key) {
  SceneConfig scene = builtinScene();
  const SceneConfig before = scene;
  std::string why;
  EXPECT_FALSE(parseSceneYaml(yaml, &scene, &why)) << yaml;
  EXPECT_NE(why.find(key), std::string::npos) << "message '" << why << "' does not name " << key;
  EXPECT_EQ(sceneToYaml(scene), sceneToYaml(before)) << "a refused scene changed the config";
}

}  // namespace

TEST(Scene, ParsesNestedKeysAndVectors) {
  SceneConfig scene;
  std::string why;
  ASSERT_TRUE(parseSceneYaml(R"(
groom: {strands: 12, particles: 20, curl_radius_m: 0.008}
solver:
  gravity_m_s2: [0, 0, -3.7]
  bend: {stiffness_n_m2: 8.0e-4}
  collision: {head_enabled: false}
motion: {type: spin, rate_hz: 1.5}
head:
  radii_m: {x: 0.1, y: 0.08, z: 0.12}
  capsules:
    - {name: neck, a_m: [0, 0, -0.05], b_m: [0, 0, -0.2], radius_m: 0.05}
)",
                             &scene, &why))
      << why;
  EXPECT_EQ(scene.groom.strands, 12);
  EXPECT_EQ(scene.groom.particles, 20);
  EXPECT_DOUBLE_EQ(scene.solver.gravity_m_s2.z(), -3.7);
  EXPECT_DOUBLE_EQ(scene.solver.bend.stiffness_n_m2, 8.0e-4);
  EXPECT_FALSE(scene.solver.collision.head_enabled);
  EXPECT_EQ(scene.motion.type, "spin");
  EXPECT_DOUBLE_EQ(scene.head.ellipsoid.radii_m.y(), 0.08);
  ASSERT_EQ(scene.head.capsules.size(), 1u);
  EXPECT_DOUBLE_EQ(scene.head.capsules[0].radius_m, 0.05);
}

TEST(Scene, BadValuesAreRefusedWithTheKeyNamed) {
  expectRefused("solver: {stretch: {axial_stiffness_n: -5}}", "solver.stretch.axial_stiffness_n");
  expectRefused("solver: {bend: {damping_n_s: .nan}}", "solver.bend.damping_n_s");
  expectRefused("groom: {linear_density_kg_per_m: 0}", "groom.linear_density_kg_per_m");
  expectRefused("groom: {particles: 0}", "groom.particles");
  expectRefused("groom: {strands: 2.5}", "groom.strands");
  expectRefused("groom: {follow_ratio: 0}", "groom.follow_ratio");
  expectRefused("groom: {follow_ratio: -4}", "groom.follow_ratio");
  expectRefused("groom: {follow_ratio: 2.5}", "groom.follow_ratio");
  expectRefused("groom: {follow_ratio: many}", "groom.follow_ratio");
  expectRefused("groom: {stranz: 10}", "groom.stranz");
  expectRefused("solver: {stretch: {stiffnes_n_per_m: 1}}", "solver.stretch.stiffnes_n_per_m");
  expectRefused("motion: {type: wobble}", "motion.type");
  expectRefused("solver: {gravity_m_s2: [0, 1]}", "solver.gravity_m_s2");
  expectRefused("solver: {bend: {smoothing_length_m: -0.01}}", "solver.bend.smoothing_length_m");
  expectRefused("solver: {collision: {head_enabled: maybe}}", "solver.collision.head_enabled");
  expectRefused("head: {capsules: [{name: x, a_m: [0, 0], b_m: [0, 0, 1], radius_m: 1}]}",
                "head.capsules[0].a_m");
  expectRefused("run: {frame_s: 0}", "run.frame_s");
  expectRefused("[1, 2, 3]", "scene");
  expectRefused("groom: {strands: [unclosed", "YAML");
}

TEST(Scene, RoundTripsThroughYaml) {
  SceneConfig scene = builtinScene();
  scene.solver.core.stiffness_n = 0.7725;
  scene.groom_file.file = "some file.hair";
  SceneConfig back;
  std::string why;
  ASSERT_TRUE(parseSceneYaml(sceneToYaml(scene), &back, &why)) << why << "\n" << sceneToYaml(scene);
  EXPECT_EQ(sceneToYaml(back), sceneToYaml(scene));
}

TEST(Scene, BuiltinSceneMatchesTheShippedDefaultYaml) {
  SceneConfig from_file;
  std::string why;
  ASSERT_TRUE(loadSceneFile(WCH_SOURCE_DIR "/config/scenes/default.yaml", &from_file, &why)) << why;
  EXPECT_EQ(sceneToYaml(from_file), sceneToYaml(builtinScene()));
}

TEST(Scene, EveryShippedSceneLoadsAndBuilds) {
  for (const char* name : {"default", "straight", "spin", "water_demo", "dense_10k"}) {
    SceneConfig scene;
    std::string why;
    const std::string path = std::string(WCH_SOURCE_DIR "/config/scenes/") + name + ".yaml";
    ASSERT_TRUE(loadSceneFile(path, &scene, &why)) << why;
    HairModel model;
    EXPECT_TRUE(buildSceneModel(scene, &model, &why)) << name << ": " << why;
  }
}

TEST(Parameters, SetIsAllOrNothingAndNamesTheBadOne) {
  SceneConfig scene = builtinScene();
  const std::string before = sceneToYaml(scene);
  std::string why;
  bool rebuild = false;
  EXPECT_FALSE(applyParameters({"solver.bend.stiffness_n_m2", "solver.nope"}, {6e-4, 1.0}, &scene,
                               &rebuild, &why));
  EXPECT_NE(why.find("solver.nope"), std::string::npos);
  EXPECT_FALSE(applyParameters({"solver.bend.stiffness_n_m2", "solver.stretch.strain_limit"},
                               {6e-4, -1.0}, &scene, &rebuild, &why));
  EXPECT_NE(why.find("solver.stretch.strain_limit"), std::string::npos);
  EXPECT_FALSE(applyParameters({"groom.strands"}, {std::nan("")}, &scene, &rebuild, &why));
  EXPECT_FALSE(applyParameters({"groom.strands"}, {1.0, 2.0}, &scene, &rebuild, &why));
  EXPECT_FALSE(applyParameters({"motion.type"}, {1.0}, &scene, &rebuild, &why));
  EXPECT_EQ(sceneToYaml(scene), before);
  ASSERT_TRUE(applyParameters({"solver.bend.stiffness_n_m2"}, {6e-4}, &scene, &rebuild, &why))
      << why;
  EXPECT_DOUBLE_EQ(scene.solver.bend.stiffness_n_m2, 6e-4);
  EXPECT_FALSE(rebuild);
  ASSERT_TRUE(applyParameters({"groom.strands"}, {40}, &scene, &rebuild, &why)) << why;
  EXPECT_TRUE(rebuild);
}

TEST(Parameters, OldPerParticleAndPerEdgeKeysAreRefusedWithTheNewKeyAndUnit) {
  // Every key the per-length parameters replaced, in a scene file and through set_parameters:
  // refused, nothing changed, and the message names the key to use and its unit.
  const struct {
    const char *yaml, *old_name, *new_name, *unit;
  } kCases[] = {
      {"groom: {particle_mass_kg: 1e-4}", "groom.particle_mass_kg", "groom.linear_density_kg_per_m",
       "kg/m"},
      {"solver: {stretch: {stiffness_n_per_m: 500}}", "solver.stretch.stiffness_n_per_m",
       "solver.stretch.axial_stiffness_n", "N per unit strain"},
      {"solver: {stretch: {damping_ns_per_m: 0.1}}", "solver.stretch.damping_ns_per_m",
       "solver.stretch.damping_n_s", "N s"},
      {"solver: {bend: {stiffness_n_per_m: 10}}", "solver.bend.stiffness_n_per_m",
       "solver.bend.stiffness_n_m2", "N m^2"},
      {"solver: {bend: {damping_ns_per_m: 0.06}}", "solver.bend.damping_ns_per_m",
       "solver.bend.damping_n_s", "N s"},
      {"solver: {bend: {smoothing_edges: 6}}", "solver.bend.smoothing_edges",
       "solver.bend.smoothing_length_m", "m"},
      {"solver: {core: {stiffness_n_per_m: 10}}", "solver.core.stiffness_n_per_m",
       "solver.core.stiffness_n", "N per unit strain"},
      {"solver: {core: {damping_ns_per_m: 0.03}}", "solver.core.damping_ns_per_m",
       "solver.core.damping_n_s", "N s"},
      {"solver: {core: {smoothing_edges: 10}}", "solver.core.smoothing_edges",
       "solver.core.smoothing_length_m", "m"},
      {"solver: {curl: {weight_n_per_m: 25}}", "solver.curl.weight_n_per_m", "solver.curl.weight_n",
       "N"},
      {"solver: {cohesion: {lin_stiffness_n_per_m: 0.004}}",
       "solver.cohesion.lin_stiffness_n_per_m", "solver.cohesion.lin_stiffness_n_per_m3",
       "N/m per m^2"},
  };
  for (const auto& c : kCases) {
    SceneConfig scene = builtinScene();
    const std::string before = sceneToYaml(scene);
    std::string why;
    EXPECT_FALSE(parseSceneYaml(c.yaml, &scene, &why)) << c.yaml;
    for (const char* part : {c.old_name, c.new_name, c.unit})
      EXPECT_NE(why.find(part), std::string::npos) << c.yaml << ": " << why;
    bool rebuild = false;
    why.clear();
    scene = builtinScene();
    EXPECT_FALSE(applyParameters({c.old_name}, {1.0}, &scene, &rebuild, &why));
    for (const char* part : {c.old_name, c.new_name, c.unit})
      EXPECT_NE(why.find(part), std::string::npos) << c.old_name << ": " << why;
    EXPECT_EQ(sceneToYaml(scene), before);
  }
}

TEST(Parameters, NamesAreUnique) {
  SceneConfig scene;
  const std::vector<ParamRef> table = parameterTable(&scene);
  for (size_t i = 0; i < table.size(); ++i)
    for (size_t j = i + 1; j < table.size(); ++j) EXPECT_NE(table[i].name, table[j].name);
}

TEST(Scene, GroomFileResampleEdgeIsValidatedWithTheKeyNamed) {
  const std::string file = "groom_file: {file: groom.hair, ";
  for (const char* bad : {"-0.01", "5e-5", "2", ".nan", ".inf"}) {
    SCOPED_TRACE(bad);
    expectRefused(file + "resample_edge_m: " + bad + "}", "groom_file.resample_edge_m");
  }
  expectRefused(file + "resample_edge_m: 0.01, resample_particles: 16}",
                "groom_file.resample_edge_m");
  SceneConfig scene = builtinScene();
  std::string why;
  ASSERT_TRUE(parseSceneYaml(file + "resample_edge_m: 0.005}", &scene, &why)) << why;
  EXPECT_DOUBLE_EQ(scene.groom_file.resample_edge_m, 0.005);
}

namespace {

/// Appends a straight strand of `n` points and `length_m` from `root` along `dir` to a .hair file.
void addLine(HairFileData* d, const Vec3& root, const Vec3& dir, double length_m, int n) {
  for (int i = 0; i < n; ++i) {
    const Vec3 p = root + dir.normalized() * (length_m * i / (n - 1));
    for (int k = 0; k < 3; ++k) d->points.push_back(static_cast<float>(p[k]));
  }
  d->strand_offsets.push_back(static_cast<uint32_t>(d->points.size() / 3));
}

}  // namespace

// A groom file as an asset pipeline writes it: strands of different lengths and point counts,
// and a few that cannot be simulated. With the default parameters it builds, and the import
// report says what was skipped.
TEST(Scene, MixedGroomFileBuildsWithTheDefaultsAndReportsWhatItSkipped) {
  HairFileData d;
  d.strand_offsets = {0};
  const Vec3 top(0, 0, 0.111);
  addLine(&d, top, Vec3(1, 0, 0), 0.05, 8);    // 0: 5 cm, 8 points.
  addLine(&d, top, Vec3(0, 1, 0), 0.30, 40);   // 1: 30 cm, 40 points.
  addLine(&d, top, Vec3(-1, 0, 0), 0.12, 16);  // 2: 12 cm, 16 points.
  addLine(&d, top, Vec3(0, -1, 0), 0.20, 5);   // 3: 20 cm, 5 points.
  addLine(&d, top, Vec3(1, 1, 0), 0.10, 2);    // 4: 2 points: skipped.
  addLine(&d, top, Vec3(1, -1, 0), 0.0, 6);    // 5: zero length: skipped.
  const std::string path = ::testing::TempDir() + "wch_test_scene_mixed.hair";
  std::string why;
  ASSERT_TRUE(writeHairFile(path, d, &why)) << why;
  SceneConfig scene;  // the defaults
  scene.groom_file.file = path;
  HairModel model;
  HairImportReport report;
  ASSERT_TRUE(buildSceneModel(scene, &model, &why, &report)) << why;
  EXPECT_EQ(model.strandCount(), 4);
  EXPECT_EQ(model.particleCount(), 8 + 40 + 16 + 5);
  EXPECT_EQ(report.strands_in_file, 6);
  ASSERT_EQ(report.skipped.size(), 2u);
  EXPECT_EQ(report.skipped[0].index, 4);
  EXPECT_EQ(report.skipped[1].index, 5);

  // Resampled to 1 cm edges: particles follow each strand's length (6, 31, 13, 21).
  scene.groom_file.resample_edge_m = 0.01;
  ASSERT_TRUE(buildSceneModel(scene, &model, &why, &report)) << why;
  EXPECT_EQ(model.particleCount(), 6 + 31 + 13 + 21);
  EXPECT_EQ(report.skipped.size(), 2u);

  // A generated groom skips nothing.
  scene.groom_file.file.clear();
  ASSERT_TRUE(buildSceneModel(scene, &model, &why, &report)) << why;
  EXPECT_TRUE(report.skipped.empty());
  EXPECT_EQ(report.strands_imported, model.strandCount());
  std::remove(path.c_str());
}

TEST(Scene, WaterSectionRoundTripsAndRefusesBadSpecsWithTheFieldNamed) {
  SceneConfig scene = builtinScene();
  EXPECT_FALSE(scene.waterActive());  // off unless asked for: nothing changes by default
  std::string why;
  ASSERT_TRUE(parseSceneYaml(
      "water: {wicking_m2_s: 3e-4, sources: ['shower:x=0,y=0,z=0.5,r=0.2,rate_kg_s=0.05,"
      "stop_s=6', 'bath:z=-0.2,start_s=10'], dryers: ['box:hx=0.3,hy=0.3,hz=0.3,start_s=6']}",
      &scene, &why))
      << why;
  EXPECT_TRUE(scene.waterActive());
  ASSERT_EQ(scene.water_sources.sources.size(), 2u);
  EXPECT_DOUBLE_EQ(scene.water_sources.sources[0].rate_kg_s, 0.05);
  EXPECT_EQ(scene.water_sources.sources[1].kind, WaterSource::Kind::kBath);
  ASSERT_EQ(scene.water_sources.dryers.size(), 1u);
  EXPECT_DOUBLE_EQ(scene.water.wicking_m2_s, 3e-4);
  SceneConfig back;
  ASSERT_TRUE(parseSceneYaml(sceneToYaml(scene), &back, &why)) << why << "\n" << sceneToYaml(scene);
  EXPECT_EQ(sceneToYaml(back), sceneToYaml(scene));
  expectRefused("water: {sources: ['shower:r=-1']}", "water.sources[0]: shower.r");
  expectRefused("water: {sources: ['shower:x=0', 'bath:z=0,stop_s=0']}",
                "water.sources[1]: bath.stop_s");
  expectRefused("water: {dryers: ['box:hz=0']}", "water.dryers[0]: box.hz");
  expectRefused("water: {dryers: 'box:hz=1'}", "water.dryers: must be a list");
  expectRefused("water: {capacity_kg_per_m: -1}", "water.capacity_kg_per_m");
  expectRefused("water: {drying: 1}", "water.drying: unknown key");
}

TEST(Scene, FollowRatioAppliesToAGroomFileByTheSameRule) {
  // The generated groom written as a .hair file and read back: the same guides (farthest-point
  // sampling on the file's roots) as the generated groom at the same follow ratio.
  SceneConfig scene;
  scene.groom.strands = 60;
  scene.groom.follow_ratio = 4;
  HairModel generated;
  std::string why;
  ASSERT_TRUE(buildSceneModel(scene, &generated, &why)) << why;
  EXPECT_EQ(generated.strandCount(), 60);
  EXPECT_EQ(generated.simulatedStrandCount(), 15);
  Groom groom;
  ASSERT_TRUE(makeGroom(scene, &groom, &why)) << why;
  const std::string path = ::testing::TempDir() + "wch_test_scene_followers.hair";
  ASSERT_TRUE(
      writeHairFile(path, groomPositionsToHair(groom.strand_offsets, groom.points, nullptr), &why))
      << why;
  scene.groom_file.file = path;
  HairModel imported;
  ASSERT_TRUE(buildSceneModel(scene, &imported, &why)) << why;
  EXPECT_EQ(imported.strandCount(), 60);
  ASSERT_EQ(imported.simulatedStrandCount(), 15);
  EXPECT_EQ(imported.followers.source_strand, generated.followers.source_strand);
  // Strands of different particle counts follow each other by normalized arc length.
  HairFileData d;
  d.strand_offsets = {0};
  const Vec3 top(0, 0, 0.111);
  addLine(&d, top, Vec3(1, 0, 0), 0.05, 8);
  addLine(&d, top, Vec3(0, 1, 0), 0.30, 40);
  addLine(&d, top, Vec3(-1, 0, 0), 0.12, 16);
  addLine(&d, top, Vec3(0, -1, 0), 0.20, 5);
  ASSERT_TRUE(writeHairFile(path, d, &why)) << why;
  scene.groom.follow_ratio = 2;
  HairModel mixed;
  ASSERT_TRUE(buildSceneModel(scene, &mixed, &why)) << why;
  ASSERT_EQ(mixed.strandCount(), 4)
      << mixed.strandSize(0) << " " << mixed.strandSize(1) << " " << mixed.strandSize(2) << " "
      << mixed.strandSize(3) << " " << mixed.strandSize(4);
  EXPECT_EQ(mixed.simulatedStrandCount(), 2);
  const FollowerMap& f = mixed.followers;
  for (int s = f.guide_strands; s < 4; ++s) {
    for (int i = 0; i < mixed.strandSize(s); ++i) {
      const size_t e =
          static_cast<size_t>(mixed.strandBegin(s) + i - mixed.strandBegin(f.guide_strands)) * 3;
      const int g = f.guide[(s - f.guide_strands) * 3];
      // Sample of particle i on its first guide: a segment of that guide, at the same fraction
      // of the length (a straight line: arc length is the distance from the root; the file holds
      // floats).
      ASSERT_GE(f.sample_index[e], mixed.strand_offsets[g]);
      ASSERT_LT(f.sample_index[e] + 1, mixed.strand_offsets[g + 1]);
      const double u = static_cast<double>(i) / (mixed.strandSize(s) - 1);
      const uint32_t a = f.sample_index[e];
      const double ug =
          ((1.0 - f.sample_fraction[e]) *
               (mixed.rest_position_head[a] - mixed.rest_position_head[mixed.strandBegin(g)])
                   .norm() +
           f.sample_fraction[e] *
               (mixed.rest_position_head[a + 1] - mixed.rest_position_head[mixed.strandBegin(g)])
                   .norm()) /
          mixed.strand_length_m[g];
      EXPECT_NEAR(ug, u, 1e-6) << "strand " << s << " particle " << i;
    }
  }
  std::remove(path.c_str());
}
