// Replays every input of fuzz/corpus/<target>/ and fuzz/regressions/<target>/ through the parser
// call of that fuzz target (fuzz/fuzz_*.cpp), in the normal build: each input must be accepted
// (and then be consistent) or refused with a non-empty message, leaving the object that was
// already loaded unchanged. Plus the bugs the fuzz targets found, one test each.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "wet_curly_hair/io/hair_file.h"
#include "wet_curly_hair/io/octomap_sdf.h"
#include "wet_curly_hair/io/scene.h"

namespace wet_curly_hair {
namespace io {
namespace {

namespace fs = std::filesystem;

std::string readBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Every regular file (not dot files, not README*) of fuzz/corpus/<target> and
/// fuzz/regressions/<target>, sorted.
std::vector<fs::path> inputsOf(const std::string& target, size_t* corpus_count) {
  std::vector<fs::path> out;
  *corpus_count = 0;
  for (const char* kind : {"corpus", "regressions"}) {
    const fs::path dir = fs::path(WCH_SOURCE_DIR) / "fuzz" / kind / target;
    if (!fs::is_directory(dir)) continue;
    std::vector<fs::path> here;
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string name = e.path().filename().string();
      if (!e.is_regular_file() || name[0] == '.' || name.rfind("README", 0) == 0) continue;
      here.push_back(e.path());
    }
    std::sort(here.begin(), here.end());
    if (std::string(kind) == "corpus") *corpus_count = here.size();
    out.insert(out.end(), here.begin(), here.end());
  }
  return out;
}

// ------------------------------------------------------------------------------------ .hair

HairFileData hairSentinel() {
  HairFileData d;
  d.strand_offsets = {0, 2};
  d.points = {1.f, 2.f, 3.f, 4.f, 5.f, 6.f};
  d.info = "already loaded";
  return d;
}

bool sameHair(const HairFileData& a, const HairFileData& b) {
  return a.strand_offsets == b.strand_offsets && a.points == b.points &&
         a.thickness == b.thickness && a.transparency == b.transparency && a.colors == b.colors &&
         a.info == b.info && a.write_segments_array == b.write_segments_array &&
         a.default_segments == b.default_segments;
}

TEST(ParserRegressions, HairInputs) {
  size_t seeds = 0;
  const std::vector<fs::path> inputs = inputsOf("fuzz_hair_file", &seeds);
  EXPECT_GE(seeds, 1u) << "fuzz/corpus/fuzz_hair_file is empty";
  int accepted = 0;
  for (const fs::path& p : inputs) {
    SCOPED_TRACE(p.string());
    const std::string bytes = readBytes(p);
    HairFileData out = hairSentinel();
    std::string why;
    if (parseHair(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), &out, &why)) {
      ++accepted;
      std::string inner;
      EXPECT_TRUE(validateHairData(out, &inner)) << inner;
      std::vector<uint8_t> again;
      EXPECT_TRUE(serializeHair(out, &again, &inner)) << inner;
    } else {
      EXPECT_FALSE(why.empty());
      EXPECT_TRUE(sameHair(out, hairSentinel()));
    }
  }
  EXPECT_GE(accepted, 1);
}

// ------------------------------------------------------------------------------- scene YAML

/// What the scene fuzz target checks: refused -> message and scene unchanged; accepted ->
/// validates and sceneToYaml reads back to the same text.
void checkSceneInput(const std::string& text, bool* accepted) {
  const SceneConfig base = builtinScene();
  const std::string base_yaml = sceneToYaml(base);
  SceneConfig scene = base;
  std::string why;
  *accepted = parseSceneYaml(text, &scene, &why);
  if (!*accepted) {
    EXPECT_FALSE(why.empty());
    EXPECT_EQ(sceneToYaml(scene), base_yaml);
    return;
  }
  std::string inner;
  EXPECT_TRUE(scene.validate(&inner)) << inner;
  const std::string yaml = sceneToYaml(scene);
  SceneConfig back;
  ASSERT_TRUE(parseSceneYaml(yaml, &back, &inner)) << inner << "\n" << yaml;
  EXPECT_EQ(sceneToYaml(back), yaml);
}

TEST(ParserRegressions, SceneInputs) {
  size_t seeds = 0;
  const std::vector<fs::path> inputs = inputsOf("fuzz_scene_yaml", &seeds);
  EXPECT_GE(seeds, 1u) << "fuzz/corpus/fuzz_scene_yaml is empty";
  int accepted = 0;
  for (const fs::path& p : inputs) {
    SCOPED_TRACE(p.string());
    bool ok = false;
    checkSceneInput(readBytes(p), &ok);
    accepted += ok;
  }
  EXPECT_GE(accepted, 1);
}

// Found by fuzz_scene_yaml: a capsule key that is not a scalar threw YAML::TypedBadConversion
// out of parseSceneYaml (the runner and the node died on such a scene file).
TEST(ParserRegressions, SceneCapsuleKeyThatIsNotAStringIsRefused) {
  SceneConfig scene = builtinScene();
  std::string why;
  EXPECT_FALSE(parseSceneYaml("head: {capsules: [{[1]: 2}]}\n", &scene, &why));
  EXPECT_NE(why.find("head.capsules[0]"), std::string::npos) << why;
  EXPECT_EQ(sceneToYaml(scene), sceneToYaml(builtinScene()));
}

// Found by fuzz_scene_yaml: sceneToYaml wrote strings between quotes without escaping, so a path
// holding '"' or '\' (or a control character) gave YAML that does not load again.
TEST(ParserRegressions, SceneStringsWithQuotesRoundTrip) {
  SceneConfig scene = builtinScene();
  scene.groom_file.file = "dir \"a\"\\b\tc.hair";
  scene.head.capsules[0].name = "ne\"ck\\";
  scene.obstacle_map.file = "x\x01y.bt";
  std::string why;
  ASSERT_TRUE(scene.validate(&why)) << why;
  SceneConfig back;
  ASSERT_TRUE(parseSceneYaml(sceneToYaml(scene), &back, &why)) << why;
  EXPECT_EQ(back.groom_file.file, scene.groom_file.file);
  EXPECT_EQ(back.obstacle_map.file, scene.obstacle_map.file);
  ASSERT_EQ(back.head.capsules.size(), 1u);
  EXPECT_EQ(back.head.capsules[0].name, scene.head.capsules[0].name);
}

// ---------------------------------------------------------------------------------- OctoMap

/// The call of fuzz_octomap: '#' starts a file, anything else is a message payload whose first
/// byte picks binary, the id and the resolution. Refused -> message, tree unchanged.
void checkOctomapInput(const std::string& bytes, bool* accepted) {
  *accepted = false;
  if (bytes.empty()) return;
  std::unique_ptr<octomap::OcTree> tree = std::make_unique<octomap::OcTree>(0.5);
  const octomap::OcTree* before = tree.get();
  std::string why;
  if (bytes[0] == '#') {
    *accepted = octreeFromFileContents(bytes, &tree, &why);
  } else {
    static const char* const kIds[4] = {"OcTree", "ColorOcTree", "1", "OcTreeStamped"};
    static const double kRes[8] = {0.05, 0.1, 0.01, 1.0, 1e-6, 0.0, -0.1, NAN};
    const uint8_t b = static_cast<uint8_t>(bytes[0]);
    const std::vector<int8_t> payload(bytes.begin() + 1, bytes.end());
    *accepted = octreeFromMessagePayload((b & 1) != 0, kIds[(b >> 1) & 3], kRes[(b >> 3) & 7],
                                         payload, &tree, &why);
  }
  if (!*accepted) {
    EXPECT_FALSE(why.empty());
    EXPECT_EQ(tree.get(), before);
    EXPECT_EQ(tree->getResolution(), 0.5);
    return;
  }
  ASSERT_TRUE(tree);
  EXPECT_GT(tree->size(), 0u);
  EXPECT_EQ(tree->calcNumNodes(), tree->size());
  std::ostringstream bt;
  ASSERT_TRUE(tree->writeBinaryConst(bt));
  std::unique_ptr<octomap::OcTree> again;
  EXPECT_TRUE(octreeFromFileContents(bt.str(), &again, &why)) << why;
  if (again) {
    EXPECT_EQ(again->size(), tree->size());
  }
}

TEST(ParserRegressions, OctomapInputs) {
  size_t seeds = 0;
  const std::vector<fs::path> inputs = inputsOf("fuzz_octomap", &seeds);
  EXPECT_GE(seeds, 1u) << "fuzz/corpus/fuzz_octomap is empty";
  int accepted = 0;
  for (const fs::path& p : inputs) {
    SCOPED_TRACE(p.string());
    bool ok = false;
    checkOctomapInput(readBytes(p), &ok);
    accepted += ok;
  }
  EXPECT_GE(accepted, 1);
}

// Found by fuzz_octomap: a header size above 2^63 - 1 turned negative on its way to the node
// count check, which then was skipped: the file was accepted whatever its size line said.
TEST(ParserRegressions, OctomapHugeHeaderSizeIsCompared) {
  const fs::path seed = fs::path(WCH_SOURCE_DIR) / "fuzz/corpus/fuzz_octomap/s.bt";
  std::string bytes = readBytes(seed);
  const size_t at = bytes.find("\nsize ");
  ASSERT_NE(at, std::string::npos);
  const size_t end = bytes.find('\n', at + 1);
  bytes.replace(at + 1, end - at - 1, "size 9999999999999999999");
  std::unique_ptr<octomap::OcTree> tree;
  std::string why;
  EXPECT_FALSE(octreeFromFileContents(bytes, &tree, &why));
  EXPECT_NE(why.find("the header says size 9999999999999999999"), std::string::npos) << why;
  EXPECT_FALSE(tree);
}

}  // namespace
}  // namespace io
}  // namespace wet_curly_hair
