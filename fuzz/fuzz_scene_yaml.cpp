// libFuzzer target: io::parseSceneYaml on arbitrary text, starting from the built-in scene.
// Invariants checked (each violation traps):
//  - no exception escapes parseSceneYaml (an escaping one aborts the fuzzer);
//  - a refused input sets a non-empty message and leaves the scene unchanged;
//  - an accepted scene passes SceneConfig::validate, and its parameter table can be read;
//  - sceneToYaml(accepted) parses back (into a default SceneConfig) to a scene whose
//    sceneToYaml text is the same: what --print-scene writes can be loaded again.
#include <cstddef>
#include <cstdint>
#include <string>

#include "wet_curly_hair/io/scene.h"

using namespace wet_curly_hair;
using namespace wet_curly_hair::io;

namespace {

void check(bool ok) {
  if (!ok) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const SceneConfig kBase = builtinScene();
  static const std::string kBaseYaml = sceneToYaml(kBase);
  const std::string text(reinterpret_cast<const char*>(data), size);

  SceneConfig scene = kBase;
  std::string why;
  if (!parseSceneYaml(text, &scene, &why)) {
    check(!why.empty());
    check(sceneToYaml(scene) == kBaseYaml);
    return 0;
  }
  std::string inner;
  check(scene.validate(&inner));
  for (const ParamRef& p : parameterTable(&scene)) {
    check(!p.name.empty());
    (void)p.valueString();
  }
  const std::string yaml = sceneToYaml(scene);
  SceneConfig back;  // defaults: the text must say everything that differs from them
  std::string back_why;
  check(parseSceneYaml(yaml, &back, &back_why));
  check(sceneToYaml(back) == yaml);
  return 0;
}
