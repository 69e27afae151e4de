// wet_curly_hair_bench: speed against error (docs/performance.md).
//
// First the built-in scene exactly as shipped (the defaults, every hardware thread): its
// real-time factor (builtin.csv). Then, for each benchmark scene, runs every solver setting
// (integrator x substep) and a reference (the explicit integrator at a substep 16 times smaller
// than the smallest benchmarked, checked against one 32 times smaller), and writes per setting:
// wall seconds per simulated second (median of
// --repeats runs, solver step only), RMS and max particle error against the reference over the
// output frames divided by the mean strand length, whether the run stayed stable, and how far the
// distributions of tip height, tip curl radius and clump distance, pooled over every output frame
// after the first, lie from the reference's (Wasserstein-1 in m and per the reference's spread,
// Kolmogorov-Smirnov; core/shape_stats.h): measures that still mean something where strands part
// on a knife edge and the pointwise error does not. Then the scaling runs: cost per
// particle-substep against strand count, 1 and 2 threads. CSV files and, with gnuplot, PNG charts
// go to --out. Every run goes through io::runScene, the offline runner's library, so
// `wet_curly_hair_run --integrator NAME --substep S --threads N` reproduces a point.
//
//   wet_curly_hair_bench --out docs/bench            # the long form (tens of minutes)
//   wet_curly_hair_bench --quick --out /tmp/bench    # a smoke run (seconds): no timing claims
//   wet_curly_hair_bench --replot --out docs/bench   # redraw the charts from the CSV files
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "bench_common.h"
#include "wet_curly_hair/core/cohesion_grid.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/shape_stats.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/io/scene_setup.h"
#include "wet_curly_hair/runner/offline_run.h"

namespace {

using wet_curly_hair::HairState;
using wet_curly_hair::Vec3;
namespace io = wet_curly_hair::io;

struct BenchScene {
  std::string name;
  std::string description;
  std::vector<std::pair<std::string, std::string>> overrides;  ///< dotted key, YAML value
  std::string motion;                                          ///< runner motion spec
};

struct Setting {
  std::string integrator;
  double substep_s;
  /// Implicit methods: strands in SIMD lanes (solver.integrator.strand_lanes); false: one strand
  /// at a time, the reference path (labelled "<integrator>_per_strand" in the scaling CSV).
  bool lanes = true;
  /// solver.integrator.lane_layout; empty: the scene's (the default).
  std::string layout{};
  std::string label() const { return lanes ? integrator : integrator + "_per_strand"; }
};

struct Options {
  std::string out = "bench_out";
  bool quick = false;
  int repeats = 5;
  int strands = 50;
  double seconds = 1.0;
  int threads = 1;
  bool scaling = true;
  bool work_precision = true;
  bool gating = true;
  bool cohesion = true;
  bool target = true;   ///< the headline target scene: 1,000 strands, full wet model, obstacle
  bool lanes = true;    ///< float or double: the target scene's dynamics in every lane layout
  bool builtin = true;  ///< the built-in scene exactly as shipped: its real-time factor
  std::vector<std::string> only_scenes;
  std::vector<std::string> only_series;  ///< scaling: only these Setting::label()s
  bool replot = false;  ///< only redraw the charts from the CSV files already in `out`
};

/// The benchmark scenes: the built-in groom (soft curls) under different loads.
std::vector<BenchScene> benchScenes() {
  return {
      {"drape",
       "dry curls settling under gravity on a still head",
       {{"saturation.root", "0"}, {"saturation.tip", "0"}},
       "still"},
      {"spin",
       "dry, head spinning at 1 rev/s about its vertical axis",
       {{"saturation.root", "0"}, {"saturation.tip", "0"}},
       "spin:rate_hz=1"},
      {"nod_shake",
       "dry, head shaking 0.35 rad at 2 Hz",
       {{"saturation.root", "0"}, {"saturation.tip", "0"}},
       "shake:freq_hz=2,amplitude_rad=0.35"},
      {"wet_clump",
       "fully wet (curl, stiffness, cohesion), nodding 0.35 rad at 1 Hz",
       {{"saturation.root", "1"}, {"saturation.tip", "1"}},
       "nod:freq_hz=1,amplitude_rad=0.35"},
      {"obstacle_slide",
       "half wet, head moving sideways at 0.3 m/s past a 5 cm sphere behind it",
       {{"saturation.root", "0.5"},
        {"saturation.tip", "0.5"},
        {"obstacles", "[\"sphere:x=-0.18,y=0.15,z=-0.05,r=0.05\"]"}},
       "linear:speed_m_s=0.3,axis_x=0,axis_y=1,axis_z=0"},
  };
}

std::vector<Setting> benchSettings(bool quick) {
  if (quick) return {{"explicit", 2e-4}, {"backward_euler", 1.0 / 240}, {"theta", 1.0 / 240}};
  std::vector<Setting> s;
  for (double h : {1e-4, 2e-4}) s.push_back({"explicit", h});
  // Up to one substep per output frame (1/60 s): a longer substep would be cut to the frame.
  for (const char* m : {"backward_euler", "theta", "midpoint"})
    for (double h : {5e-4, 1e-3, 2e-3, 1.0 / 240, 1.0 / 120, 1.0 / 60}) s.push_back({m, h});
  return s;
}

bool applyOverride(const std::string& key, const std::string& value, io::SceneConfig* scene,
                   std::string* why) {
  return io::parseSceneYaml(io::dottedToYaml(key, value), scene, why);
}

bool makeScene(const BenchScene& b, int strands, double seconds, io::SceneConfig* scene,
               std::string* why) {
  *scene = io::builtinScene();
  for (const auto& [k, v] : b.overrides)
    if (!applyOverride(k, v, scene, why)) return false;
  if (!applyOverride("groom.strands", std::to_string(strands), scene, why) ||
      !applyOverride("run.seconds", std::to_string(seconds), scene, why))
    return false;
  scene->motion = wet_curly_hair::HeadMotionConfig();
  return wet_curly_hair::parseMotionSpec(b.motion, &scene->motion, why);
}

struct RunResult {
  io::RunSummary summary;
  std::vector<wet_curly_hair::Vec3List> frames;      ///< output positions per frame (when kept)
  std::vector<wet_curly_hair::Vec3List> sim_frames;  ///< simulated positions (when kept)
  /// Shape samples (tip height, tip curl radius, clump distance) pooled over every output frame
  /// after the first, of the output and of the simulated positions (when kept).
  wet_curly_hair::ShapeSamples shape, sim_shape;
};

/// Appends to *to what was appended to `from` since it held `sizes` (the three sizes).
void copyTail(const wet_curly_hair::ShapeSamples& from, const size_t sizes[3],
              wet_curly_hair::ShapeSamples* to) {
  auto tail = [](const std::vector<double>& a, size_t n, std::vector<double>* b) {
    b->insert(b->end(), a.begin() + n, a.end());
  };
  tail(from.tip_height_m, sizes[0], &to->tip_height_m);
  tail(from.curl_radius_m, sizes[1], &to->curl_radius_m);
  tail(from.clump_distance_m, sizes[2], &to->clump_distance_m);
}

bool runOnce(io::SceneConfig scene, const Setting& setting, int threads, bool keep_frames,
             RunResult* result, std::string* why, bool stage_timing = false) {
  scene.solver.integrator.method = setting.integrator;
  scene.solver.integrator.substep_s = setting.substep_s;
  scene.solver.integrator.threads = threads;
  scene.solver.integrator.strand_lanes = setting.lanes;
  if (!setting.layout.empty()) scene.solver.integrator.lane_layout = setting.layout;
  if (!scene.solver.validate("solver.", why)) return false;
  io::RunOptions options;
  options.measure = false;
  // The tangle counts are never read here; the cohesion section compares exact clump distances.
  options.tangles = false;
  options.sample_strands = 0;
  options.stage_timing = stage_timing;  // clock reads cost: off for the cost figures
  result->frames.clear();
  result->sim_frames.clear();
  result->shape = result->sim_shape = {};
  wet_curly_hair::HairModel model;
  wet_curly_hair::MetricScratch scratch;
  if (keep_frames && !io::buildSceneModel(scene, &model, why)) return false;
  if (keep_frames)
    options.on_frame = [&](int f, const HairState& state) {
      const wet_curly_hair::Vec3List& shown = wet_curly_hair::displayPositions(state);
      result->frames.push_back(shown);
      result->sim_frames.push_back(state.position);
      if (f == 0) return;  // the initial state: the same in every run
      const wet_curly_hair::Pose pose =
          wet_curly_hair::headPose(scene.motion, f * scene.run.frame_s);
      auto sample = [&](const wet_curly_hair::Vec3List& x, wet_curly_hair::ShapeSamples* out) {
        wet_curly_hair::appendShapeSamples(model, x, state.saturation, pose,
                                           scene.run.clump_search_m, &scratch, out, threads);
      };
      const wet_curly_hair::ShapeSamples& s = result->shape;
      const size_t sizes[3] = {s.tip_height_m.size(), s.curl_radius_m.size(),
                               s.clump_distance_m.size()};
      sample(shown, &result->shape);
      // Without the cohesion display pass the output positions are the simulated ones.
      if (&shown == &state.position || shown == state.position)
        copyTail(result->shape, sizes, &result->sim_shape);
      else
        sample(state.position, &result->sim_shape);
    };
  return io::runScene(scene, options, &result->summary, why);
}

/// CSV columns of the shape distances (compareShapes), appended after the pointwise ones.
const char* kShapeHeader =
    ",tip_height_w1_m,tip_height_w1_per_spread,tip_height_ks,curl_radius_w1_m,"
    "curl_radius_w1_per_spread,curl_radius_ks,clump_distance_w1_m,clump_distance_w1_per_spread,"
    "clump_distance_ks";

std::string fmt(double v) {
  char b[64];
  std::snprintf(b, sizeof(b), "%.6g", v);
  return b;
}

std::string shapeColumns(const wet_curly_hair::ShapeDistance& d) {
  std::string out;
  for (const wet_curly_hair::SampleDistance* s : {&d.tip_height, &d.curl_radius, &d.clump_distance})
    out += "," + fmt(s->w1) + "," + fmt(s->w1 / s->spread_b) + "," + fmt(s->ks);
  return out;
}

/// One line: each shape distance in mm, per the reference's spread, and the KS statistic.
void printShape(const char* prefix, const wet_curly_hair::ShapeDistance& d) {
  const char* names[] = {"tip height", "curl radius", "clump distance"};
  const wet_curly_hair::SampleDistance* s[] = {&d.tip_height, &d.curl_radius, &d.clump_distance};
  std::printf("%s shape W1 (mm, /spread, KS):", prefix);
  for (int k = 0; k < 3; ++k)
    std::printf("%s %s %.3f, %.3f, %.3f", k ? ";" : "", names[k], 1e3 * s[k]->w1,
                s[k]->w1 / s[k]->spread_b, s[k]->ks);
  std::printf("\n");
}

struct Error {
  double rms = 0.0;
  double max = 0.0;
};

Error frameError(const std::vector<wet_curly_hair::Vec3List>& a,
                 const std::vector<wet_curly_hair::Vec3List>& b, double length_m,
                 size_t horizon = SIZE_MAX) {
  Error e;
  double sum = 0.0;
  size_t count = 0;
  const size_t frames = std::min({a.size(), b.size(), horizon});
  for (size_t f = 1; f < frames; ++f) {
    for (size_t i = 0; i < a[f].size() && i < b[f].size(); ++i) {
      const double d = (a[f][i] - b[f][i]).norm();
      sum += d * d;
      e.max = std::max(e.max, std::isfinite(d) ? d : INFINITY);
      ++count;
    }
  }
  e.rms = count ? std::sqrt(sum / count) / length_m : 0.0;
  e.max /= length_m;
  return e;
}

/// Output frames (from the start) over which two runs stay within `tolerance` RMS of each other
/// per frame, relative to the strand length: the horizon over which a reference has converged.
size_t convergedHorizon(const std::vector<wet_curly_hair::Vec3List>& a,
                        const std::vector<wet_curly_hair::Vec3List>& b, double length_m,
                        double tolerance) {
  const size_t frames = std::min(a.size(), b.size());
  for (size_t f = 1; f < frames; ++f) {
    const Error e = frameError({a[f - 1], a[f]}, {b[f - 1], b[f]}, length_m);
    if (!(e.rms <= tolerance)) return f;
  }
  return frames;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0.0 : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

/// Stable: every value finite, no strand repaired, and the largest strain before limiting within
/// twice the strain limit (the explicit stretch spring's blow-up shows there first).
bool stable(const io::RunSummary& s, double strain_limit) {
  return s.finite && s.repairs == 0 && s.max_strain_before_limit <= 2.0 * strain_limit;
}

bool writeFile(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  return static_cast<bool>(out);
}

bool haveGnuplot() { return std::system("command -v gnuplot > /dev/null 2>&1") == 0; }

/// Writes a gnuplot script and runs it (the charts go where the script says).
void runGnuplot(const std::string& script, const std::string& text) {
  writeFile(script, text);
  if (std::system(("gnuplot " + script).c_str()) != 0)
    std::fprintf(stderr, "wet_curly_hair_bench: gnuplot failed on %s\n", script.c_str());
}

/// Work-precision chart: one line per integrator (all scenes' points, one panel per scene).
void plotWorkPrecision(const std::string& dir, const std::vector<std::string>& scenes) {
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1500,900 font 'sans,10'\n"
     << "set output '" << dir << "/work_precision.png'\n"
     << "set termoption noenhanced\n"
     << "set datafile separator ','\n"
     << "set logscale xy\nset grid\nset key bottom left font 'sans,8'\n"
     << "set multiplot layout 2,3 title 'Speed against error (RMS particle error / strand length "
        "vs wall s per simulated s; hollow: unstable)'\n";
  for (const std::string& s : scenes) {
    gp << "set title '" << s << "'\nset xlabel 'wall s per simulated s'\n"
       << "set ylabel 'RMS error / strand length'\n"
       << "set arrow from graph 0, first 0.01 to graph 1, first 0.01 nohead dt 2 lc 'gray'\n"
       << "plot ";
    const char* methods[] = {"explicit", "backward_euler", "theta", "midpoint"};
    const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd"};
    for (int m = 0; m < 4; ++m) {
      gp << (m ? ", " : "") << "'" << dir << "/work_precision.csv' using "
         << "(strcol(1) eq '" << s << "' && strcol(2) eq '" << methods[m]
         << "' && $9 == 1 ? $4 : NaN):5 with linespoints pt 7 lc rgb '" << colours[m] << "' title '"
         << methods[m] << "', '" << dir << "/work_precision.csv' using "
         << "(strcol(1) eq '" << s << "' && strcol(2) eq '" << methods[m]
         << "' && $9 == 0 ? $4 : NaN):5 with points pt 6 lc rgb '" << colours[m] << "' notitle";
    }
    gp << "\nunset arrow\n";
  }
  gp << "unset multiplot\n";
  runGnuplot(dir + "/work_precision.gp", gp.str());
}

void plotScaling(const std::string& dir) {
  // One data block per (integrator, threads) series, in strand order: the CSV interleaves the
  // series, and gnuplot breaks a line at every row a filter drops (points only, no lines).
  const char* combos[][2] = {
      {"explicit", "1"}, {"explicit", "2"}, {"backward_euler", "1"},   {"backward_euler", "2"},
      {"theta", "1"},    {"theta", "2"},    {"theta_per_strand", "1"}, {"theta_per_strand", "2"}};
  std::map<std::string, std::vector<std::pair<int, std::string>>> series;
  {
    std::ifstream in(dir + "/scaling.csv");
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      std::vector<std::string> f;
      std::stringstream ss(line);
      for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
      if (f.size() < 7) continue;
      series[f[0] + "," + f[2]].push_back({std::atoi(f[1].c_str()), f[6]});
    }
  }
  std::ostringstream data, gp;
  gp << "set terminal pngcairo size 1100,600 font 'sans,10'\n"
     << "set output '" << dir << "/scaling.png'\n"
     << "set termoption noenhanced\n"
     << "set logscale x\nset grid\nset key outside right top\n"
     << "set yrange [0:*]\n"
     << "set title 'Cost per particle-substep against strand count (32 particles per strand)'\n"
     << "set xlabel 'strands'\nset ylabel 'ns per particle-substep (wall)'\n"
     << "plot ";
  int block = 0;
  for (const auto& c : combos) {
    auto it = series.find(std::string(c[0]) + "," + c[1]);
    if (it == series.end()) continue;
    std::sort(it->second.begin(), it->second.end());
    for (const auto& [strands, ns] : it->second) data << strands << " " << ns << "\n";
    data << "\n\n";
    gp << (block ? ", " : "") << "'" << dir << "/scaling_series.dat' index " << block
       << " using 1:2 with linespoints title '" << c[0] << ", " << c[1] << " thread"
       << (c[1][0] == '1' ? "" : "s") << "'";
    ++block;
  }
  gp << "\n";
  if (block == 0) return;
  writeFile(dir + "/scaling_series.dat", data.str());
  runGnuplot(dir + "/scaling.gp", gp.str());
}

/// Float or double: cost against error of the target scene's dynamics, one line per lane layout
/// over the theta substeps, the explicit points apart.
void plotLanes(const std::string& dir) {
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1000,620 font 'sans,10'\n"
     << "set output '" << dir << "/lanes.png'\n"
     << "set termoption noenhanced\n"
     << "set datafile separator ','\n"
     << "set logscale xy\nset grid\nset key top right\n"
     << "set title 'Strand lanes: float or double (1,000 strands x 32, wet, obstacle, 2 threads; "
        "dynamics alone)'\n"
     << "set xlabel 'wall s per simulated s'\nset ylabel 'RMS error / strand length'\n"
     << "set arrow from graph 0, first 0.01 to graph 1, first 0.01 nohead dt 2 lc 'gray'\n"
     << "plot ";
  const char* layouts[] = {"double4", "double8", "float8", "float16"};
  const char* colours[] = {"#1f77b4", "#17becf", "#d62728", "#ff7f0e"};
  for (int k = 0; k < 4; ++k) {
    gp << (k ? ", " : "") << "'" << dir
       << "/lanes.csv' using (strcol(1) eq 'theta' && strcol(3) eq '" << layouts[k]
       << "' ? $6 : NaN):9 with linespoints pt 7 lc rgb '" << colours[k] << "' title '"
       << layouts[k] << " theta', '" << dir
       << "/lanes.csv' using (strcol(1) eq 'explicit' && strcol(3) eq '" << layouts[k]
       << "' ? $6 : NaN):9 with points pt 5 ps 1.5 lc rgb '" << colours[k] << "' title '"
       << layouts[k] << " explicit'";
  }
  gp << "\n";
  runGnuplot(dir + "/lanes.gp", gp.str());
}

const char* kUsage =
    "usage: wet_curly_hair_bench [--out DIR] [--quick] [--repeats N] [--strands N] [--seconds T]\n"
    "                            [--threads N] [--scene NAME]... [--no-scaling]\n"
    "                            [--scaling-series "
    "explicit|backward_euler|theta|theta_per_strand]...\n"
    "                            [--no-work-precision] [--no-gating]\n"
    "                            [--no-cohesion] [--no-target] [--no-lanes] [--no-builtin]\n"
    "                            [--replot]\n";

/// The speed-against-error chart: every benchmark scene x setting against a converged reference.
/// Returns 2 when a run fails, 0 otherwise; *all_ok turns false when a file cannot be written.
int benchWorkPrecision(const Options& opt, bool* all_ok) {
  std::string why;
  std::vector<std::string> scene_names;

  const std::vector<Setting> settings = benchSettings(opt.quick);
  double smallest = settings.front().substep_s;
  for (const Setting& s : settings) smallest = std::min(smallest, s.substep_s);
  const Setting reference{"explicit", smallest / 16.0};
  const Setting check{"explicit", smallest / 32.0};
  std::ostringstream csv;
  csv << "scene,integrator,substep_s,wall_s_per_sim_s,rms_error,max_error,"
         "max_strain_before_limit,repairs,stable,realtime_factor,runs"
      << kShapeHeader << "\n";
  std::ostringstream refcsv;
  refcsv << "scene,reference_substep_s,check_substep_s,rms_difference,max_difference,"
            "reference_wall_s"
         << kShapeHeader << "\n";
  for (const BenchScene& b : benchScenes()) {
    if (!opt.only_scenes.empty() &&
        std::find(opt.only_scenes.begin(), opt.only_scenes.end(), b.name) == opt.only_scenes.end())
      continue;
    scene_names.push_back(b.name);
    io::SceneConfig scene;
    if (!makeScene(b, opt.strands, opt.seconds, &scene, &why)) {
      std::fprintf(stderr, "wet_curly_hair_bench: scene %s: %s\n", b.name.c_str(), why.c_str());
      return 2;
    }
    const double length = scene.groom.length_m;
    RunResult ref, chk;
    if (!runOnce(scene, reference, opt.threads, true, &ref, &why) ||
        !runOnce(scene, check, opt.threads, true, &chk, &why)) {
      std::fprintf(stderr, "wet_curly_hair_bench: reference of %s: %s\n", b.name.c_str(),
                   why.c_str());
      return 2;
    }
    const Error converged = frameError(ref.frames, chk.frames, length);
    const wet_curly_hair::ShapeDistance ref_shape = compareShapes(chk.shape, ref.shape);
    refcsv << b.name << "," << fmt(reference.substep_s) << "," << fmt(check.substep_s) << ","
           << fmt(converged.rms) << "," << fmt(converged.max) << "," << fmt(ref.summary.wall_s)
           << shapeColumns(ref_shape) << "\n";
    std::printf("%-15s reference %.3g s vs %.3g s: RMS %.2e, max %.2e of strand length\n",
                b.name.c_str(), reference.substep_s, check.substep_s, converged.rms, converged.max);
    printShape((b.name + " reference").c_str(), ref_shape);
    for (const Setting& setting : settings) {
      std::vector<double> walls;
      RunResult run;
      Error err;
      wet_curly_hair::ShapeDistance shape;
      for (int r = 0; r < opt.repeats; ++r) {
        if (!runOnce(scene, setting, opt.threads, r == 0, &run, &why)) {
          std::fprintf(stderr, "wet_curly_hair_bench: %s %s: %s\n", b.name.c_str(),
                       setting.integrator.c_str(), why.c_str());
          return 2;
        }
        if (r == 0) err = frameError(run.frames, ref.frames, length);
        if (r == 0) shape = compareShapes(run.shape, ref.shape);
        walls.push_back(run.summary.wall_s / run.summary.sim_s);
      }
      const double cost = median(walls);
      const bool ok = stable(run.summary, scene.solver.stretch.strain_limit);
      csv << b.name << "," << setting.integrator << "," << fmt(setting.substep_s) << ","
          << fmt(cost) << "," << fmt(err.rms) << "," << fmt(err.max) << ","
          << fmt(run.summary.max_strain_before_limit) << "," << run.summary.repairs << ","
          << (ok ? 1 : 0) << "," << fmt(cost > 0 ? 1.0 / cost : 0.0) << "," << opt.repeats
          << shapeColumns(shape) << "\n";
      std::printf("%-15s %-15s %-9.3g cost %8.4f s/s  RMS %.2e  max %.2e  %s\n", b.name.c_str(),
                  setting.integrator.c_str(), setting.substep_s, cost, err.rms, err.max,
                  ok ? "stable" : "UNSTABLE");
      printShape("               ", shape);
      std::fflush(stdout);
    }
  }
  *all_ok = writeFile(opt.out + "/work_precision.csv", csv.str()) &&
            writeFile(opt.out + "/reference.csv", refcsv.str()) && *all_ok;
  if (haveGnuplot()) plotWorkPrecision(opt.out, scene_names);
  return 0;
}

/// Scaling with the strand count and threads (the full wet model, cohesion display pass off).
/// Returns 2 when a run fails, 0 otherwise; *all_ok turns false when a file cannot be written.
int benchScaling(const Options& opt, bool* all_ok) {
  std::string why;

  // Cost per particle-substep of the full wet model with an obstacle in reach, against the
  // strand count, 1 and 2 threads. Fewer simulated frames for the big counts: the figure is
  // per particle-substep.
  std::vector<int> counts =
      opt.quick ? std::vector<int>{10, 40} : std::vector<int>{100, 300, 1000, 3000, 10000};
  const std::vector<Setting> settings = opt.quick
                                            ? std::vector<Setting>{{"explicit", 2e-4},
                                                                   {"theta", 1.0 / 240},
                                                                   {"theta", 1.0 / 240, false}}
                                            : std::vector<Setting>{{"explicit", 2e-4},
                                                                   {"backward_euler", 1.0 / 240},
                                                                   {"theta", 1.0 / 240},
                                                                   {"theta", 1.0 / 240, false}};
  std::ostringstream csv;
  csv << "integrator,strands,threads,substep_s,particles,wall_s_per_sim_s,"
         "ns_per_particle_substep,realtime_factor,runs,rounds,relative_to_1000\n";
  // obstacle_slide (wet: curl, eq. 13, adhesion, obstacle collision) without the per-frame
  // cohesion display pass: its cost grows with the neighbours within h, i.e. with the strand
  // density, not with the strand count as such; it is measured on its own (docs/performance.md).
  BenchScene target = benchScenes()[4];
  target.overrides.push_back({"solver.cohesion.mode", "off"});
  // A series' points are measured in rounds: every round runs each point of the series once
  // (the order reversed every other round), so that a slow spell of this shared machine falls
  // on all strand counts alike instead of on the one being measured. A point's cost is the
  // median over the rounds; its cost relative to the 1,000-strand point of the same thread
  // count is the median of the ratios within each round (paired), the figure the flatness is
  // judged by.
  const int rounds = opt.quick ? 1 : std::max(5, opt.repeats);
  const int reference_count = opt.quick ? counts.back() : 1000;
  struct Point {
    int count = 0;
    int threads = 1;
    io::SceneConfig scene;
    std::vector<double> costs;  ///< wall s per simulated s, one per round
    int runs = 0;
    RunResult run;
  };
  for (const Setting& setting : settings) {
    if (!opt.only_series.empty() && std::find(opt.only_series.begin(), opt.only_series.end(),
                                              setting.label()) == opt.only_series.end())
      continue;
    std::vector<Point> points;
    for (int count : counts) {
      for (int threads : {1, 2}) {
        const double work = double(count) * 32.0 / setting.substep_s;  // particle-substeps/s
        const double seconds =
            opt.quick ? 0.1 : std::clamp(std::round(30.0 * 3e7 / work) / 30.0, 1.0 / 30, 1.0);
        Point p;
        p.count = count;
        p.threads = threads;
        if (!makeScene(target, count, seconds, &p.scene, &why)) {
          std::fprintf(stderr, "wet_curly_hair_bench: %s\n", why.c_str());
          return 2;
        }
        points.push_back(std::move(p));
      }
    }
    for (int r = 0; r < rounds; ++r) {
      for (size_t k = 0; k < points.size(); ++k) {
        Point& p = points[r % 2 ? points.size() - 1 - k : k];
        // Short points (a 100-strand run is 20-50 ms of wall time) take several runs per
        // round, until 0.25 s of wall time or 8 runs; the round's cost is their total wall
        // time over their total simulated time.
        double wall = 0.0, sim = 0.0;
        for (int n = 0; n < (opt.quick ? 1 : 8) && (n == 0 || wall < 0.25); ++n) {
          if (!runOnce(p.scene, setting, p.threads, false, &p.run, &why)) {
            std::fprintf(stderr, "wet_curly_hair_bench: scaling: %s\n", why.c_str());
            return 2;
          }
          wall += p.run.summary.wall_s;
          sim += p.run.summary.sim_s;
          ++p.runs;
        }
        p.costs.push_back(wall / sim);
      }
    }
    for (const Point& p : points) {
      const Point* ref = nullptr;
      for (const Point& q : points)
        if (q.count == reference_count && q.threads == p.threads) ref = &q;
      std::vector<double> ratios;
      // Per particle-substep (the substep is the series'; the particle counts differ).
      const double per_particle = double(ref ? ref->run.summary.particles : 1) /
                                  std::max<double>(1, p.run.summary.particles);
      for (int r = 0; ref && r < rounds; ++r)
        ratios.push_back(per_particle * p.costs[r] / ref->costs[r]);
      const double cost = median(p.costs);
      const double substeps = 1.0 / p.run.summary.substep_s;
      const double ns = 1e9 * cost / (p.run.summary.particles * substeps);
      csv << setting.label() << "," << p.count << "," << p.threads << ","
          << fmt(p.run.summary.substep_s) << "," << p.run.summary.particles << "," << fmt(cost)
          << "," << fmt(ns) << "," << fmt(1.0 / cost) << "," << p.runs << "," << rounds << ","
          << fmt(median(ratios)) << "\n";
      std::printf(
          "scaling %-16s %6d strands %d thread(s): %7.1f ns/particle-substep, "
          "real-time factor %.3f, %.3f x the %d-strand cost\n",
          setting.label().c_str(), p.count, p.threads, ns, 1.0 / cost, median(ratios),
          reference_count);
    }
    std::fflush(stdout);
  }
  *all_ok = writeFile(opt.out + "/scaling.csv", csv.str()) && *all_ok;
  if (haveGnuplot()) plotScaling(opt.out);
  return 0;
}

/// A cohesion candidate of benchCohesion.
struct CohesionCandidate {
  const char* evaluation;
  int cells;             ///< lattice nodes per kernel radius (grid only)
  const char* wet_sums;  ///< solver.cohesion.grid_wet_sums (grid only)
};

/// benchCohesion's scene: fully wet, still, `count` strands, the candidate's evaluation.
bool cohesionScene(const Options& opt, const CohesionCandidate& ev, int count,
                   io::SceneConfig* scene, std::string* why) {
  BenchScene b{"cohesion",
               "fully wet, still",
               {{"saturation.root", "1"},
                {"saturation.tip", "1"},
                {"solver.cohesion.evaluation", "\"" + std::string(ev.evaluation) + "\""},
                {"solver.cohesion.grid_cells_per_radius", std::to_string(ev.cells)},
                {"solver.cohesion.grid_wet_sums", "\"" + std::string(ev.wet_sums) + "\""}},
               "still"};
  return makeScene(b, count, opt.quick ? 0.1 : 0.2, scene, why);
}

/// The lattice an evaluation runs on the scene's model, as "grid<nodes per radius> <where the
/// sums ran>" (grid_wet_sums "auto" resolved), or "exact".
bool cohesionLatticeName(const io::SceneConfig& scene, std::string* name, std::string* why) {
  if (scene.solver.cohesion.evaluation != "grid") {
    *name = scene.solver.cohesion.evaluation;
    return true;
  }
  wet_curly_hair::HairModel model;
  if (!io::buildSceneModel(scene, &model, why)) return false;
  const wet_curly_hair::CohesionLattice lattice =
      wet_curly_hair::cohesionLattice(model, scene.solver.cohesion);
  *name = "grid" + std::to_string(lattice.cells_per_radius) +
          (lattice.node_sums ? " nodes" : " particles");
  return true;
}

/// The cohesion display pass on its own: exact and the lattice evaluations.
/// Returns 2 when a run fails, 0 otherwise; *all_ok turns false when a file cannot be written.
int benchCohesion(const Options& opt, bool* all_ok) {
  std::string why;

  // The cohesion display pass on its own (it runs once per output frame, and its exact cost
  // grows with the neighbours within h): CPU per wet particle-frame, exact and the lattice at
  // 4, 3 and 2 nodes per radius (the candidates of the lattice density). p^w never feeds back,
  // so every evaluation sees the same dynamics: its output positions are compared with exact's
  // frame by frame (RMS over the frames and particles, in m, relative to exact's RMS
  // displacement |p^w - p| and to the strand length). The lattice's sums of eq. (10) gathered per
  // particle, or convolved at the nodes (solver.cohesion.grid_wet_sums) at 4 and 3; "auto" runs
  // one of those to the bit (test_cohesion), so its row is the row of the lattice it resolves
  // to at that strand count (the `lattice` column), not a measurement of its own.
  std::ostringstream csv;
  csv << "strands,evaluation,cells_per_radius,wet_sums,lattice,us_per_wet_particle_frame,"
         "clump_distance_m,pw_rms_vs_exact_m,pw_rms_vs_exact_rel,pw_rms_vs_exact_length,runs\n";
  typedef CohesionCandidate Evaluation;
  const std::vector<Evaluation> evaluations =
      opt.quick ? std::vector<Evaluation>{{"exact", 4, "particles"},
                                          {"grid", 3, "particles"},
                                          {"grid", 4, "nodes"},
                                          {"grid", 3, "auto"}}
                : std::vector<Evaluation>{{"exact", 4, "particles"}, {"grid", 4, "particles"},
                                          {"grid", 3, "particles"},  {"grid", 2, "particles"},
                                          {"grid", 4, "nodes"},      {"grid", 3, "nodes"},
                                          {"grid", 3, "auto"}};
  const std::vector<int> counts =
      opt.quick ? std::vector<int>{6} : std::vector<int>{100, 300, 1000, 2000, 5000};
  for (int count : counts) {
    RunResult exact_frames;
    double displacement_rms = 0.0;
    std::map<std::string, std::string> measured;  // lattice name -> the row's measured fields
    for (const Evaluation& ev : evaluations) {
      const std::string evaluation = ev.evaluation;
      io::SceneConfig scene;
      std::string lattice;
      if (!cohesionScene(opt, ev, count, &scene, &why) ||
          !cohesionLatticeName(scene, &lattice, &why)) {
        std::fprintf(stderr, "wet_curly_hair_bench: cohesion: %s\n", why.c_str());
        return 2;
      }
      const std::string key =
          evaluation + "," + std::to_string(ev.cells) + "," + ev.wet_sums + "," + lattice + ",";
      if (std::string(ev.wet_sums) == "auto") {
        if (!measured.count(lattice)) {
          std::fprintf(stderr, "wet_curly_hair_bench: cohesion: auto ran %s, not a candidate\n",
                       lattice.c_str());
          return 2;
        }
        csv << count << "," << key << measured[lattice];
        std::printf("cohesion %6d strands grid   3 auto      runs %s\n", count, lattice.c_str());
        continue;
      }
      std::vector<double> us;
      RunResult run;
      const int repeats = opt.quick ? 1 : 3;
      for (int r = 0; r < repeats; ++r) {
        if (!runOnce(scene, {"theta", 1.0 / 30}, opt.threads, false, &run, &why, true)) {
          std::fprintf(stderr, "wet_curly_hair_bench: cohesion: %s\n", why.c_str());
          return 2;
        }
        const double particles = double(run.summary.particles) * run.summary.steps;
        us.push_back(1e6 * run.summary.stage_cpu_s[wet_curly_hair::kStageCohesion] / particles);
      }
      // Untimed: the frames, to compare the output positions with exact's.
      RunResult frames;
      if (!runOnce(scene, {"theta", 1.0 / 30}, opt.threads, true, &frames, &why)) {
        std::fprintf(stderr, "wet_curly_hair_bench: cohesion: %s\n", why.c_str());
        return 2;
      }
      if (evaluation == "exact") {
        exact_frames = frames;
        displacement_rms = frameError(frames.frames, frames.sim_frames, 1.0).rms;
      }
      const double error = frameError(frames.frames, exact_frames.frames, 1.0).rms;
      const double relative = displacement_rms > 0.0 ? error / displacement_rms : 0.0;
      const double length = scene.groom.length_m;
      std::ostringstream row;
      row << fmt(median(us)) << "," << fmt(run.summary.clump_distance_m) << "," << fmt(error) << ","
          << fmt(relative) << "," << fmt(error / length) << "," << repeats << "\n";
      measured[lattice] = row.str();
      csv << count << "," << key << row.str();
      std::printf(
          "cohesion %6d strands %-6s %d %-9s %8.2f us per wet particle-frame, clump %.3f mm, "
          "p^w vs exact RMS %.4f mm (%.2f %% of the displacement, %.3f %% of the length)\n",
          count, evaluation.c_str(), ev.cells, ev.wet_sums, median(us),
          1e3 * run.summary.clump_distance_m, 1e3 * error, 100.0 * relative,
          100.0 * error / length);
      std::fflush(stdout);
    }
  }
  *all_ok = writeFile(opt.out + "/cohesion.csv", csv.str()) && *all_ok;
  return 0;
}

/// Float or double (part 4): the target scene's dynamics in every lane layout against the target's
/// reference (errors over its converged horizon). The layouts run in turn within each repeat;
/// every cost ratio is the median over the repeats of the ratio within one repeat. Returns 2
/// when a run fails, 0 otherwise.
int benchLanes(const Options& opt, const io::SceneConfig& scene, const RunResult& ref,
               size_t horizon, int strands, int threads, bool* all_ok) {
  std::string why;
  const double length = scene.groom.length_m;

  const std::vector<std::string> layouts = {"double4", "double8", "float8", "float16"};
  const std::vector<Setting> lane_settings =
      opt.quick ? std::vector<Setting>{{"theta", 2e-3}}
                : std::vector<Setting>{
                      {"theta", 1e-3}, {"theta", 2e-3}, {"theta", 1.0 / 240}, {"explicit", 2e-4}};
  std::ostringstream lanes;
  lanes << "integrator,substep_s,lane_layout,strands,threads,wall_s_per_sim_s,"
           "realtime_factor,cost_vs_double4,rms_error,max_error,stable,runs\n";
  for (const Setting& base : lane_settings) {
    std::map<std::string, std::vector<double>> walls;
    std::map<std::string, Error> errors;
    std::map<std::string, bool> stable_run;
    for (int r = 0; r < opt.repeats; ++r) {
      for (const std::string& layout : layouts) {
        Setting setting = base;
        setting.layout = layout;
        RunResult run;
        if (!runOnce(scene, setting, threads, r == 0, &run, &why)) {
          std::fprintf(stderr, "wet_curly_hair_bench: lanes: %s\n", why.c_str());
          return 2;
        }
        if (r == 0) {
          errors[layout] = frameError(run.sim_frames, ref.sim_frames, length, horizon);
          stable_run[layout] = stable(run.summary, scene.solver.stretch.strain_limit);
        }
        walls[layout].push_back(run.summary.wall_s / run.summary.sim_s);
      }
    }
    for (const std::string& layout : layouts) {
      std::vector<double> q;
      for (int r = 0; r < opt.repeats; ++r) q.push_back(walls[layout][r] / walls["double4"][r]);
      const double cost = median(walls[layout]);
      const Error& e = errors[layout];
      lanes << base.integrator << "," << fmt(base.substep_s) << "," << layout << "," << strands
            << "," << threads << "," << fmt(cost) << "," << fmt(1.0 / cost) << "," << fmt(median(q))
            << "," << fmt(e.rms) << "," << fmt(e.max) << "," << (stable_run[layout] ? 1 : 0) << ","
            << opt.repeats << "\n";
      std::printf(
          "lanes %-9s %-9.3g %-8s cost %7.4f s/s (RTF %.2f, %.3f of double4)  RMS %.3e  "
          "max %.3e  %s\n",
          base.integrator.c_str(), base.substep_s, layout.c_str(), cost, 1.0 / cost, median(q),
          e.rms, e.max, stable_run[layout] ? "stable" : "UNSTABLE");
      std::fflush(stdout);
    }
  }
  *all_ok = writeFile(opt.out + "/lanes.csv", lanes.str()) && *all_ok;
  if (haveGnuplot()) plotLanes(opt.out);
  return 0;
}

/// What one target row is measured against: the reference run and its converged horizon.
struct TargetReference {
  const RunResult& ref;
  double length;   ///< strand length, m
  size_t horizon;  ///< output frames over which the reference has converged
  double horizon_s;
  int strands, threads;
};

/// One row of target.csv: cost (median of the repeats), error over the horizon and the whole
/// run, shape distances. Dynamics rows compare simulated positions, full-model rows
/// (`output`) the output positions.
bool measureTargetRow(const Options& opt, const TargetReference& target, const io::SceneConfig& sc,
                      const Setting& setting, const char* cohesion, bool output,
                      std::ostringstream* csv, std::string* why) {
  std::vector<double> walls;
  RunResult run;
  Error err, err_whole;
  wet_curly_hair::ShapeDistance shape;
  for (int r = 0; r < opt.repeats; ++r) {
    if (!runOnce(sc, setting, target.threads, r == 0, &run, why)) return false;
    if (r == 0) {
      const auto& mine = output ? run.frames : run.sim_frames;
      const auto& theirs = output ? target.ref.frames : target.ref.sim_frames;
      err = frameError(mine, theirs, target.length, target.horizon);
      err_whole = frameError(mine, theirs, target.length);
      shape = output ? compareShapes(run.shape, target.ref.shape)
                     : compareShapes(run.sim_shape, target.ref.sim_shape);
    }
    walls.push_back(run.summary.wall_s / run.summary.sim_s);
  }
  const double cost = median(walls);
  const bool ok = stable(run.summary, sc.solver.stretch.strain_limit);
  *csv << setting.integrator << "," << fmt(setting.substep_s) << "," << (setting.lanes ? 1 : 0)
       << "," << cohesion << "," << target.strands << "," << target.threads << "," << fmt(cost)
       << "," << fmt(1.0 / cost) << "," << fmt(err.rms) << "," << fmt(err.max) << ","
       << (ok ? 1 : 0) << "," << opt.repeats << "," << fmt(err_whole.rms) << ","
       << fmt(err_whole.max) << "," << fmt(target.horizon_s) << shapeColumns(shape) << "\n";
  std::printf(
      "target %-15s %-9.3g lanes %d cohesion %-12s cost %7.4f s/s (RTF %.2f)  RMS "
      "%.2e  max %.2e (whole run %.2e, %.2e)  %s\n",
      setting.integrator.c_str(), setting.substep_s, setting.lanes ? 1 : 0, cohesion, cost,
      1.0 / cost, err.rms, err.max, err_whole.rms, err_whole.max, ok ? "stable" : "UNSTABLE");
  printShape("target         ", shape);
  std::fflush(stdout);
  return true;
  return true;
}

/// The 1,000-strand target scene and the lane layouts, against one reference.
/// Returns 2 when a run fails, 0 otherwise; *all_ok turns false when a file cannot be written.
int benchTargetAndLanes(const Options& opt, bool* all_ok) {
  std::string why;

  // The headline target: 1,000 strands x 32 particles, the full wet model (curl, eq. 13,
  // adhesion, the per-frame cohesion display pass of eq. 10) and an obstacle (obstacle_slide),
  // 2 threads, measured on that scene itself against a reference at a substep 16 times smaller
  // than the smallest candidate (the midpoint method, whose error vanishes with the step like
  // every other's, with the exact cohesion evaluation), checked against 32 times smaller.
  // First the dynamics alone (cohesion off; errors of the simulated positions), then the full
  // model at the fastest candidates: errors of the output positions p^w, which carry the
  // dynamics' error and the cohesion evaluation's (exact, or the lattice at 4, 3, 2 nodes per
  // radius in float, and at 4 in double).
  const int strands = opt.quick ? 16 : 1000;  // 16: one block of every lane layout
  const int threads = 2;
  const double seconds = opt.quick ? 0.1 : 1.0;
  const std::vector<Setting> candidates =
      opt.quick ? std::vector<Setting>{{"theta", 2e-3}, {"theta", 2e-3, false}}
                : std::vector<Setting>{
                      {"theta", 1e-3},         {"theta", 2e-3},          {"midpoint", 1e-3},
                      {"midpoint", 2e-3},      {"backward_euler", 1e-3}, {"theta", 1.0 / 360},
                      {"midpoint", 1.0 / 360}, {"midpoint", 1.0 / 300},  {"theta", 1.0 / 240},
                      {"midpoint", 1.0 / 240}, {"theta", 1e-3, false},   {"theta", 2e-3, false}};
  struct Display {
    const char* label;
    const char* evaluation;
    int cells;
    bool single;
    double refresh_period_s = 0.0;  ///< cohesion.refresh_period_s: offsets held between
  };
  const std::vector<Display> displays =
      opt.quick ? std::vector<Display>{{"exact", "exact", 4, true}, {"grid4", "grid", 4, true}}
                : std::vector<Display>{{"exact", "exact", 4, true},
                                       {"grid4", "grid", 4, true},
                                       {"grid3", "grid", 3, true},
                                       {"grid2", "grid", 2, true},
                                       {"grid4_double", "grid", 4, false},
                                       {"grid3_every_2nd_frame", "grid", 3, true, 1.0 / 30},
                                       {"grid3_every_4th_frame", "grid", 3, true, 1.0 / 15}};
  // The full model's rows: every display pass at theta 2e-3 and 1e-3 s; the default lattice (and
  // 4 nodes per radius) at the midpoint steps that fit 6 and 5 substeps in an output frame.
  struct FullRow {
    Setting setting;
    std::vector<std::string> displays;  ///< labels; empty: every display pass
  };
  const std::vector<FullRow> full_rows =
      opt.quick ? std::vector<FullRow>{{{"theta", 2e-3}, {}}}
                : std::vector<FullRow>{{{"theta", 2e-3}, {}},
                                       {{"theta", 1e-3}, {}},
                                       {{"midpoint", 1.0 / 360}, {"grid3", "grid4"}},
                                       {{"midpoint", 1.0 / 300}, {"grid3", "grid4"}}};
  double smallest = candidates.front().substep_s;
  for (const Setting& c : candidates) smallest = std::min(smallest, c.substep_s);
  BenchScene target = benchScenes()[4];
  BenchScene dynamics = target;
  dynamics.overrides.push_back({"solver.cohesion.mode", "off"});
  io::SceneConfig scene, full_scene;
  if (!makeScene(dynamics, strands, seconds, &scene, &why) ||
      !makeScene(target, strands, seconds, &full_scene, &why)) {
    std::fprintf(stderr, "wet_curly_hair_bench: target: %s\n", why.c_str());
    return 2;
  }
  const double length = scene.groom.length_m;
  // The references run the full model (exact cohesion): p^w never feeds back into the dynamics
  // (A14), so their simulated positions are those of the dynamics alone.
  RunResult ref, chk;
  if (!runOnce(full_scene, {"midpoint", smallest / 16.0}, threads, true, &ref, &why) ||
      !runOnce(full_scene, {"midpoint", smallest / 32.0}, threads, true, &chk, &why)) {
    std::fprintf(stderr, "wet_curly_hair_bench: target reference: %s\n", why.c_str());
    return 2;
  }
  // With 1,000 strands some pass the sphere on a knife edge: their paths part for any change of
  // the step, so the reference converges only over a horizon. The errors are taken over the
  // frames where reference and check stay within 0.1 % RMS (10x below the 1 % budget).
  const double horizon_tolerance = 1e-3;
  const size_t horizon =
      convergedHorizon(ref.sim_frames, chk.sim_frames, length, horizon_tolerance);
  const double fps = 1.0 / scene.run.frame_s;
  const Error whole = frameError(ref.sim_frames, chk.sim_frames, length);
  const Error converged = frameError(ref.sim_frames, chk.sim_frames, length, horizon);
  const Error converged_out = frameError(ref.frames, chk.frames, length, horizon);
  std::printf(
      "target %d strands: reference midpoint %.3g s vs %.3g s: over the whole run RMS "
      "%.2e, max %.2e; converged (per-frame RMS <= %.0e) over the first %zu frames "
      "(%.3f s): RMS %.2e, max %.2e (output positions p^w: RMS %.2e, max %.2e)\n",
      strands, smallest / 16.0, smallest / 32.0, whole.rms, whole.max, horizon_tolerance, horizon,
      (horizon - 1) / fps, converged.rms, converged.max, converged_out.rms, converged_out.max);
  // The shape distributions pooled over the whole run (every output frame after the first):
  // the references' distance from each other is the floor of any setting's.
  const wet_curly_hair::ShapeDistance ref_shape_sim = compareShapes(chk.sim_shape, ref.sim_shape);
  const wet_curly_hair::ShapeDistance ref_shape_out = compareShapes(chk.shape, ref.shape);
  printShape("target reference check (simulated positions)", ref_shape_sim);
  printShape("target reference check (output positions p^w)", ref_shape_out);
  std::ostringstream csv;
  csv << "integrator,substep_s,strand_lanes,cohesion,strands,threads,wall_s_per_sim_s,"
         "realtime_factor,rms_error,max_error,stable,runs,rms_error_whole_run,"
         "max_error_whole_run,horizon_s"
      << kShapeHeader << "\n";
  const double horizon_s = (horizon - 1) / fps;
  csv << "reference_check,midpoint " << fmt(smallest / 16.0) << " vs " << fmt(smallest / 32.0)
      << ",1,off," << strands << "," << threads << "," << fmt(ref.summary.wall_s) << ",0,"
      << fmt(converged.rms) << "," << fmt(converged.max) << ",1,1," << fmt(whole.rms) << ","
      << fmt(whole.max) << "," << fmt(horizon_s) << shapeColumns(ref_shape_sim) << "\n";
  csv << "reference_check_output,midpoint " << fmt(smallest / 16.0) << " vs "
      << fmt(smallest / 32.0) << ",1,exact," << strands << "," << threads << ","
      << fmt(ref.summary.wall_s) << ",0," << fmt(converged_out.rms) << "," << fmt(converged_out.max)
      << ",1,1," << fmt(frameError(ref.frames, chk.frames, length).rms) << ","
      << fmt(frameError(ref.frames, chk.frames, length).max) << "," << fmt(horizon_s)
      << shapeColumns(ref_shape_out) << "\n";
  const TargetReference reference{ref, length, horizon, horizon_s, strands, threads};
  auto measure = [&](const io::SceneConfig& sc, const Setting& setting, const char* cohesion,
                     bool output) {
    return measureTargetRow(opt, reference, sc, setting, cohesion, output, &csv, &why);
  };
  for (const Setting& c : candidates) {
    if (!opt.target) break;
    if (!measure(scene, c, "off", false)) {
      std::fprintf(stderr, "wet_curly_hair_bench: target: %s\n", why.c_str());
      return 2;
    }
  }
  if (opt.lanes && benchLanes(opt, scene, ref, horizon, strands, threads, all_ok) != 0) return 2;
  for (const FullRow& row : full_rows) {
    if (!opt.target) break;
    for (const Display& d : displays) {
      if (!row.displays.empty() &&
          std::find(row.displays.begin(), row.displays.end(), d.label) == row.displays.end())
        continue;
      const Setting& setting = row.setting;
      BenchScene with = target;
      with.overrides.push_back(
          {"solver.cohesion.evaluation", std::string("\"") + d.evaluation + "\""});
      with.overrides.push_back({"solver.cohesion.grid_cells_per_radius", std::to_string(d.cells)});
      with.overrides.push_back(
          {"solver.cohesion.grid_single_precision", d.single ? "true" : "false"});
      with.overrides.push_back({"solver.cohesion.refresh_period_s", fmt(d.refresh_period_s)});
      io::SceneConfig sc;
      if (!makeScene(with, strands, seconds, &sc, &why) || !measure(sc, setting, d.label, true)) {
        std::fprintf(stderr, "wet_curly_hair_bench: target: %s\n", why.c_str());
        return 2;
      }
    }
  }
  if (opt.target) *all_ok = writeFile(opt.out + "/target.csv", csv.str()) && *all_ok;
  return 0;
}

/// The built-in scene exactly as shipped (io::builtinScene: the defaults, every hardware thread),
/// 2 s, --repeats runs (at least 3): its real-time factor, the package's first target (RTF >= 3 on
/// a 2-core machine). Returns 2 when a run fails, 0 otherwise; *all_ok turns false when the file
/// cannot be written.
int benchBuiltin(const Options& opt, bool* all_ok) {
  io::SceneConfig scene = io::builtinScene();
  scene.run.seconds = opt.quick ? 0.2 : 2.0;
  const int runs = opt.quick ? 1 : std::max(3, opt.repeats);
  io::RunOptions options;
  options.measure = false;
  options.tangles = false;
  options.clump_distance = false;
  options.stage_timing = false;  // clock reads cost
  std::vector<double> rtf;
  io::RunSummary summary;
  for (int r = 0; r < runs; ++r) {
    std::string why;
    if (!io::runScene(scene, options, &summary, &why)) {
      std::fprintf(stderr, "wet_curly_hair_bench: builtin: %s\n", why.c_str());
      return 2;
    }
    rtf.push_back(summary.wall_s > 0.0 ? summary.sim_s / summary.wall_s : 0.0);
  }
  const auto [lo, hi] = std::minmax_element(rtf.begin(), rtf.end());
  std::ostringstream csv;
  csv << "scene,strands,particles,integrator,substep_s,threads,lane_layout,cohesion,sim_s,runs,"
         "realtime_factor,realtime_factor_min,realtime_factor_max\n";
  csv << "builtin," << summary.strands << "," << summary.particles << "," << summary.integrator
      << "," << fmt(summary.substep_s) << "," << summary.threads << "," << summary.lane_layout
      << "," << summary.cohesion << "," << fmt(scene.run.seconds) << "," << runs << ","
      << fmt(median(rtf)) << "," << fmt(*lo) << "," << fmt(*hi) << "\n";
  std::printf(
      "builtin %d strands, %s %.3g s, %d threads, %s lanes, cohesion %s: real-time factor %.2f "
      "(median of %d runs of %.3g s; %.2f to %.2f)\n",
      summary.strands, summary.integrator.c_str(), summary.substep_s, summary.threads,
      summary.lane_layout.c_str(), summary.cohesion.c_str(), median(rtf), runs, scene.run.seconds,
      *lo, *hi);
  *all_ok = writeFile(opt.out + "/builtin.csv", csv.str()) && *all_ok;
  return 0;
}

/// "Model only what the scene needs": dry against wet, obstacle out of reach.
/// Returns 2 when a run fails, 0 otherwise; *all_ok turns false when a file cannot be written.
int benchGating(const Options& opt, bool* all_ok) {
  std::string why;

  // "Model only what the scene needs": the same nodding scene dry and fully wet, and with an
  // obstacle out of the hair's reach, per integrator; ratios of medians measured in one run.
  std::ostringstream csv;
  csv << "integrator,variant,wall_s_per_sim_s,ratio_to_wet,ratio_to_no_obstacle,runs\n";
  const BenchScene base{
      "gating", "nodding, built-in groom", {}, "nod:freq_hz=1,amplitude_rad=0.35"};
  struct Variant {
    const char* name;
    const char* saturation;
    bool far_obstacle;
  };
  const Variant variants[] = {{"wet", "1", false},
                              {"dry", "0", false},
                              {"wet_far_obstacle", "1", true},
                              {"dry_far_obstacle", "0", true}};
  const std::vector<Setting> settings =
      opt.quick ? std::vector<Setting>{{"theta", 1.0 / 240}}
                : std::vector<Setting>{{"explicit", 2e-4}, {"theta", 1.0 / 240}};
  const int strands = opt.quick ? 6 : 100;
  // 3 s: 1 s of the dry implicit scene took 35 ms of wall time, too short to tell 5 % apart.
  const double seconds = opt.quick ? 0.1 : 3.0;
  // The variants run in turn within each repeat, and every ratio is the median over the
  // repeats of the ratio within one repeat: slow drifts of the shared machine (which moved
  // whole-run medians by several percent between variants run one after another) cancel.
  const int repeats = opt.quick ? opt.repeats : std::max(opt.repeats, 9);
  for (const Setting& setting : settings) {
    std::map<std::string, io::SceneConfig> scenes;
    for (const Variant& v : variants) {
      BenchScene b = base;
      b.overrides = {{"saturation.root", v.saturation}, {"saturation.tip", v.saturation}};
      if (v.far_obstacle) b.overrides.push_back({"obstacles", "[\"sphere:x=5,y=0,z=0,r=0.5\"]"});
      if (!makeScene(b, strands, seconds, &scenes[v.name], &why)) {
        std::fprintf(stderr, "wet_curly_hair_bench: gating: %s\n", why.c_str());
        return 2;
      }
    }
    std::map<std::string, std::vector<double>> walls;
    for (int r = 0; r < repeats; ++r) {
      for (const Variant& v : variants) {
        RunResult run;
        if (!runOnce(scenes[v.name], setting, opt.threads, false, &run, &why)) {
          std::fprintf(stderr, "wet_curly_hair_bench: gating: %s\n", why.c_str());
          return 2;
        }
        walls[v.name].push_back(run.summary.wall_s / run.summary.sim_s);
      }
    }
    auto ratio = [&](const std::string& a, const std::string& b) {
      std::vector<double> q;
      for (int r = 0; r < repeats; ++r) q.push_back(walls[a][r] / walls[b][r]);
      return median(q);
    };
    for (const Variant& v : variants) {
      const std::string name = v.name;
      const bool wet = name.rfind("wet", 0) == 0;
      const std::string wet_twin = wet ? name : "wet" + name.substr(3);
      const std::string no_obstacle = v.far_obstacle ? (wet ? "wet" : "dry") : name;
      const double cost = median(walls[name]);
      csv << setting.integrator << "," << name << "," << fmt(cost) << ","
          << fmt(ratio(name, wet_twin)) << "," << fmt(ratio(name, no_obstacle)) << "," << repeats
          << "\n";
      std::printf("gating %-15s %-17s %8.4f s/s  vs wet %.3f  vs no obstacle %.3f\n",
                  setting.integrator.c_str(), name.c_str(), cost, ratio(name, wet_twin),
                  ratio(name, no_obstacle));
    }
  }
  *all_ok = writeFile(opt.out + "/gating.csv", csv.str()) && *all_ok;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "wet_curly_hair_bench: %s needs a value\n%s", a.c_str(), kUsage);
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--out")
      opt.out = value();
    else if (a == "--quick")
      opt.quick = true;
    else if (a == "--repeats")
      opt.repeats = std::atoi(value().c_str());
    else if (a == "--strands")
      opt.strands = std::atoi(value().c_str());
    else if (a == "--seconds")
      opt.seconds = std::atof(value().c_str());
    else if (a == "--threads")
      opt.threads = std::atoi(value().c_str());
    else if (a == "--scene")
      opt.only_scenes.push_back(value());
    else if (a == "--scaling-series")
      opt.only_series.push_back(value());
    else if (a == "--no-scaling")
      opt.scaling = false;
    else if (a == "--no-work-precision")
      opt.work_precision = false;
    else if (a == "--no-gating")
      opt.gating = false;
    else if (a == "--no-cohesion")
      opt.cohesion = false;
    else if (a == "--no-target")
      opt.target = false;
    else if (a == "--no-lanes")
      opt.lanes = false;
    else if (a == "--no-builtin")
      opt.builtin = false;
    else if (a == "--replot")
      opt.replot = true;
    else {
      std::fprintf(stderr, "wet_curly_hair_bench: unknown option '%s'\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  if (opt.quick) {
    opt.repeats = 1;
    opt.strands = 6;
    opt.seconds = 0.2;
  }
  if (opt.repeats < 1 || opt.strands < 1 || !(opt.seconds > 0.0) || opt.threads < 1) {
    std::fprintf(stderr,
                 "wet_curly_hair_bench: --repeats, --strands, --seconds and --threads "
                 "must be positive\n");
    return 2;
  }
  if (opt.replot) {
    // Redraws work_precision.png and scaling.png from the CSV files already in --out.
    if (!haveGnuplot()) {
      std::fprintf(stderr, "wet_curly_hair_bench: --replot needs gnuplot\n");
      return 2;
    }
    std::vector<std::string> names;
    for (const BenchScene& b : benchScenes()) names.push_back(b.name);
    plotWorkPrecision(opt.out, names);
    plotScaling(opt.out);
    std::ifstream lanes_csv(opt.out + "/lanes.csv");
    if (lanes_csv) plotLanes(opt.out);
    return 0;
  }
  if (!wet_curly_hair::bench::makeOutputDirectory("wet_curly_hair_bench", opt.out)) return 2;
  bool all_ok = true;
  if (opt.builtin && benchBuiltin(opt, &all_ok) != 0) return 2;
  if (opt.work_precision && benchWorkPrecision(opt, &all_ok) != 0) return 2;
  if (opt.scaling && benchScaling(opt, &all_ok) != 0) return 2;
  if (opt.cohesion && benchCohesion(opt, &all_ok) != 0) return 2;
  if ((opt.target || opt.lanes) && benchTargetAndLanes(opt, &all_ok) != 0) return 2;
  if (opt.gating && benchGating(opt, &all_ok) != 0) return 2;
  if (!all_ok) {
    std::fprintf(stderr, "wet_curly_hair_bench: cannot write into %s\n", opt.out.c_str());
    return 2;
  }
  std::printf("wrote %s\n", opt.out.c_str());
  return 0;
}
