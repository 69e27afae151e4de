// What a follower costs: the built-in scene (wet toward the tips, nodding) with a sphere behind
// the head, run at follow ratios K (one strand in K simulated, the others interpolated,
// followers.h) against the full simulation of the same groom (K = 1). Every follower is compared
// with the same strand (same root) of the full run, particle by particle, at every compared frame:
// RMS and max position error over the whole run and of the tips alone, in % of the strand's
// length. Also the tip curl radius and the clump distance of each run (all output strands), and
// the cost: wall seconds of step() per simulated second (median of --runs runs). Each K > 1 runs
// again with the cohesion sums at the guides (cohesion.gather_at guides): the followers' display
// positions p^w of the two against each other and each against the full run's. Writes
// DIR/NAME.csv and, with gnuplot, DIR/NAME.png (NAME: --name, default followers) (cost against
// error, K as the knob), and a Markdown table on stdout with the CPU. usage: bench_followers
// [--strands N] [--ks 1,2,4,8,16] [--seconds T] [--runs N] [--threads N]
//                        [--compare-stride F] [--out DIR] [--name NAME] [--dry] [--sag-free]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "bench_common.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/io/scene.h"
#include "wet_curly_hair/io/scene_setup.h"
#include "wet_curly_hair/runner/offline_run.h"

using namespace wet_curly_hair;
using wet_curly_hair::bench::cpuLine;

namespace {

struct Options {
  int strands = 400;
  std::vector<int> ks = {1, 2, 4, 8, 16};
  double seconds = 3.0;
  int runs = 3;
  int threads = 1;
  int compare_stride = 1;  ///< compare every F-th frame (memory: the reference keeps those)
  std::string out = ".";
  std::string name = "followers";  ///< --name: DIR/NAME.csv, DIR/NAME.png
  bool dry = false;  ///< --dry: saturation 0 everywhere (no wet effects) instead of the scene's
  /// --sag-free: the groom starts at equilibrium (solver.sag_free) instead of falling from it.
  bool sag_free = false;
};

io::SceneConfig benchScene(const Options& o, int k) {
  io::SceneConfig scene = io::builtinScene();
  scene.groom.strands = o.strands;
  scene.groom.follow_ratio = k;
  scene.run.seconds = o.seconds;
  scene.solver.integrator.threads = o.threads;
  if (o.dry) scene.saturation.root = scene.saturation.tip = 0.0;
  scene.solver.sag_free = o.sag_free;
  scene.obstacles.push_back(bench::sphereBehindTheHead());
  return scene;
}

struct Row {
  int k = 0, guides = 0;
  double cost = 0.0, follower_cost = 0.0;  ///< wall s per simulated s; the followers stage's
  double rms = 0.0, max = 0.0, tip_rms = 0.0, tip_max = 0.0;  ///< fractions of strand length
  double curl_radius_m = 0.0, clump_m = 0.0;
  /// The followers' edges over the compared frames: the largest and the smallest (L - L0) / L0.
  double max_strain = 0.0, min_strain = 0.0;
  bool finite = true;
  /// K > 1, the same scene with cohesion.gather_at "guides": its cost, its clump distance, and
  /// its followers' display positions p^w against those of the gather at every particle (same
  /// dynamics: p^w never feeds back), RMS and max in fractions of strand length; beside them the
  /// RMS of the display offset |p^w - p| itself (gather at every particle).
  double guides_cost = 0.0, guides_clump_m = 0.0, display_rms = 0.0, display_max = 0.0;
  double offset_rms = 0.0;
  /// The followers' display positions p^w against the full run's p^w of the same strand, RMS in
  /// fractions of strand length: what the user sees against what simulating every strand shows,
  /// with this run's sums (and with the sums at the guides, guides_full_display_rms).
  double full_display_rms = 0.0, guides_full_display_rms = 0.0;
  double guides_offset_rms = 0.0;  ///< the offset |p^w - p| with the sums at the guides, RMS
};

/// The wet_position of the followers of every compared frame.
typedef std::vector<Vec3List> Frames;

/// The full run's positions and display positions of every compared frame (groom strand order).
struct Reference {
  std::vector<Vec3List> position, wet_position;
};

/// Runs the scene at follow ratio k `runs` times; compares the first run's followers with
/// `reference` (the full run; empty: this is the reference, stored into *store).
Row runK(const Options& o, int k, const Reference* reference, Reference* store,
         const std::string& gather_at = "all", Frames* display_store = nullptr,
         const Frames* display_reference = nullptr) {
  io::SceneConfig scene = benchScene(o, k);
  scene.solver.cohesion.gather_at = gather_at;
  HairModel model;
  std::string why;
  if (!io::buildSceneModel(scene, &model, &why)) {
    std::fprintf(stderr, "bench_followers: %s\n", why.c_str());
    std::exit(2);
  }
  const FollowerMap& f = model.followers;
  const int first_follower = f.guide_strands > 0 ? f.guide_strands : model.strandCount();
  double sum2 = 0.0, tip_sum2 = 0.0, max = 0.0, tip_max = 0.0;
  double max_strain = 0.0, min_strain = 0.0;
  double display_sum2 = 0.0, display_max = 0.0, offset_sum2 = 0.0, full_display_sum2 = 0.0;
  long count = 0, tips = 0, display_count = 0;
  const int follower_particle0 = model.strandBegin(first_follower);
  io::RunOptions options;
  options.measure = false;
  options.tangles = false;
  options.on_frame = [&](int frame, const HairState& state) {
    if (frame % o.compare_stride != 0) return;
    const Vec3List& shown = displayPositions(state);
    if (display_store) display_store->emplace_back(shown.begin() + follower_particle0, shown.end());
    for (int s = first_follower; s < model.strandCount(); ++s) {
      const int begin = model.strandBegin(s);
      for (int i = begin; i < begin + model.strandSize(s); ++i) {
        const double len = model.strand_length_m[s];
        const double off = (shown[i] - state.position[i]).norm() / len;
        offset_sum2 += off * off;
        if (display_reference) {
          const Vec3& ref = (*display_reference)[frame / o.compare_stride][i - follower_particle0];
          const double e = (shown[i] - ref).norm() / len;
          display_sum2 += e * e;
          display_max = std::max(display_max, e);
        }
        ++display_count;
      }
    }
    for (int s = first_follower; s < model.strandCount(); ++s) {
      const int begin = model.strandBegin(s);
      for (int i = begin; i + 1 < begin + model.strandSize(s); ++i) {
        const double strain =
            (state.position[i + 1] - state.position[i]).norm() / model.rest_edge_m[i] - 1.0;
        max_strain = std::max(max_strain, strain);
        min_strain = std::min(min_strain, strain);
      }
    }
    if (store) {  // the full run: groom order is model order
      store->position.push_back(state.position);
      store->wet_position.push_back(shown);
      return;
    }
    const Vec3List& ref = reference->position[frame / o.compare_stride];
    const Vec3List& ref_wet = reference->wet_position[frame / o.compare_stride];
    for (int s = first_follower; s < model.strandCount(); ++s) {
      const int src = f.source_strand[s];
      const int n = model.strandSize(s), begin = model.strandBegin(s);
      const int ref_begin = static_cast<int>(src) * n;  // the groom: equal particle counts
      for (int i = 0; i < n; ++i) {
        const double e =
            (state.position[begin + i] - ref[ref_begin + i]).norm() / model.strand_length_m[s];
        sum2 += e * e;
        max = std::max(max, e);
        ++count;
        const double w =
            (shown[begin + i] - ref_wet[ref_begin + i]).norm() / model.strand_length_m[s];
        full_display_sum2 += w * w;
      }
      const double e = (state.position[begin + n - 1] - ref[ref_begin + n - 1]).norm() /
                       model.strand_length_m[s];
      tip_sum2 += e * e;
      tip_max = std::max(tip_max, e);
      ++tips;
    }
  };
  Row row;
  row.k = k;
  row.guides = model.simulatedStrandCount();
  std::vector<double> costs, follower_costs;
  for (int r = 0; r < o.runs; ++r) {
    io::RunSummary s;
    if (!io::runScene(scene, options, &s, &why)) {
      std::fprintf(stderr, "bench_followers: %s\n", why.c_str());
      std::exit(2);
    }
    costs.push_back(s.wall_s / s.sim_s);
    follower_costs.push_back(s.stage_cpu_s[kStageFollowers] / s.sim_s);
    if (r == 0) {
      row.curl_radius_m = s.curl_radius_tip_m;
      row.clump_m = s.clump_distance_m;
      row.finite = s.finite;
      options.on_frame = nullptr;  // the runs after the first are timed only
      store = nullptr;
    }
  }
  std::sort(costs.begin(), costs.end());
  std::sort(follower_costs.begin(), follower_costs.end());
  row.cost = costs[costs.size() / 2];
  row.follower_cost = follower_costs[follower_costs.size() / 2];
  row.rms = count ? std::sqrt(sum2 / count) : 0.0;
  row.max = max;
  row.tip_rms = tips ? std::sqrt(tip_sum2 / tips) : 0.0;
  row.tip_max = tip_max;
  row.max_strain = max_strain;
  row.min_strain = min_strain;
  row.display_rms = display_count ? std::sqrt(display_sum2 / display_count) : 0.0;
  row.display_max = display_max;
  row.offset_rms = display_count ? std::sqrt(offset_sum2 / display_count) : 0.0;
  row.full_display_rms = count ? std::sqrt(full_display_sum2 / count) : 0.0;
  return row;
}

void plot(const std::string& dir, const std::string& name, const std::string& title) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) {
    std::printf("gnuplot not found: no %s.png\n", name.c_str());
    return;
  }
  const std::string csv = dir + "/" + name + ".csv";
  std::ostringstream gp;
  gp << "set terminal pngcairo size 900,600\nset output '" << dir << "/" << name << ".png'\n"
     << "set datafile separator ','\nset key autotitle columnhead\nset logscale x\n"
     << "set xlabel 'cost: wall s of step() per simulated s'\n"
     << "set ylabel 'follower error over the run, % of strand length'\nset yrange [0:*]\n"
     << "set title '" << title << "' noenhanced\nset key top right\n"
     << "plot '" << csv << "' using 4:6 with linespoints pt 7 title 'RMS', "
     << "'' using 4:8 with linespoints pt 7 title 'RMS, tips', "
     << "'' using 4:6:(sprintf('K=%d', $2)) with labels offset 0,1 "
        "notitle\n";
  const std::string path = dir + "/" + name + ".gp";
  std::ofstream(path) << gp.str();
  if (std::system(("gnuplot '" + path + "'").c_str()) != 0)
    std::printf("gnuplot failed on %s\n", path.c_str());
}

bool parse(int argc, char** argv, Options* o) {
  for (int a = 1; a < argc; a += 2) {
    const std::string flag = argv[a];
    if (flag == "--dry" || flag == "--sag-free") {
      (flag == "--dry" ? o->dry : o->sag_free) = true;
      --a;
      continue;
    }
    if (a + 1 >= argc) return false;
    const std::string v = argv[a + 1];
    if (flag == "--strands") {
      o->strands = std::atoi(v.c_str());
    } else if (flag == "--ks") {
      o->ks.clear();
      std::stringstream ss(v);
      for (std::string item; std::getline(ss, item, ',');) o->ks.push_back(std::atoi(item.c_str()));
    } else if (flag == "--seconds") {
      o->seconds = std::atof(v.c_str());
    } else if (flag == "--runs") {
      o->runs = std::max(1, std::atoi(v.c_str()));
    } else if (flag == "--threads") {
      o->threads = std::atoi(v.c_str());
    } else if (flag == "--compare-stride") {
      o->compare_stride = std::max(1, std::atoi(v.c_str()));
    } else if (flag == "--name") {
      o->name = v;
    } else if (flag == "--out") {
      o->out = v;
    } else {
      return false;
    }
  }
  return o->strands > 0 && o->seconds > 0.0 && !o->ks.empty();
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, &o)) {
    std::fprintf(
        stderr,
        "usage: bench_followers [--strands N] [--ks 1,2,4,8,16] [--seconds T] [--runs N]"
        " [--threads N] [--compare-stride F] [--out DIR] [--name NAME] [--dry] [--sag-free]\n");
    return 2;
  }
  if (!bench::makeOutputDirectory("bench_followers", o.out)) return 2;
  const std::string cpu = cpuLine();
  std::printf(
      "CPU: %s; %d strands x 32, %g s of the built-in %s nod with a sphere%s, %d thread(s),"
      " cost the median of %d runs\n\n",
      cpu.c_str(), o.strands, o.seconds, o.dry ? "dry" : "wet",
      o.sag_free ? ", sag-free start" : "", o.threads, o.runs);
  Reference reference;
  std::vector<Row> rows;
  rows.push_back(runK(o, 1, nullptr, &reference));
  for (int k : o.ks) {
    if (k <= 1) continue;
    Frames display;
    Row row = runK(o, k, &reference, nullptr, "all", &display);
    const Row guides = runK(o, k, &reference, nullptr, "guides", nullptr, &display);
    row.guides_cost = guides.cost;
    row.guides_clump_m = guides.clump_m;
    row.display_rms = guides.display_rms;
    row.display_max = guides.display_max;
    row.guides_full_display_rms = guides.full_display_rms;
    row.guides_offset_rms = guides.offset_rms;
    rows.push_back(row);
  }
  std::ofstream csv(o.out + "/" + o.name + ".csv");
  csv << "strands,K,guides,cost_s_per_s,followers_cpu_s_per_s,rms_pct,max_pct,tip_rms_pct,"
         "tip_max_pct,curl_radius_tip_mm,clump_distance_mm,finite,guides_cost_s_per_s,"
         "guides_clump_distance_mm,display_offset_rms_pct,guides_display_rms_pct,"
         "guides_display_max_pct,follower_max_strain_pct,follower_min_strain_pct,"
         "display_vs_full_rms_pct,guides_display_vs_full_rms_pct,guides_display_offset_rms_pct\n";
  std::printf(
      "| K | guides | cost, s/s | of it followers, s/s | RMS %% | max %% | tip RMS %% | tip max %% "
      "| curl radius, mm | clump distance, mm | follower edge strain, max / min %% |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows) {
    csv << o.strands << "," << r.k << "," << r.guides << "," << r.cost << "," << r.follower_cost
        << "," << 100 * r.rms << "," << 100 * r.max << "," << 100 * r.tip_rms << ","
        << 100 * r.tip_max << "," << 1e3 * r.curl_radius_m << "," << 1e3 * r.clump_m << ","
        << (r.finite ? 1 : 0) << "," << r.guides_cost << "," << 1e3 * r.guides_clump_m << ","
        << 100 * r.offset_rms << "," << 100 * r.display_rms << "," << 100 * r.display_max << ","
        << 100 * r.max_strain << "," << 100 * r.min_strain << "," << 100 * r.full_display_rms << ","
        << 100 * r.guides_full_display_rms << "," << 100 * r.guides_offset_rms << "\n";
    std::printf(
        "| %d | %d | %.3g | %.3g | %.3g | %.3g | %.3g | %.3g | %.2f | %.2f | %.3g / %.3g |\n", r.k,
        r.guides, r.cost, r.follower_cost, 100 * r.rms, 100 * r.max, 100 * r.tip_rms,
        100 * r.tip_max, 1e3 * r.curl_radius_m, 1e3 * r.clump_m, 100 * r.max_strain,
        100 * r.min_strain);
  }
  std::printf(
      "\nThe cohesion display with the sums at the guides only (cohesion.gather_at guides) against"
      " the sums at every particle (same dynamics), followers' p^w:\n\n| K | cost, s/s, all |"
      " cost, s/s, guides | ratio | display offset RMS %%, all | guides | p^w difference RMS %% |"
      " max %% |"
      " clump distance, mm, all | guides | p^w against the full run's, RMS %%, all | guides |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows) {
    if (r.k <= 1) continue;
    std::printf(
        "| %d | %.3g | %.3g | %.2f | %.3g | %.3g | %.3g | %.3g | %.2f | %.2f | %.3g | %.3g |\n",
        r.k, r.cost, r.guides_cost, r.guides_cost / r.cost, 100 * r.offset_rms,
        100 * r.guides_offset_rms, 100 * r.display_rms, 100 * r.display_max, 1e3 * r.clump_m,
        1e3 * r.guides_clump_m, 100 * r.full_display_rms, 100 * r.guides_full_display_rms);
  }
  csv.close();
  plot(o.out, o.name,
       "followers against the full simulation, " + std::to_string(o.strands) + " strands; " + cpu);
  return 0;
}
