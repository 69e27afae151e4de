// wet_curly_hair_run: the offline runner. Runs a scene (the built-in one when given none) for a
// set simulated time under a scripted head motion and writes a JSON summary. See README.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>

#include "wet_curly_hair/runner/offline_run.h"
#include "wet_curly_hair/io/scene.h"

namespace {

const char* kUsage =
    "usage: wet_curly_hair_run [--scene FILE.yaml] [--seconds T] [--motion NAME[:key=value,...]]\n"
    "                          [--json OUT.json] [--hair-frames DIR] [--hair-stride N]\n"
    "                          [--strands N] [--particles N] [--length M] [--curl-radius M]\n"
    "                          [--curl-pitch M] [--seed S] [--set NAME=VALUE]... [--print-scene]\n"
    "                          [--saturation ROOT,TIP] [--cohesion ours|lin|kim|off]\n"
    "                          [--obstacle sphere:x=..,y=..,z=..,r=..]... (also box:, plane:)\n"
    "                          [--obstacle-map FILE.bt|FILE.ot] [--obstacle-map-offset x,y,z]\n"
    "                          [--sdf-resolution M] [--integrator NAME] [--substep S]\n"
    "                          [--threads N] [--no-stage-timing]\n"
    "                          [--saturation-at T,ROOT,TIP]... [--series-stride N] [--rtf-window S]\n"
    "integrators: explicit, backward_euler, midpoint, theta (--set solver.integrator.theta=T)\n"
    "motions: still, spin:rate_hz=R, nod:freq_hz=F,amplitude_rad=A, shake:freq_hz=F,amplitude_rad=A,\n"
    "         teleport:distance_m=D, linear:speed_m_s=V (all also take start_s, stop_s, axis_x/y/z)\n";

bool parseNumber(const std::string& flag, const std::string& text, double* v, std::string* why) {
  char* end = nullptr;
  *v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0') {
    *why = flag + ": '" + text + "' is not a number";
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace wet_curly_hair;
  io::SceneConfig scene = io::builtinScene();
  io::RunOptions options;
  std::string json_path, why, motion_spec;
  // Every override is a dotted scene key and its YAML value text, applied on top of the scene.
  std::vector<std::pair<std::string, std::string>> overrides;
  bool print_scene = false;
  std::vector<AnalyticObstacle> extra_obstacles;
  bool seconds_given = false;
  double seconds = 0.0;
  std::string scene_path;
  // First pass: the scene file, so that overrides apply on top of it whatever their order.
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--scene" && i + 1 < argc) scene_path = argv[i + 1];
  if (!scene_path.empty()) {
    io::SceneConfig loaded;  // defaults, not the built-in scene, under a scene file
    if (!io::loadSceneFile(scene_path, &loaded, &why)) {
      std::fprintf(stderr, "wet_curly_hair_run: %s\n", why.c_str());
      return 2;
    }
    scene = loaded;
  }
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&](std::string* v) {
      if (i + 1 >= argc) {
        why = a + ": needs a value";
        return false;
      }
      *v = argv[++i];
      return true;
    };
    std::string v;
    double x = 0.0;
    auto groomOverride = [&](const char* name) {
      if (!next(&v) || !parseNumber(a, v, &x, &why)) return false;
      overrides.emplace_back(name, v);
      return true;
    };
    bool ok = true;
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (a == "--scene") {
      ok = next(&v);
    } else if (a == "--seconds") {
      ok = next(&v) && parseNumber(a, v, &seconds, &why);
      seconds_given = true;
    } else if (a == "--motion") {
      ok = next(&motion_spec);
    } else if (a == "--json") {
      ok = next(&json_path);
    } else if (a == "--hair-frames") {
      ok = next(&options.hair_frames_dir);
    } else if (a == "--hair-stride") {
      ok = next(&v) && parseNumber(a, v, &x, &why);
      options.hair_stride = static_cast<int>(x);
    } else if (a == "--strands") {
      ok = groomOverride("groom.strands");
    } else if (a == "--particles") {
      ok = groomOverride("groom.particles");
    } else if (a == "--length") {
      ok = groomOverride("groom.length_m");
    } else if (a == "--curl-radius") {
      ok = groomOverride("groom.curl_radius_m");
    } else if (a == "--curl-pitch") {
      ok = groomOverride("groom.curl_pitch_m");
    } else if (a == "--seed") {
      ok = groomOverride("groom.seed");
    } else if (a == "--set") {
      ok = next(&v);
      const size_t eq = v.find('=');
      if (ok && eq == std::string::npos) {
        why = "--set: '" + v + "' is not NAME=VALUE";
        ok = false;
      } else if (ok) {
        overrides.emplace_back(v.substr(0, eq), v.substr(eq + 1));
      }
    } else if (a == "--saturation") {
      ok = next(&v);
      const size_t comma = v.find(',');
      double root = 0.0, tip = 0.0;
      if (ok && comma == std::string::npos) {
        why = "--saturation: '" + v + "' is not ROOT,TIP";
        ok = false;
      } else if (ok) {
        ok = parseNumber("--saturation ROOT", v.substr(0, comma), &root, &why) &&
             parseNumber("--saturation TIP", v.substr(comma + 1), &tip, &why);
        overrides.emplace_back("saturation.root", v.substr(0, comma));
        overrides.emplace_back("saturation.tip", v.substr(comma + 1));
      }
    } else if (a == "--cohesion") {
      ok = next(&v);
      overrides.emplace_back("solver.cohesion.mode", v);
    } else if (a == "--obstacle") {
      ok = next(&v);
      AnalyticObstacle o;
      if (ok) ok = AnalyticObstacle::parse(v, &o, &why);
      if (ok) extra_obstacles.push_back(o);
    } else if (a == "--obstacle-map") {
      ok = next(&v);
      overrides.emplace_back("obstacle_map.file", "\"" + v + "\"");
    } else if (a == "--obstacle-map-offset") {
      ok = next(&v);
      overrides.emplace_back("obstacle_map.offset_m", "[" + v + "]");
    } else if (a == "--sdf-resolution") {
      ok = next(&v) && parseNumber(a, v, &x, &why);
      overrides.emplace_back("obstacle_map.resolution_m", v);
    } else if (a == "--integrator") {
      ok = next(&v);
      overrides.emplace_back("solver.integrator.method", v);
    } else if (a == "--substep") {
      ok = next(&v) && parseNumber(a, v, &x, &why);
      overrides.emplace_back("solver.integrator.substep_s", v);
    } else if (a == "--threads") {
      ok = next(&v) && parseNumber(a, v, &x, &why);
      overrides.emplace_back("solver.integrator.threads", v);
    } else if (a == "--saturation-at") {
      // A root-to-tip ramp set on every particle before the first frame starting at or after T.
      ok = next(&v);
      const size_t c1 = ok ? v.find(',') : std::string::npos;
      const size_t c2 = c1 == std::string::npos ? c1 : v.find(',', c1 + 1);
      io::RunOptions::SaturationEvent e;
      if (ok && c2 == std::string::npos) {
        why = "--saturation-at: '" + v + "' is not T,ROOT,TIP";
        ok = false;
      } else if (ok) {
        ok = parseNumber("--saturation-at T", v.substr(0, c1), &e.time_s, &why) &&
             parseNumber("--saturation-at ROOT", v.substr(c1 + 1, c2 - c1 - 1), &e.root, &why) &&
             parseNumber("--saturation-at TIP", v.substr(c2 + 1), &e.tip, &why);
        if (ok) options.saturation_events.push_back(e);
      }
    } else if (a == "--series-stride") {
      ok = next(&v) && parseNumber(a, v, &x, &why);
      options.series_stride = static_cast<int>(x);
    } else if (a == "--rtf-window") {
      ok = next(&v) && parseNumber(a, v, &x, &why);
      options.rtf_window_s = x;
    } else if (a == "--no-stage-timing") {
      options.stage_timing = false;
    } else if (a == "--print-scene") {
      print_scene = true;
    } else {
      why = "unknown option '" + a + "'\n" + kUsage;
      ok = false;
    }
    if (!ok) {
      std::fprintf(stderr, "wet_curly_hair_run: %s\n", why.c_str());
      return 2;
    }
  }
  if (seconds_given) overrides.emplace_back("run.seconds", std::to_string(seconds));
  for (const auto& [name, value] : overrides) {
    if (!io::parseSceneYaml(io::dottedToYaml(name, value), &scene, &why)) {
      std::fprintf(stderr, "wet_curly_hair_run: %s\n", why.c_str());
      return 2;
    }
  }
  if (!motion_spec.empty() && !parseMotionSpec(motion_spec, &scene.motion, &why)) {
    std::fprintf(stderr, "wet_curly_hair_run: %s\n", why.c_str());
    return 2;
  }
  scene.obstacles.insert(scene.obstacles.end(), extra_obstacles.begin(), extra_obstacles.end());
  if (print_scene) {
    std::fputs(io::sceneToYaml(scene).c_str(), stdout);
    return 0;
  }
  io::RunSummary summary;
  if (!io::runScene(scene, options, &summary, &why)) {
    std::fprintf(stderr, "wet_curly_hair_run: %s\n", why.c_str());
    return 2;
  }
  const std::string json = summary.toJson();
  if (!json_path.empty()) {
    std::ofstream out(json_path);
    out << json << "\n";
    if (!out) {
      std::fprintf(stderr, "wet_curly_hair_run: cannot write %s\n", json_path.c_str());
      return 2;
    }
  }
  std::cout << json << std::endl;
  return summary.finite ? 0 : 1;
}
