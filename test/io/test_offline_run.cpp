// The offline runner as a library: summary fields, frames written, bad scenes refused.
#include <gtest/gtest.h>

#include <cstdio>
#include <sys/stat.h>

#include "wet_curly_hair/io/hair_file.h"
#include "wet_curly_hair/io/offline_run.h"

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
  EXPECT_EQ(s.energy.size(), 31u);
  EXPECT_EQ(s.hair_frames_written, 4);  // frames 0, 10, 20, 30
  HairFileData frame;
  ASSERT_TRUE(readHairFile(options.hair_frames_dir + "/frame_00030.hair", &frame, &why)) << why;
  EXPECT_EQ(frame.strandCount(), 10);
  const std::string json = s.toJson();
  for (const char* key : {"\"strands\"", "\"particles\"", "\"steps\"", "\"substep_s\"", "\"wall_s\"",
                          "\"sim_s\"", "\"max_strain\"", "\"mean_strain\"", "\"max_penetration_m\"",
                          "\"repairs\"", "\"energy\"", "\"finite\""})
    EXPECT_NE(json.find(key), std::string::npos) << key;
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

TEST(OfflineRun, RealHairFromAnotherTool) {
  // sintel_lite.hair: 228 strands, Blender units (scale 0.01 to metres), y up.
  const std::string path = WCH_SOURCE_DIR "/../shared/data/sintel_lite.hair";
  struct stat st;
  if (stat(path.c_str(), &st) != 0) GTEST_SKIP() << path << " not present";
  SceneConfig scene = builtinScene();
  scene.groom_file.file = path;
  scene.groom_file.scale = 0.01;
  scene.groom_file.up_axis = "y";
  scene.groom_file.offset_m = Vec3(0.0, 0.0, -0.35);
  scene.groom_file.resample_particles = 24;
  scene.solver.collision.head_enabled = false;  // the Sintel head is not our ellipsoid
  scene.run.seconds = 0.25;
  RunSummary s;
  std::string why;
  ASSERT_TRUE(runScene(scene, RunOptions(), &s, &why)) << why;
  EXPECT_EQ(s.strands, 228);
  EXPECT_EQ(s.particles, 228 * 24);
  EXPECT_TRUE(s.finite);
}
