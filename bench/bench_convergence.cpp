// Speed against error in space and time (docs/convergence.md), under the built-in scene's nod:
//  - a hanging curly strand (no head), at 16 ... 128 particles with every integrator and a range
//    of substeps, against a reference fine in both (256 particles, the explicit method at its
//    resolution-following substep, at most 2.5e-5 s);
//  - the 40-strand groom on the head (collision on), the same resolutions with the explicit
//    method, midpoint (the default) and theta 0.6, against 256 particles with midpoint at
//    1.25e-4 s (the explicit method at 256 particles strain-limits the root edges against the
//    collision offset on every substep and settles elsewhere: docs/convergence.md).
// The error is over the whole run: at every sampled frame, the distance between each strand and
// the reference at 17 material points (equal fractions of the arc length from the root; the grooms
// are sampled at equal chords, so particle i of n sits at i / (n - 1) of the length), RMS over
// strands, points and frames, over the strand length. The cost is the wall time of step() per
// simulated second, median of `--runs` runs (default 3). Writes convergence.csv and
// convergence_groom.csv and, with gnuplot, convergence.png and convergence_groom.png (error
// against cost, one curve per resolution) into --out (default .).
// usage: bench_convergence [--out DIR] [--seconds T] [--runs N]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "bench_common.h"
#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/head_motion.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/state.h"

using namespace wet_curly_hair;

namespace {

constexpr double kFrame = 1.0 / 60.0;
constexpr int kSampleEvery = 3;      // frames between error samples
constexpr int kMaterialPoints = 17;  // root to tip

struct Setting {
  int particles;
  std::string method;
  double substep_s;
};

struct Trace {
  std::vector<std::vector<Vec3>> samples;  // per sampled frame, the material points
  double wall_s = 0.0;
  double length_m = 0.0;  ///< mean strand length
  double substep_used_s = 0.0;
  bool finite = true;
};

Vec3 materialPoint(const HairState& s, int begin, int n, double fraction) {
  const double x = fraction * (n - 1);
  const int i = std::min(n - 2, static_cast<int>(std::floor(x)));
  const double u = x - i;
  return (1.0 - u) * s.position[begin + i] + u * s.position[begin + i + 1];
}

/// One strand hanging free (strands == 1: root pointing down, no head) or a groom on the head.
Trace simulate(const Setting& setting, int strands, double seconds) {
  GroomConfig g;
  g.strands = strands;
  g.particles = setting.particles;
  if (strands == 1) g.scalp_axis = Vec3(0, 0, -1);
  SolverConfig c;
  c.collision.head_enabled = strands > 1;
  c.cohesion.mode = "off";
  c.integrator.method = setting.method;
  // The explicit settings mean "at most substep_s": at fine resolutions its stability bound,
  // which buildModel reads off the springs (a substep past it is refused).
  c.integrator.substep_s = setting.method == "explicit" ? 1e-7 : setting.substep_s;
  HairModel m;
  std::string why;
  Trace t;
  if (!buildModel(generateGroom(g, EllipsoidShape()), g.linear_density_kg_per_m, HeadShape(), c, &m,
                  &why)) {
    std::fprintf(stderr, "bench_convergence: %s\n", why.c_str());
    std::exit(2);
  }
  for (double l : m.strand_length_m) t.length_m += l / m.strandCount();  // the mean
  if (setting.method == "explicit")
    c.integrator.substep_s = std::min(setting.substep_s, m.explicit_substep_bound_s);
  t.substep_used_s = c.integrator.substep_s;
  HeadMotionConfig motion;
  motion.type = "nod";  // the built-in scene's: 0.5 Hz, 0.3 rad
  HairState s = makeState(m, headPose(motion, 0.0), headTwist(motion, 0.0));
  std::fill(s.saturation.begin(), s.saturation.end(), 0.0);
  const int frames = static_cast<int>(std::lround(seconds / kFrame));
  for (int f = 0; f < frames; ++f) {
    const StepInputs in{headPose(motion, f * kFrame), headPose(motion, (f + 1) * kFrame)};
    const auto start = std::chrono::steady_clock::now();
    step(m, c, in, kFrame, &s, nullptr);
    t.wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if ((f + 1) % kSampleEvery != 0) continue;
    std::vector<Vec3> points;
    for (int strand = 0; strand < m.strandCount(); ++strand)
      for (int k = 0; k < kMaterialPoints; ++k) {
        points.push_back(materialPoint(s, m.strandBegin(strand), m.strandSize(strand),
                                       double(k) / (kMaterialPoints - 1)));
        t.finite = t.finite && points.back().allFinite();
      }
    t.samples.push_back(points);
  }
  return t;
}

double rmsError(const Trace& a, const Trace& reference) {
  double sum = 0.0;
  size_t count = 0;
  for (size_t f = 0; f < a.samples.size(); ++f)
    for (size_t k = 0; k < a.samples[f].size(); ++k, ++count)
      sum += (a.samples[f][k] - reference.samples[f][k]).squaredNorm();
  return std::sqrt(sum / std::max<size_t>(count, 1)) / reference.length_m;
}

/// Error against cost from DIR/NAME.csv into DIR/NAME.png, one curve per resolution.
void plot(const std::string& dir, const std::string& name, const std::string& title,
          const std::vector<int>& resolutions) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) {
    std::printf("gnuplot not found: no %s.png\n", name.c_str());
    return;
  }
  std::string script = "set terminal pngcairo size 900,600\nset output '" + dir + "/" + name +
                       ".png'\nset datafile separator ','\nset logscale xy\n"
                       "set xlabel 'cost, wall s per simulated s'\n"
                       "set ylabel 'RMS error over the run / strand length'\n"
                       "set title '" +
                       title + "'\nset key outside right\nplot ";
  for (size_t k = 0; k < resolutions.size(); ++k) {
    const std::string n = std::to_string(resolutions[k]);
    script += std::string(k ? ", " : "") + "'" + dir + "/" + name + ".csv' using ($1==" + n +
              " ? $5 : 1/0):6 with points pt 7 title '" + n + " particles'";
  }
  script += "\n";
  const std::string path = dir + "/" + name + ".gp";
  std::ofstream(path) << script;
  if (std::system(("gnuplot '" + path + "'").c_str()) != 0)
    std::printf("gnuplot failed on %s\n", path.c_str());
}

/// Runs every setting against the reference and writes DIR/NAME.csv and a table on stdout.
void runCase(const std::string& dir, const std::string& name, int strands,
             const Setting& reference_setting, const std::vector<Setting>& settings, double seconds,
             int runs) {
  const Trace reference = simulate(reference_setting, strands, seconds);
  std::ofstream csv(dir + "/" + name + ".csv");
  csv << "particles,method,substep_config_s,substep_used_s,cost_s_per_s,rms_error,finite\n";
  std::printf(
      "| particles | method | substep used, s | cost, s/s | RMS error |\n|---|---|---|---|---|\n");
  for (const Setting& s : settings) {
    std::vector<double> costs;
    Trace t;
    for (int r = 0; r < runs; ++r) {
      t = simulate(s, strands, seconds);
      costs.push_back(t.wall_s / seconds);
    }
    std::sort(costs.begin(), costs.end());
    const double cost = costs[costs.size() / 2];
    const double error = t.finite ? rmsError(t, reference) : NAN;
    csv << s.particles << "," << s.method << "," << s.substep_s << "," << t.substep_used_s << ","
        << cost << "," << error << "," << (t.finite ? 1 : 0) << "\n";
    std::printf("| %d | %s | %.3g | %.3g | %.3g %% |\n", s.particles, s.method.c_str(),
                t.substep_used_s, cost, 100.0 * error);
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = ".";
  double seconds = 2.0;
  int runs = 3;
  for (int k = 1; k + 1 < argc; k += 2) {
    const std::string a = argv[k];
    if (a == "--out")
      out = argv[k + 1];
    else if (a == "--seconds")
      seconds = std::atof(argv[k + 1]);
    else if (a == "--runs")
      runs = std::max(1, std::atoi(argv[k + 1]));
    else {
      std::fprintf(stderr, "usage: bench_convergence [--out DIR] [--seconds T] [--runs N]\n");
      return 2;
    }
  }
  if (argc % 2 == 0 || !(seconds > 0.0)) {
    std::fprintf(stderr, "usage: bench_convergence [--out DIR] [--seconds T] [--runs N]\n");
    return 2;
  }
  if (!bench::makeOutputDirectory("bench_convergence", out)) return 2;
  std::printf("%s; %g s of the nod\n", bench::cpuLine().c_str(), seconds);
  const std::vector<int> resolutions = {16, 32, 64, 128};
  std::vector<Setting> strand_settings, groom_settings;
  for (int n : resolutions) {
    strand_settings.push_back({n, "explicit", 2e-4});
    groom_settings.push_back({n, "explicit", 2e-4});
    for (double h : {4e-3, 2e-3, 1e-3, 5e-4}) {
      strand_settings.push_back({n, "backward_euler", h});
      strand_settings.push_back({n, "theta", h});
      strand_settings.push_back({n, "midpoint", h});
    }
    for (double h : {2e-3, 1e-3, 5e-4}) {
      groom_settings.push_back({n, "theta", h});
      groom_settings.push_back({n, "midpoint", h});
    }
  }
  std::printf("\nOne hanging strand, against 256 particles (explicit, <= 2.5e-5 s)\n");
  runCase(out, "convergence", 1, {256, "explicit", 2.5e-5}, strand_settings, seconds, runs);
  plot(out, "convergence", "Hanging curly strand under a nod: space and time error", resolutions);
  std::printf("\n40 strands on the head, against 256 particles (midpoint, 1.25e-4 s)\n");
  runCase(out, "convergence_groom", 40, {256, "midpoint", 1.25e-4}, groom_settings, seconds, runs);
  plot(out, "convergence_groom", "40-strand groom on the head under a nod: space and time error",
       resolutions);
  return 0;
}
