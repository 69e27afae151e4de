// wet_curly_hair_run: the offline runner. Runs a scene (the built-in one when given none) for a
// set simulated time under a scripted head motion and writes a JSON summary. Options and JSON
// keys: docs/runner.md.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/runner/offline_run.h"

namespace {

const char* kUsage =
    "usage: wet_curly_hair_run [--scene FILE.yaml] [--seconds T] [--motion NAME[:key=value,...]]\n"
    "                          [--json OUT.json] [--hair-frames DIR] [--hair-stride N]\n"
    "                          [--strands N] [--particles N] [--length M] [--curl-radius M]\n"
    "                          [--curl-pitch M] [--seed S] [--follow-ratio K]\n"
    "                          [--set NAME=VALUE]... [--print-scene]\n"
    "                          [--saturation ROOT,TIP] [--cohesion ours|lin|kim|off]\n"
    "                          [--obstacle sphere:x=..,y=..,z=..,r=..]... (also box:, plane:)\n"
    "                          [--obstacle-map FILE.bt|FILE.ot] [--obstacle-map-offset x,y,z]\n"
    "                          [--sdf-resolution M] [--integrator NAME] [--substep S]\n"
    "                          [--threads N] [--no-stage-timing] [--no-measure]\n"
    "                          [--tangle-series N] [--no-tangles] [--no-clump-distance]\n"
    "                          [--sample-strands N] [--hair-contact on|off]\n"
    "                          [--crossings] [--no-crossings]\n"
    "                          [--saturation-at T,ROOT,TIP]... [--series-stride N] [--rtf-window "
    "S]\n"
    "                          [--water-source shower:x=..,y=..,z=..,r=..,rate_kg_s=..,start_s=..,"
    "stop_s=..]...\n"
    "                          [--water-source bath:z=..,start_s=..,stop_s=..]...\n"
    "                          [--dryer box:x=..,y=..,z=..,hx=..,hy=..,hz=..,rate_per_s=..,"
    "start_s=..,stop_s=..]...\n"
    "integrators: explicit, backward_euler, midpoint, theta (--set solver.integrator.theta=T)\n"
    "motions: still, spin:rate_hz=R, nod:freq_hz=F,amplitude_rad=A, "
    "shake:freq_hz=F,amplitude_rad=A,\n"
    "         teleport:distance_m=D, linear:speed_m_s=V (all also take start_s, stop_s, "
    "axis_x/y/z)\n";

bool parseNumber(const std::string& flag, const std::string& text, double* v, std::string* why) {
  char* end = nullptr;
  *v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0') {
    *why = flag + ": '" + text + "' is not a number";
    return false;
  }
  return true;
}

/// What the command line asks for, before it is applied to the scene.
struct CommandLine {
  wet_curly_hair::io::SceneConfig scene = wet_curly_hair::io::builtinScene();
  wet_curly_hair::io::RunOptions options;
  std::string json_path, motion_spec;
  /// Every override is a dotted scene key and its YAML value text, applied on top of the scene.
  std::vector<std::pair<std::string, std::string>> overrides;
  std::vector<wet_curly_hair::AnalyticObstacle> extra_obstacles;
  wet_curly_hair::WaterSources extra_water;  ///< --water-source and --dryer, added to the scene's
  bool print_scene = false;
  bool help = false;
  bool seconds_given = false;
  double seconds = 0.0;
};

/// The arguments one after the other; value() takes the one after the current flag.
class Arguments {
 public:
  Arguments(int argc, char** argv) : argc_(argc), argv_(argv) {}
  bool more() const { return i_ < argc_; }
  const std::string& flag() const { return flag_; }
  void advance() { flag_ = argv_[i_++]; }
  bool value(std::string* v, std::string* why) {
    if (i_ >= argc_) {
      *why = flag_ + ": needs a value";
      return false;
    }
    *v = argv_[i_++];
    return true;
  }
  bool number(double* x, std::string* why) {
    std::string v;
    return value(&v, why) && parseNumber(flag_, v, x, why);
  }

 private:
  int argc_;
  char** argv_;
  int i_ = 1;
  std::string flag_;
};

/// The scene file (--scene) first, so that overrides apply on top of it whatever their order.
bool loadSceneArgument(int argc, char** argv, CommandLine* cl, std::string* why) {
  std::string scene_path;
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--scene" && i + 1 < argc) scene_path = argv[i + 1];
  if (scene_path.empty()) return true;
  wet_curly_hair::io::SceneConfig loaded;  // defaults, not the built-in scene, under a scene file
  if (!wet_curly_hair::io::loadSceneFile(scene_path, &loaded, why)) return false;
  cl->scene = loaded;
  return true;
}

enum class Parsed { kOk, kBad, kUnknown };

Parsed result(bool ok) { return ok ? Parsed::kOk : Parsed::kBad; }

/// --saturation-at T,ROOT,TIP: a root-to-tip ramp set on every particle before the first frame
/// starting at or after T.
bool parseSaturationEvent(const std::string& v, wet_curly_hair::io::RunOptions* options,
                          std::string* why) {
  const size_t c1 = v.find(',');
  const size_t c2 = c1 == std::string::npos ? c1 : v.find(',', c1 + 1);
  if (c2 == std::string::npos) {
    *why = "--saturation-at: '" + v + "' is not T,ROOT,TIP";
    return false;
  }
  wet_curly_hair::io::RunOptions::SaturationEvent e;
  if (!parseNumber("--saturation-at T", v.substr(0, c1), &e.time_s, why) ||
      !parseNumber("--saturation-at ROOT", v.substr(c1 + 1, c2 - c1 - 1), &e.root, why) ||
      !parseNumber("--saturation-at TIP", v.substr(c2 + 1), &e.tip, why))
    return false;
  options->saturation_events.push_back(e);
  return true;
}

/// The options of the run itself and its outputs (not scene keys).
Parsed parseRunFlag(Arguments* args, CommandLine* cl, std::string* why) {
  const std::string& a = args->flag();
  wet_curly_hair::io::RunOptions& options = cl->options;
  std::string v;
  double x = 0.0;
  if (a == "--scene") return result(args->value(&v, why));
  if (a == "--seconds") {
    cl->seconds_given = true;
    return result(args->number(&cl->seconds, why));
  }
  if (a == "--motion") return result(args->value(&cl->motion_spec, why));
  if (a == "--json") return result(args->value(&cl->json_path, why));
  if (a == "--hair-frames") return result(args->value(&options.hair_frames_dir, why));
  if (a == "--hair-stride") {
    const bool ok = args->number(&x, why);
    options.hair_stride = static_cast<int>(x);
    return result(ok);
  }
  if (a == "--saturation-at")
    return result(args->value(&v, why) && parseSaturationEvent(v, &options, why));
  if (a == "--series-stride") {
    const bool ok = args->number(&x, why);
    options.series_stride = static_cast<int>(x);
    return result(ok);
  }
  if (a == "--rtf-window") {
    const bool ok = args->number(&x, why);
    options.rtf_window_s = x;
    return result(ok);
  }
  if (a == "--no-stage-timing") {
    options.stage_timing = false;
    return Parsed::kOk;
  }
  if (a == "--sample-strands") {
    const bool ok = args->number(&x, why);
    options.sample_strands = static_cast<int>(x);
    if (ok && (x < 0 || x != std::floor(x) || x > 2e9)) {
      *why = "--sample-strands: must be a whole number, 0 or more";
      return Parsed::kBad;
    }
    return result(ok);
  }
  if (a == "--tangle-series") {
    const bool ok = args->number(&x, why);
    options.tangle_series = true;
    options.tangle_series_stride = static_cast<int>(x);
    if (ok && (x < 1 || x != std::floor(x) || x > 2e9)) {
      *why = "--tangle-series: must be a whole number of frames, at least 1";
      return Parsed::kBad;
    }
    return result(ok);
  }
  for (const auto& [flag, field] : {std::pair<const char*, bool*>{"--no-measure", &options.measure},
                                    {"--no-clump-distance", &options.clump_distance},
                                    {"--no-tangles", &options.tangles},
                                    {"--no-crossings", &options.crossings}}) {
    if (a != flag) continue;
    *field = false;
    return Parsed::kOk;
  }
  if (a == "--crossings") {
    options.crossings_always = true;
    return Parsed::kOk;
  }
  if (a == "--print-scene") {
    cl->print_scene = true;
    return Parsed::kOk;
  }
  return Parsed::kUnknown;
}

/// The flags that are shorthands for scene keys: each becomes an override.
Parsed parseSceneFlag(Arguments* args, CommandLine* cl, std::string* why) {
  static const std::vector<std::pair<std::string, std::string>> kNumberKeys = {
      {"--strands", "groom.strands"},
      {"--particles", "groom.particles"},
      {"--length", "groom.length_m"},
      {"--curl-radius", "groom.curl_radius_m"},
      {"--curl-pitch", "groom.curl_pitch_m"},
      {"--seed", "groom.seed"},
      {"--follow-ratio", "groom.follow_ratio"},
      {"--sdf-resolution", "obstacle_map.resolution_m"},
      {"--substep", "solver.integrator.substep_s"},
      {"--threads", "solver.integrator.threads"}};
  static const std::vector<std::pair<std::string, std::string>> kTextKeys = {
      {"--cohesion", "solver.cohesion.mode"}, {"--integrator", "solver.integrator.method"}};
  const std::string& a = args->flag();
  std::string v;
  double x = 0.0;
  for (const auto& [flag, key] : kNumberKeys) {
    if (a != flag) continue;
    if (!args->value(&v, why) || !parseNumber(a, v, &x, why)) return Parsed::kBad;
    cl->overrides.emplace_back(key, v);
    return Parsed::kOk;
  }
  for (const auto& [flag, key] : kTextKeys) {
    if (a != flag) continue;
    const bool ok = args->value(&v, why);
    cl->overrides.emplace_back(key, v);
    return result(ok);
  }
  if (a == "--hair-contact") {
    if (!args->value(&v, why)) return Parsed::kBad;
    if (v != "on" && v != "off") {
      *why = "--hair-contact: '" + v + "' is not on or off";
      return Parsed::kBad;
    }
    cl->overrides.emplace_back("solver.hair_contact.enabled", v == "on" ? "true" : "false");
    return Parsed::kOk;
  }
  if (a == "--set") {
    if (!args->value(&v, why)) return Parsed::kBad;
    const size_t eq = v.find('=');
    if (eq == std::string::npos) {
      *why = "--set: '" + v + "' is not NAME=VALUE";
      return Parsed::kBad;
    }
    cl->overrides.emplace_back(v.substr(0, eq), v.substr(eq + 1));
    return Parsed::kOk;
  }
  if (a == "--saturation") {
    if (!args->value(&v, why)) return Parsed::kBad;
    const size_t comma = v.find(',');
    if (comma == std::string::npos) {
      *why = "--saturation: '" + v + "' is not ROOT,TIP";
      return Parsed::kBad;
    }
    double root = 0.0, tip = 0.0;
    const bool ok = parseNumber("--saturation ROOT", v.substr(0, comma), &root, why) &&
                    parseNumber("--saturation TIP", v.substr(comma + 1), &tip, why);
    cl->overrides.emplace_back("saturation.root", v.substr(0, comma));
    cl->overrides.emplace_back("saturation.tip", v.substr(comma + 1));
    return result(ok);
  }
  if (a == "--obstacle") {
    wet_curly_hair::AnalyticObstacle o;
    if (!args->value(&v, why) || !wet_curly_hair::AnalyticObstacle::parse(v, &o, why))
      return Parsed::kBad;
    cl->extra_obstacles.push_back(o);
    return Parsed::kOk;
  }
  if (a == "--water-source") {
    wet_curly_hair::WaterSource w;
    if (!args->value(&v, why)) return Parsed::kBad;
    if (!wet_curly_hair::WaterSource::parse(v, &w, why)) {
      *why = "--water-source: " + *why;
      return Parsed::kBad;
    }
    cl->extra_water.sources.push_back(w);
    return Parsed::kOk;
  }
  if (a == "--dryer") {
    wet_curly_hair::WaterDryer d;
    if (!args->value(&v, why)) return Parsed::kBad;
    if (!wet_curly_hair::WaterDryer::parse(v, &d, why)) {
      *why = "--dryer: " + *why;
      return Parsed::kBad;
    }
    cl->extra_water.dryers.push_back(d);
    return Parsed::kOk;
  }
  if (a == "--obstacle-map") {
    const bool ok = args->value(&v, why);
    cl->overrides.emplace_back("obstacle_map.file", "\"" + v + "\"");
    return result(ok);
  }
  if (a == "--obstacle-map-offset") {
    const bool ok = args->value(&v, why);
    cl->overrides.emplace_back("obstacle_map.offset_m", "[" + v + "]");
    return result(ok);
  }
  return Parsed::kUnknown;
}

/// Reads every flag; stops at --help (cl->help).
bool parseCommandLine(int argc, char** argv, CommandLine* cl, std::string* why) {
  if (!loadSceneArgument(argc, argv, cl, why)) return false;
  Arguments args(argc, argv);
  while (args.more()) {
    args.advance();
    if (args.flag() == "--help" || args.flag() == "-h") {
      cl->help = true;
      return true;
    }
    Parsed parsed = parseRunFlag(&args, cl, why);
    if (parsed == Parsed::kUnknown) parsed = parseSceneFlag(&args, cl, why);
    if (parsed == Parsed::kUnknown) {
      *why = "unknown option '" + args.flag() + "'\n" + kUsage;
      return false;
    }
    if (parsed == Parsed::kBad) return false;
  }
  return true;
}

/// The overrides, the motion and the extra obstacles, on top of the scene.
bool applyToScene(CommandLine* cl, std::string* why) {
  if (cl->seconds_given) cl->overrides.emplace_back("run.seconds", std::to_string(cl->seconds));
  for (const auto& [name, value] : cl->overrides)
    if (!wet_curly_hair::io::parseSceneYaml(wet_curly_hair::io::dottedToYaml(name, value),
                                            &cl->scene, why))
      return false;
  if (!cl->motion_spec.empty() &&
      !wet_curly_hair::parseMotionSpec(cl->motion_spec, &cl->scene.motion, why))
    return false;
  cl->scene.obstacles.insert(cl->scene.obstacles.end(), cl->extra_obstacles.begin(),
                             cl->extra_obstacles.end());
  for (const wet_curly_hair::WaterSource& w : cl->extra_water.sources)
    cl->scene.water_sources.sources.push_back(w);
  for (const wet_curly_hair::WaterDryer& d : cl->extra_water.dryers)
    cl->scene.water_sources.dryers.push_back(d);
  return true;
}

int fail(const std::string& why) {
  std::fprintf(stderr, "wet_curly_hair_run: %s\n", why.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace wet_curly_hair;
  CommandLine cl;
  std::string why;
  if (!parseCommandLine(argc, argv, &cl, &why)) return fail(why);
  if (cl.help) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (!applyToScene(&cl, &why)) return fail(why);
  if (cl.print_scene) {
    std::fputs(io::sceneToYaml(cl.scene).c_str(), stdout);
    return 0;
  }
  io::RunSummary summary;
  if (!io::runScene(cl.scene, cl.options, &summary, &why)) return fail(why);
  const std::string json = summary.toJson();
  if (!cl.json_path.empty()) {
    std::ofstream out(cl.json_path);
    out << json << "\n";
    if (!out) return fail("cannot write " + cl.json_path);
  }
  std::cout << json << std::endl;
  return io::runExitCode(summary);
}
