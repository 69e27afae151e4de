// Stable cohesion (eq. 10, A11-A14) and the force-based baselines.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <string>

#include "wet_curly_hair/core/cohesion.h"
#include "wet_curly_hair/core/cohesion_grid.h"
#include "wet_curly_hair/core/metrics.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/wet_kernels.h"
#include "wet_curly_hair/io/scene_setup.h"

using namespace wet_curly_hair;

namespace {

/// A model of `strands` strands of `particles` particles each, particle i of strand s at
/// point(s, i) (a Vec3: an Eigen expression returned by a lambda would dangle), rooted downward.
template <typename Point>
HairModel strandsModel(int strands, int particles, const SolverConfig& c, Point point) {
  Groom g;
  for (int s = 0; s < strands; ++s) {
    for (int i = 0; i < particles; ++i) g.points.push_back(point(s, i));
    g.strand_offsets.push_back(static_cast<uint32_t>(g.points.size()));
    g.root_normals.push_back(Vec3(0, 0, -1));
  }
  HairModel model;
  std::string why;
  EXPECT_TRUE(buildModel(g, GroomConfig().linear_density_kg_per_m, HeadShape(), c, &model, &why))
      << why;
  return model;
}

/// Two parallel straight strands `gap` apart, plus a third far away.
struct Fixture {
  HairModel model;
  HairState state;
  Fixture(double gap) {
    model = strandsModel(3, 10, SolverConfig(), [gap](int s, int i) -> Vec3 {
      return (s == 2 ? Vec3(1.0, 0, 0) : Vec3(s * gap, 0, 0)) + Vec3(0, 0, -0.008 * i);
    });
    state = makeState(model, Pose(), Twist());
  }
};

}  // namespace

TEST(Cohesion, DryHairIsUntouched) {
  Fixture f(0.005);
  CohesionConfig c;
  c.evaluation = "exact";  // eq. (10) summed over every neighbour: the analytic answers
  EXPECT_EQ(computeDisplayCohesion(f.model, c, &f.state), 0);
  for (int i = 0; i < f.model.particleCount(); ++i)
    EXPECT_EQ(displayPositions(f.state)[i], f.state.position[i]);
}

TEST(Cohesion, NothingToDisplayLeavesTheDisplayToThePositions) {
  // Dry hair, cohesion off on wet hair, and tightness 0: p^w = p everywhere, and the pass writes
  // no display position (a frame's copy of every position); displayPositions reads the positions.
  // The hair moved since its display positions were written, so a stale list would show.
  const double frame = 1.0 / 60.0;
  for (const char* what : {"dry", "off", "tightness 0"}) {
    Fixture f(0.005);
    CohesionConfig c;
    if (std::string(what) != "dry")
      std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
    if (std::string(what) == "off") c.mode = "off";
    if (std::string(what) == "tightness 0") c.tightness = 0.0;
    const Vec3List written = f.state.wet_position;
    for (Vec3& p : f.state.position) p += Vec3(0.01, -0.02, 0.03);
    EXPECT_EQ(updateDisplayCohesion(f.model, c, frame, &f.state), 0) << what;
    EXPECT_TRUE(f.state.display_is_position) << what;
    EXPECT_EQ(f.state.wet_position, written) << what << ": nothing written";
    EXPECT_EQ(&displayPositions(f.state), &f.state.position) << what;
  }
  // Held offsets: an evaluation with nothing to display holds nothing, not the offsets of the
  // evaluation before it; the next one displays again, written and read.
  Fixture f(0.005);
  CohesionConfig c;
  c.refresh_period_s = 2.0 * frame;
  std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
  EXPECT_EQ(updateDisplayCohesion(f.model, c, frame, &f.state), 20);
  EXPECT_FALSE(f.state.display_is_position);
  std::fill(f.state.saturation.begin(), f.state.saturation.end(), 0.0);
  EXPECT_EQ(updateDisplayCohesion(f.model, c, 3.0 * frame, &f.state), 0);  // dry: nothing
  std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
  EXPECT_EQ(updateDisplayCohesion(f.model, c, 4.0 * frame, &f.state), 0);  // held: still nothing
  EXPECT_TRUE(f.state.display_is_position);
  EXPECT_EQ(updateDisplayCohesion(f.model, c, 5.0 * frame, &f.state), 20);
  EXPECT_FALSE(f.state.display_is_position);
  EXPECT_EQ(&displayPositions(f.state), &f.state.wet_position);
  EXPECT_GT(f.state.wet_position[0].x() - f.state.position[0].x(), 1e-3) << "pulled to strand 1";
}

TEST(Cohesion, WetNeighboursClumpIsolatedParticlesStay) {
  Fixture f(0.005);
  std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
  CohesionConfig c;
  c.evaluation = "exact";  // eq. (10) summed over every neighbour: the analytic answers
  c.include_self = false;  // the literal neighbour set of A13: exact pull of lambda * gap
  const Vec3List before = f.state.position;
  EXPECT_GT(computeDisplayCohesion(f.model, c, &f.state), 0);
  for (int i = 0; i < 10; ++i) {
    // Strand 0 moves toward strand 1 along x by lambda times the gap (its only neighbour), and
    // strand 1 toward strand 0: by 0.85 * 0.005 each (same-strand neighbours excluded, A13).
    EXPECT_NEAR(f.state.wet_position[i].x(), 0.85 * 0.005, 1e-12);
    EXPECT_NEAR(f.state.wet_position[10 + i].x(), 0.005 - 0.85 * 0.005, 1e-12);
    EXPECT_EQ(f.state.wet_position[20 + i], f.state.position[20 + i]) << "isolated strand";
  }
  // The dynamics never read p^w: positions are unchanged.
  EXPECT_EQ(f.state.position, before);
}

TEST(Cohesion, SelfWeightMakesThePullGrowSmoothlyWithDistance) {
  // With the particle in its own Shepard sum, a neighbour near the edge of the support pulls
  // little; without it, any neighbour inside the support pulls by the full lambda.
  for (double gap : {0.019, 0.01, 0.002}) {
    Fixture f(gap);
    std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
    CohesionConfig c;
    c.evaluation = "exact";  // eq. (10) summed over every neighbour: the analytic answers
    c.radius_m = 0.02;
    computeDisplayCohesion(f.model, c, &f.state);
    const double pull = f.state.wet_position[5].x() / (0.85 * gap);
    if (gap > 0.015) {
      EXPECT_LT(pull, 0.1) << gap;
    }
    if (gap < 0.005) {
      EXPECT_GT(pull, 0.3) << gap;
    }
    EXPECT_LT(pull, 1.0) << gap;
  }
}

TEST(Cohesion, HeldOffsetsRideOnThePositionsUntilTheNextRefresh) {
  // Refresh every 2 frames: the frame between evaluations holds the offsets of the last one.
  // Analytic: both strands 0 and 1 pulled by lambda * gap toward each other (no self weight).
  const double frame = 1.0 / 60.0, gap = 0.005;
  Fixture f(gap);
  std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
  CohesionConfig c;
  c.evaluation = "exact";
  c.include_self = false;
  c.refresh_period_s = 2.0 * frame;
  EXPECT_EQ(updateDisplayCohesion(f.model, c, frame, &f.state), 20);  // the first call evaluates
  // Strand 1 moves 3 mm farther: a fresh evaluation would pull by lambda * 8 mm, the held offset
  // stays lambda * 5 mm, carried by the new positions; and strand 0 dries (p^w = p at once).
  for (int i = 10; i < 20; ++i) f.state.position[i].x() += 0.003;
  for (int i = 0; i < 10; ++i) f.state.saturation[i] = 0.0;
  EXPECT_EQ(updateDisplayCohesion(f.model, c, 2.0 * frame, &f.state), 10);
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(f.state.wet_position[i], f.state.position[i]) << "dried";
    EXPECT_NEAR(f.state.wet_position[10 + i].x(), gap + 0.003 - 0.85 * gap, 1e-12);
  }
  // Two frames after the evaluation the offsets are due again (whatever the frame times' round
  // off): strand 1 alone is wet, its only neighbour dry (weighed, pulling nowhere): p^w = p.
  EXPECT_EQ(updateDisplayCohesion(f.model, c, 3.0 * frame, &f.state), 10);
  for (int i = 0; i < f.model.particleCount(); ++i)
    EXPECT_EQ(f.state.wet_position[i], f.state.position[i]) << i;
  // Period 0 evaluates at every call, and a reset forgets the held offsets.
  for (int i = 0; i < 10; ++i) f.state.saturation[i] = 1.0;
  c.refresh_period_s = 0.0;
  HairState every = f.state;
  EXPECT_EQ(updateDisplayCohesion(f.model, c, 3.0 * frame, &every), 20);
  c.refresh_period_s = 10.0;
  resetState(f.model, Pose(), Twist(), &f.state);
  for (int i = 10; i < 20; ++i) f.state.position[i].x() += 0.003;
  EXPECT_EQ(updateDisplayCohesion(f.model, c, 0.0, &f.state), 20);
  EXPECT_NEAR(f.state.wet_position[0].x(), 0.85 * (gap + 0.003), 1e-12);
}

TEST(Cohesion, IsTranslationInvariant) {
  Fixture a(0.007), b(0.007);
  const Vec3 shift(12.3, -4.5, 6.7);
  for (Vec3& x : b.state.position) x += shift;
  for (Fixture* f : {&a, &b})
    for (int i = 0; i < f->model.particleCount(); ++i)
      f->state.saturation[i] = 0.3 + 0.05 * (i % 7);
  CohesionConfig c;
  c.evaluation = "exact";  // eq. (10) summed over every neighbour: the analytic answers
  computeDisplayCohesion(a.model, c, &a.state);
  computeDisplayCohesion(b.model, c, &b.state);
  for (int i = 0; i < a.model.particleCount(); ++i)
    EXPECT_LT((b.state.wet_position[i] - shift - a.state.wet_position[i]).norm(), 1e-12) << i;
}

namespace {

/// A wet curly head of hair after 0.2 s of falling from the rest groom (theta integrator, the
/// runner's `--integrator theta --substep 0.0333`), saturation 0.4 at the root to 1 at the tip.
struct WetScene {
  HairModel model;
  HairState state;
  SolverConfig solver;
  explicit WetScene(int strands, int cells_per_radius = 4, int particles = 0) {
    io::SceneConfig scene;
    scene.groom.strands = strands;
    if (particles > 0) scene.groom.particles = particles;
    scene.solver.integrator.method = "theta";
    scene.solver.integrator.substep_s = 0.0333;
    scene.solver.cohesion.evaluation = "grid";
    scene.solver.cohesion.grid_cells_per_radius = cells_per_radius;
    std::string why;
    EXPECT_TRUE(io::buildSceneModel(scene, &model, &why)) << why;
    solver = scene.solver;
    state = makeState(model, Pose(), Twist());
    for (int s = 0; s < model.strandCount(); ++s)
      for (int k = 0; k < model.strandSize(s); ++k)
        state.saturation[model.strandBegin(s) + k] = 0.4 + 0.6 * k / (model.strandSize(s) - 1);
    StepInputs inputs;
    for (int k = 0; k < 6; ++k) step(model, solver, inputs, 1.0 / 30.0, &state, nullptr);
  }
};

/// The display pass's per-particle scratch of the first `particles` entries set to NaN (the
/// float arrays' padding past them stays zero, as the lanes need it): an entry read in a call
/// that did not write it (a particle no thread stored) shows as a non-finite or different p^w.
void poisonDisplayScratch(int particles, HairState* s) {
  CohesionNodeGrid& g = s->cohesion_grid;
  for (std::vector<double>* v : {&g.volume, &g.wet_share, &g.rx, &g.ry, &g.rz, &s->density})
    std::fill_n(v->begin(), std::min<size_t>(v->size(), particles),
                std::numeric_limits<double>::quiet_NaN());
  for (std::vector<float>* v :
       {&g.kx_f, &g.ky_f, &g.kz_f, &g.tx_f, &g.ty_f, &g.tz_f, &g.volume_f, &g.wet_share_f,
        &g.own_weight_f, &g.own_px_f, &g.own_py_f, &g.own_pz_f})
    std::fill_n(v->begin(), std::min<size_t>(v->size(), particles),
                std::numeric_limits<float>::quiet_NaN());
}

struct Discrepancy {
  double rms_m = 0.0, max_m = 0.0;            ///< |p^w_grid - p^w_exact|
  double rms_disp_m = 0.0, max_disp_m = 0.0;  ///< |p^w_exact - p|
  int count = 0;
};

Discrepancy compare(const HairState& exact, const HairState& grid) {
  Discrepancy d;
  double e2 = 0.0, d2 = 0.0;
  for (size_t i = 0; i < exact.position.size(); ++i) {
    if (exact.saturation[i] <= 0.0) continue;
    const double e = (grid.wet_position[i] - exact.wet_position[i]).norm();
    const double disp = (exact.wet_position[i] - exact.position[i]).norm();
    e2 += e * e;
    d2 += disp * disp;
    d.max_m = std::max(d.max_m, e);
    d.max_disp_m = std::max(d.max_disp_m, disp);
    ++d.count;
  }
  d.rms_m = std::sqrt(e2 / std::max(d.count, 1));
  d.rms_disp_m = std::sqrt(d2 / std::max(d.count, 1));
  return d;
}

}  // namespace

TEST(CohesionGrid, MatchesExactOnAWetCurlyScene) {
  // Measured (docs/physics.md §7.3), 300 strands x 32 particles, h = 4 cm, lumped masses (the
  // tips weigh half an interior particle), RMS displacement |p^w - p| 3.47 mm (max 12.0 mm):
  // |p^w_grid - p^w_exact| RMS / RMS displacement and max, at 4 nodes per radius 0.038 and
  // 1.13 mm, at 3 0.091 and 2.29 mm, at 2 0.32 and 6.45 mm. Bounds: those with about 30 %
  // margin.
  struct Case {
    int cells;
    double rms_rel, max_mm;
  };
  for (const Case& k : {Case{4, 0.05, 1.5}, Case{3, 0.12, 3.0}, Case{2, 0.42, 8.4}}) {
    WetScene scene(300, k.cells);
    ASSERT_GT(scene.model.cohesion_grid_nodes, 0u);
    HairState exact = scene.state, grid = scene.state;
    CohesionConfig c = scene.solver.cohesion;
    c.evaluation = "exact";
    const int n_exact = computeDisplayCohesion(scene.model, c, &exact);
    c.evaluation = "grid";
    const int n_grid = computeDisplayCohesion(scene.model, c, &grid);
    EXPECT_EQ(grid.warnings.cohesion_grid_fallbacks, 0u);
    const Discrepancy d = compare(exact, grid);
    std::printf(
        "cells %d: exact %d grid %d clumped; |p^w_grid - p^w_exact| RMS %.4f mm max %.4f mm;"
        " |p^w - p| RMS %.4f mm max %.4f mm; RMS ratio %.4f, max ratio %.4f\n",
        k.cells, n_exact, n_grid, 1e3 * d.rms_m, 1e3 * d.max_m, 1e3 * d.rms_disp_m,
        1e3 * d.max_disp_m, d.rms_m / d.rms_disp_m, d.max_m / d.max_disp_m);
    if (k.rms_rel > 0.0) {
      EXPECT_LT(d.rms_m / d.rms_disp_m, k.rms_rel) << k.cells;
      EXPECT_LT(1e3 * d.max_m, k.max_mm) << k.cells;
    }
    // The simulated positions are untouched.
    for (size_t i = 0; i < grid.position.size(); ++i)
      ASSERT_EQ(grid.position[i], scene.state.position[i]);
  }
}

TEST(CohesionGrid, SumsConvolvedAtTheNodesOneNodeFinerBeatTheGathersAgainstExact) {
  // grid_wet_sums "nodes": the splatted sums convolved at the nodes and interpolated to the
  // particle, two interpolations where the gathers have one, so at the same lattice their error
  // is larger (measured, 300 strands, RMS / RMS displacement and max: 0.145 and 2.98 mm at 3
  // nodes per radius against the gathers' 0.093 and 2.43 mm; 0.070 and 1.59 mm at 4 against
  // 0.038 and 1.14 mm). One node per radius finer they are closer to exact than the gathers,
  // from 2 and from 3, in RMS and in max. Reference: exact.
  for (int cells : {2, 3}) {
    WetScene coarse(300, cells), fine(300, cells + 1);
    HairState exact = coarse.state, gathers = coarse.state, nodes = fine.state;
    CohesionConfig c = coarse.solver.cohesion;
    c.grid_wet_sums = "particles";
    c.evaluation = "exact";
    computeDisplayCohesion(coarse.model, c, &exact);
    c.evaluation = "grid";
    computeDisplayCohesion(coarse.model, c, &gathers);
    CohesionConfig c_fine = fine.solver.cohesion;
    c_fine.grid_wet_sums = "nodes";
    const int n_nodes = computeDisplayCohesion(fine.model, c_fine, &nodes);
    EXPECT_EQ(nodes.warnings.cohesion_grid_fallbacks, 0u);
    for (size_t i = 0; i < nodes.position.size(); ++i)  // the same dynamics in both scenes
      ASSERT_EQ(nodes.position[i], exact.position[i]);
    const Discrepancy dg = compare(exact, gathers), dn = compare(exact, nodes);
    std::printf(
        "%d clumped; |p^w - p^w_exact| RMS / RMS displacement, max: gathers at %d %.4f, %.4f mm; "
        "nodes at %d %.4f, %.4f mm\n",
        n_nodes, cells, dg.rms_m / dg.rms_disp_m, 1e3 * dg.max_m, cells + 1,
        dn.rms_m / dn.rms_disp_m, 1e3 * dn.max_m);
    EXPECT_GT(n_nodes, 9000);
    EXPECT_LT(dn.rms_m, dg.rms_m) << cells;
    EXPECT_LT(dn.max_m, dg.max_m) << cells;
    for (size_t i = 0; i < nodes.position.size(); ++i)
      ASSERT_EQ(nodes.position[i], fine.state.position[i]) << "the display pass moved hair";
  }
}

TEST(CohesionGrid, RestParticlesPerCellCountsTheOccupiedCells) {
  // Two strands of 5 particles 1 mm apart in one 1 cm cell (h = 4 cm at 4 nodes per radius): 10
  // particles in 1 cell; the same strands with their particles 2 cm apart: 10 cells.
  SolverConfig sc;
  const HairModel packed = strandsModel(2, 5, sc, [](int s, int i) -> Vec3 {
    return Vec3(0.002 + 0.001 * s, 0.002, -0.002 - 0.001 * i);
  });
  const HairModel spread = strandsModel(2, 5, sc, [](int s, int i) -> Vec3 {
    return Vec3(0.005 + 0.02 * s, 0.005, -0.005 - 0.02 * i);
  });
  EXPECT_DOUBLE_EQ(restParticlesPerCell(packed, 0.04, 4), 10.0);
  EXPECT_DOUBLE_EQ(restParticlesPerCell(spread, 0.04, 4), 1.0);
}

TEST(CohesionGrid, AutoTakesTheNodeSumsWhereTheHairIsDense) {
  // grid_wet_sums "auto": 400 strands of 10 particles packed 1 mm apart hold far more than
  // kNodeSumsParticlesPerCell particles per 1.33 cm cell; three strands 6 mm and 30 cm apart hold
  // about 1.
  SolverConfig sc;
  sc.cohesion.evaluation = "grid";
  sc.cohesion.grid_wet_sums = "auto";
  auto packed = [](int s, int i) -> Vec3 {
    return Vec3(0.001 * (s % 20), 0.001 * (s / 20), -0.008 * i);
  };
  const HairModel dense = strandsModel(400, 10, sc, packed);
  const HairModel sparse = strandsModel(3, 10, sc, [](int s, int i) -> Vec3 {
    return (s == 2 ? Vec3(0.3, 0, 0) : Vec3(s * 0.006, 0, 0)) + Vec3(0, 0, -0.008 * i);
  });
  EXPECT_EQ(dense.cohesion_rest_density_cells, 3);
  EXPECT_GT(dense.cohesion_rest_particles_per_cell, kNodeSumsParticlesPerCell);
  EXPECT_LT(sparse.cohesion_rest_particles_per_cell, kNodeSumsParticlesPerCell);
  const CohesionLattice on_dense = cohesionLattice(dense, sc.cohesion);
  EXPECT_TRUE(on_dense.node_sums);
  EXPECT_EQ(on_dense.cells_per_radius, 3);
  const CohesionLattice on_sparse = cohesionLattice(sparse, sc.cohesion);
  EXPECT_FALSE(on_sparse.node_sums);
  EXPECT_EQ(on_sparse.cells_per_radius, 3);
  // The gathers at every other lattice (the threshold is the crossover measured at 3), and with
  // the node volumes.
  for (int cells : {2, 4}) {
    SolverConfig other = sc;
    other.cohesion.grid_cells_per_radius = cells;
    const HairModel dense_other = strandsModel(400, 10, other, packed);
    EXPECT_GT(dense_other.cohesion_rest_particles_per_cell, kNodeSumsParticlesPerCell) << cells;
    EXPECT_FALSE(cohesionLattice(dense_other, other.cohesion).node_sums) << cells;
  }
  CohesionConfig c = sc.cohesion;
  c.grid_cells_per_radius = 4;
  EXPECT_FALSE(cohesionLattice(dense, c).node_sums) << "the density was measured at 3, not 4";
  c = sc.cohesion;
  c.grid_node_volumes = true;
  EXPECT_FALSE(cohesionLattice(dense, c).node_sums);
  // On the dense hair, wet, "auto" is the node sums at 3 to the bit.
  HairState a = makeState(dense, Pose(), Twist());
  std::fill(a.saturation.begin(), a.saturation.end(), 1.0);
  HairState b = a;
  const int n_auto = computeDisplayCohesion(dense, sc.cohesion, &a, 2);
  c = sc.cohesion;
  c.grid_wet_sums = "nodes";
  const int n_nodes = computeDisplayCohesion(dense, c, &b, 2);
  EXPECT_GT(n_auto, 0);
  EXPECT_EQ(n_auto, n_nodes);
  EXPECT_EQ(a.warnings.cohesion_grid_fallbacks + b.warnings.cohesion_grid_fallbacks, 0u);
  for (int i = 0; i < dense.particleCount(); ++i) ASSERT_EQ(a.wet_position[i], b.wet_position[i]);
}

TEST(CohesionGrid, AutoOnADenseGroomMeetsTheBudgetsAgainstExact) {
  // The budgets the defaults are chosen by (docs/bench/defaults.txt, bench_summary.py): the
  // output positions within 1 % of the strand length RMS of exact's and within a fifth of its
  // RMS displacement (1 % of 25 cm is about the whole displacement here, so the first alone
  // barely holds the display pass), and the clump distance within 1 % of exact's. 1,000 strands
  // hold 5.6 particles per cell at 3 nodes per radius, so "auto" takes the node sums there
  // (measured here: 0.13 % of the length, 0.14 of the displacement, the clump distance 0.08 %
  // from exact's; with the own strand's pull not subtracted 0.25 %, 0.26 and 0.47 %: only the
  // fifth fails).
  WetScene scene(1000, 3);
  ASSERT_TRUE(cohesionLattice(scene.model, scene.solver.cohesion).node_sums);
  HairState exact = scene.state, autos = scene.state;
  CohesionConfig c = scene.solver.cohesion;
  c.evaluation = "exact";
  computeDisplayCohesion(scene.model, c, &exact, 2);
  const int n_auto = computeDisplayCohesion(scene.model, scene.solver.cohesion, &autos, 2);
  EXPECT_GT(n_auto, 25000);
  const Discrepancy d = compare(exact, autos);
  double length = 0.0;
  for (double l : scene.model.strand_length_m) length += l / scene.model.strandCount();
  MetricScratch scratch;
  const double search_m = 0.05;
  const double clump_exact =
      clumpDistance(scene.model, exact.wet_position, exact.saturation, search_m, &scratch, 2);
  const double clump_auto =
      clumpDistance(scene.model, autos.wet_position, autos.saturation, search_m, &scratch, 2);
  std::printf(
      "auto: |p^w - p^w_exact| RMS %.4f mm (%.3f %% of the mean length %.1f mm), RMS "
      "displacement %.4f mm; clump distance %.4f against exact's %.4f mm\n",
      1e3 * d.rms_m, 100.0 * d.rms_m / length, 1e3 * length, 1e3 * d.rms_disp_m, 1e3 * clump_auto,
      1e3 * clump_exact);
  EXPECT_LT(d.rms_m, 0.01 * length);
  EXPECT_NEAR(clump_auto, clump_exact, 0.01 * clump_exact);
  EXPECT_LT(d.rms_m, 0.2 * d.rms_disp_m);
}

TEST(CohesionGrid, NodeVolumesMatchExactWithinAFifthOfTheDisplacement) {
  // The volume of a particle's share of node n, m / rho(x_n) instead of m / rho(p), differs from
  // it by the density's change over a cell: the same order as the lattice's own error, which
  // the particle volumes leave. Bounds: the lattice's error below a fifth of the displacement it
  // approximates (RMS), and at most twice the particle volumes' in RMS and max. Measured
  // (300 strands): RMS / displacement 0.059 against 0.038 at 4 nodes per radius, 0.120 against
  // 0.093 at 3; max 1.28 against 1.14 mm and 2.28 against 2.43 mm.
  for (int cells : {4, 3}) {
    WetScene scene(300, cells);
    HairState exact = scene.state, particle = scene.state, node = scene.state;
    CohesionConfig c = scene.solver.cohesion;
    c.evaluation = "exact";
    computeDisplayCohesion(scene.model, c, &exact);
    c.evaluation = "grid";
    computeDisplayCohesion(scene.model, c, &particle);
    c.grid_node_volumes = true;
    computeDisplayCohesion(scene.model, c, &node);
    EXPECT_EQ(node.warnings.cohesion_grid_fallbacks, 0u);
    const Discrepancy dp = compare(exact, particle), dn = compare(exact, node);
    std::printf(
        "cells %d: |p^w_grid - p^w_exact| RMS / RMS displacement, max: particle volumes %.4f, "
        "%.4f mm; node volumes %.4f, %.4f mm\n",
        cells, dp.rms_m / dp.rms_disp_m, 1e3 * dp.max_m, dn.rms_m / dn.rms_disp_m, 1e3 * dn.max_m);
    EXPECT_LT(dn.rms_m, 0.2 * dn.rms_disp_m) << cells;
    EXPECT_LT(dn.rms_m, 2.0 * dp.rms_m) << cells;
    EXPECT_LT(dn.max_m, 2.0 * dp.max_m) << cells;
    EXPECT_NE(dn.rms_m, dp.rms_m) << "the node volumes were not used";
  }
}

TEST(CohesionGrid, SinglePrecisionMatchesDoubleFarBelowTheLatticeError) {
  // The float lattice (gathers and own-strand shares) against the double one, with and without the
  // particle's own weight (without it the Shepard denominator is the other-strand weight
  // alone, where round-off would show first), at 4 nodes per radius and at 3 (with AVX-512 the
  // float gathers pack two rows per register at both: rows of 8 nodes, and of 6 padded to 8).
  // The lattice's own error at 4 is 0.130 mm RMS and 1.44 mm max (MatchesExactOnAWetCurlyScene),
  // larger at 3; float round-off is ~1e-7 of the sums.
  for (const auto& [cells, include_self] :
       {std::pair{4, true}, std::pair{4, false}, std::pair{3, true}, std::pair{3, false}}) {
    WetScene scene(300, cells);
    HairState single = scene.state, twice = scene.state;
    CohesionConfig c = scene.solver.cohesion;
    c.include_self = include_self;
    c.grid_single_precision = true;
    const int n_single = computeDisplayCohesion(scene.model, c, &single, 2);
    c.grid_single_precision = false;
    const int n_double = computeDisplayCohesion(scene.model, c, &twice, 2);
    const Discrepancy d = compare(twice, single);
    std::printf(
        "cells %d include_self %d: single %d double %d clumped; |p^w_single - p^w_double| RMS "
        "%.3g um, max %.3g um\n",
        cells, include_self, n_single, n_double, 1e6 * d.rms_m, 1e6 * d.max_m);
    EXPECT_EQ(n_single, n_double);
    // At most 1 % of the lattice's own error at 4 nodes per radius (measured with the gathers and
    // the own-strand sums in float, at 4: include_self 0.001 / 0.010 um RMS / max, without it
    // 0.023 / 1.5 um; at 3: 0.001 / 0.012 and 0.060 / 3.9 um; earlier at 4: 1.0 um max, and
    // 0.037 / 2.95 um with the double fallback removed; with only the gathers in float, 0.034 /
    // 2.3 um, and 0.34 / 33 um without the fallback, where the max bound failed). On an AVX2
    // build (one row per 8-float vector at 3) the fallback below 1e-3 of the own weight let 16.7
    // um through without the own weight, and failed here; below 1e-2, 0.61 um. With the sums'
    // positions from one reference node (larger terms in float), on the first-generation EPYC:
    // at 4, 0.011 / 0.098 um and 0.033 / 1.5 um; at 3, 0.010 / 0.084 and 0.027 / 1.0 um.
    EXPECT_LT(d.rms_m, 0.01 * 0.130e-3) << include_self;
    EXPECT_LT(d.max_m, 0.01 * 1.44e-3) << include_self;
  }
}

TEST(CohesionGrid, ALoneParticlesDensityIsTheTwiceCorrectedKernelOverItsCell) {
  // The densities are convolved at the nodes and interpolated to the particles: a particle alone
  // within reach sees only itself, through two trilinear interpolations (its splat and the
  // interpolation), whose mean bias the nodes cancel with K = W - (c^2 / 6) lap W (none at 2
  // nodes per radius). W = q^3, q = h^2 - r^2, so lap W = -42 q^2 + 24 h^2 q. The strand's root
  // sits at the box's top, in x and y on a node, and 0.3 m = 22.5 c (at 3 nodes per radius)
  // above its tip, which sits on a node: the root's density mixes K at 0 and at c, half each.
  for (int cells : {2, 3, 4}) {
    SolverConfig sc;
    sc.cohesion.evaluation = "grid";
    sc.cohesion.grid_cells_per_radius = cells;
    Groom g;
    g.points = {Vec3(0, 0, 0), Vec3(0, 0, -0.3)};
    g.strand_offsets.push_back(2);
    g.root_normals = {Vec3(0, 0, -1)};
    HairModel model;
    std::string why;
    ASSERT_TRUE(buildModel(g, GroomConfig().linear_density_kg_per_m, HeadShape(), sc, &model, &why))
        << why;
    HairState state = makeState(model, Pose(), Twist());
    std::fill(state.saturation.begin(), state.saturation.end(), 1.0);
    computeDisplayCohesion(model, sc.cohesion, &state);
    ASSERT_EQ(state.warnings.cohesion_grid_fallbacks, 0u);
    const double h = sc.cohesion.radius_m, h2 = h * h, c = h / cells;
    auto kernel = [&](double r) {
      const double q = h2 - r * r;
      const double laplacian = -42.0 * q * q + 24.0 * h2 * q;
      return q * q * q - (cells >= 3 ? c * c / 6.0 : 0.0) * laplacian;
    };
    const double norm = 315.0 / (64.0 * M_PI * std::pow(h, 9));
    const double tz = std::fmod(0.3 / c, 1.0);  // the root's fraction above its cell's floor
    const double expected_root =
        norm * model.mass_kg[0] *
        ((tz * tz + (1 - tz) * (1 - tz)) * kernel(0.0) + 2.0 * tz * (1 - tz) * kernel(c));
    EXPECT_NEAR(state.density[1], norm * model.mass_kg[1] * kernel(0.0), 1e-9 * state.density[1])
        << cells;
    EXPECT_NEAR(state.density[0], expected_root, 1e-9 * expected_root) << cells;
  }
}

TEST(CohesionGrid, EvaluatesItsFunctionalExactlyInDouble) {
  // The lattice replaces W(|p_i - p_j|) by W~_ij = sum_n t_jn K(|p_i - x_n|) over the 8 nodes of
  // p_j's cell, K = W - (c^2 / 12) lap W (docs/physics.md §7.3); splat and gathers only reorder
  // the sums. Evaluated here directly, particle by particle, from the lattice's own volumes V_j
  // (state.cohesion_grid.volume) and its nodes (origin: the particles' lowest corner less
  // cells + 2 nodes, as computeDisplayCohesionGrid places it): eq. (10)'s p^w from the other
  // strands' V_j W~_ij and V_j sigma_j W~_ij (p_j - p_i) must match the lattice's in double to
  // round-off, whatever node the lattice takes the positions of its sums from.
  SolverConfig sc;
  sc.cohesion.evaluation = "grid";
  sc.cohesion.grid_single_precision = false;
  sc.cohesion.include_self = false;
  const HairModel model = strandsModel(3, 12, sc, [](int s, int i) -> Vec3 {  // wavy, 5 mm apart
    return Vec3(0.005 * s + 0.002 * std::sin(i + s), 0.001 * s * std::cos(0.7 * i), -0.0071 * i);
  });
  ASSERT_EQ(model.particleCount(), 36);
  HairState state = makeState(model, Pose(), Twist());
  for (int i = 0; i < model.particleCount(); ++i) state.saturation[i] = 0.3 + 0.05 * (i % 13);
  ASSERT_EQ(computeDisplayCohesion(model, sc.cohesion, &state), model.particleCount());
  ASSERT_EQ(state.warnings.cohesion_grid_fallbacks, 0u);
  const int cells = sc.cohesion.grid_cells_per_radius;
  const double h = sc.cohesion.radius_m, h2 = h * h, c = h / cells;
  Vec3 lo = state.position[0];
  for (const Vec3& p : state.position) lo = lo.cwiseMin(p);
  const Vec3 origin = lo - Vec3::Constant((cells + 2) * c);
  auto node_kernel = [&](double r2) {
    const double q = h2 - r2;
    return q > 0.0 ? q * q * q + 3.5 * c * c * q * q - 2.0 * c * c * h2 * q : 0.0;
  };
  double worst = 0.0, largest_offset = 0.0;
  for (int i = 0; i < model.particleCount(); ++i) {
    const Vec3& pi = state.position[i];
    double weight = 0.0;
    Vec3 pull = Vec3::Zero();
    for (int j = 0; j < model.particleCount(); ++j) {
      if (state.grid.strand_of[j] == state.grid.strand_of[i]) continue;
      const Vec3 u = (state.position[j] - origin) / c;
      const Vec3 k = u.array().floor().matrix(), t = u - k;
      double w = 0.0;  // W~_ij
      for (int corner = 0; corner < 8; ++corner) {
        const Vec3 a((corner & 1) ? 1.0 : 0.0, (corner & 2) ? 1.0 : 0.0, (corner & 4) ? 1.0 : 0.0);
        const Vec3 share = a.cwiseProduct(t) + (Vec3::Ones() - a).cwiseProduct(Vec3::Ones() - t);
        w += share.prod() * node_kernel((origin + c * (k + a) - pi).squaredNorm());
      }
      const double v = state.cohesion_grid.volume[j];
      weight += v * w;
      pull += v * state.saturation[j] * w * (state.position[j] - pi);
    }
    ASSERT_GT(weight, 0.0) << i;
    const Vec3 offset = clumpOffset(pull, weight, sc.cohesion.tightness);
    worst = std::max(worst, (state.wet_position[i] - (pi + offset)).norm());
    largest_offset = std::max(largest_offset, offset.norm());
  }
  std::printf(
      "lattice against its functional evaluated directly: max %.3g m, offsets up to %.3g m\n",
      worst, largest_offset);
  EXPECT_GT(largest_offset, 1e-4) << "no clumping: the test proves nothing";
  EXPECT_LT(worst, 1e-12);
}

namespace {

void dryHairAndIsolatedStrand(bool node_volumes, const char* wet_sums) {
  SolverConfig sc;
  sc.cohesion.evaluation = "grid";
  sc.cohesion.grid_node_volumes = node_volumes;
  sc.cohesion.grid_wet_sums = wet_sums;
  // Two strands 6 mm apart and a third 30 cm away.
  const HairModel model = strandsModel(3, 10, sc, [](int s, int i) -> Vec3 {
    return (s == 2 ? Vec3(0.3, 0, 0) : Vec3(s * 0.006, 0, 0)) + Vec3(0, 0, -0.008 * i);
  });
  ASSERT_EQ(model.particleCount(), 30);
  ASSERT_GT(model.cohesion_grid_nodes, 0u);
  HairState state = makeState(model, Pose(), Twist());
  EXPECT_EQ(computeDisplayCohesion(model, sc.cohesion, &state), 0) << "dry";
  for (int i = 0; i < model.particleCount(); ++i)
    EXPECT_EQ(state.wet_position[i], state.position[i]);
  std::fill(state.saturation.begin(), state.saturation.end(), 1.0);
  EXPECT_EQ(computeDisplayCohesion(model, sc.cohesion, &state), 20);
  EXPECT_EQ(state.warnings.cohesion_grid_fallbacks, 0u);
  for (int i = 0; i < 10; ++i) {
    EXPECT_GT(state.wet_position[i].x(), state.position[i].x()) << "pulled toward strand 1";
    EXPECT_EQ(state.wet_position[20 + i], state.position[20 + i]) << "isolated strand";
  }
  // A dry strand keeps p^w = p even next to a wet one.
  for (int i = 10; i < 20; ++i) state.saturation[i] = 0.0;
  computeDisplayCohesion(model, sc.cohesion, &state);
  for (int i = 10; i < 30; ++i) EXPECT_EQ(state.wet_position[i], state.position[i]) << i;
}

}  // namespace

TEST(CohesionGrid, DryHairAndIsolatedStrandAreUntouched) {
  // With node volumes too: the own strand's share then weights each corner by m / rho_n, as
  // the splat did, or the isolated strand would keep a remainder of its own sums.
  // With the sums convolved at the nodes, the isolated strand's particles have no other strand
  // to outweigh their own: the own share goes through the lattice's functional, and cancels.
  for (bool node_volumes : {false, true}) {
    SCOPED_TRACE(node_volumes ? "node volumes" : "particle volumes");
    dryHairAndIsolatedStrand(node_volumes, "particles");
  }
  SCOPED_TRACE("sums convolved at the nodes");
  dryHairAndIsolatedStrand(false, "nodes");
}

TEST(CohesionGrid, IsTranslationInvariantAndThreadIndependent) {
  const Vec3 shift(12.3, -4.5, 6.7);
  struct Case {
    bool single, node_volumes;
    const char* wet_sums;
  };
  for (const Case& k : {Case{false, false, "particles"}, Case{true, false, "particles"},
                        Case{false, true, "particles"}, Case{true, true, "particles"},
                        Case{true, false, "nodes"}}) {
    const bool single = k.single;
    SCOPED_TRACE(k.node_volumes ? "node volumes" : "particle volumes");
    SCOPED_TRACE(k.wet_sums);
    WetScene a(120);
    CohesionConfig c = a.solver.cohesion;
    ASSERT_EQ(c.evaluation, "grid");
    c.grid_single_precision = single;
    c.grid_node_volumes = k.node_volumes;
    c.grid_wet_sums = k.wet_sums;
    HairState b = a.state;
    for (Vec3& x : b.position) x += shift;
    HairState a1 = a.state, a2 = a.state, a3 = a.state, a5 = a.state;
    // The steps left the scratch of an evaluation at these very positions: poisoned, every
    // thread count must write what it reads (the splat's owning visits store each particle's).
    for (HairState* s : {&a1, &a2, &a3, &a5, &b}) poisonDisplayScratch(a.model.particleCount(), s);
    const int n1 = computeDisplayCohesion(a.model, c, &a1, 1);
    const int n2 = computeDisplayCohesion(a.model, c, &a2, 2);
    // 3 and 5 threads: the splat's halves get unequal teams, and a team of more than one
    // splits its half's node layers.
    computeDisplayCohesion(a.model, c, &a3, 3);
    computeDisplayCohesion(a.model, c, &a5, 5);
    computeDisplayCohesion(a.model, c, &b, 2);
    EXPECT_GT(n1, 0);
    EXPECT_EQ(n1, n2);
    double worst = 0.0;
    for (int i = 0; i < a.model.particleCount(); ++i) {
      ASSERT_TRUE(a1.wet_position[i].allFinite()) << "particle " << i;
      ASSERT_EQ(a1.wet_position[i], a2.wet_position[i]) << "1 vs 2 threads, particle " << i;
      ASSERT_EQ(a1.wet_position[i], a3.wet_position[i]) << "1 vs 3 threads, particle " << i;
      ASSERT_EQ(a1.wet_position[i], a5.wet_position[i]) << "1 vs 5 threads, particle " << i;
      worst = std::max(worst, ((b.wet_position[i] - shift) - a1.wet_position[i]).norm());
    }
    std::printf("single %d: worst |p^w(shifted) - shift - p^w| %.3g m\n", single, worst);
    // Double: round-off of coordinates ~15 m from the origin (1e-15 relative; measured
    // 1.2e-15 m). Float: that round-off can flip the rounding of a float copy (relative 6e-8)
    // of a node sum or of a particle's fraction in its cell, amplified by the own-strand
    // cancellation (measured 2.4e-9 m with the own-strand sums in float, 2.1e-10 m with only
    // the gathers in float; the whole float-vs-double difference is bounded in
    // SinglePrecisionMatchesDoubleFarBelowTheLatticeError).
    EXPECT_LT(worst, single ? 1e-8 : 1e-12);
    EXPECT_EQ(a1.warnings.cohesion_grid_fallbacks + b.warnings.cohesion_grid_fallbacks, 0u);
  }
}

// The solver repairs non-finite strands before the display pass; a caller of the core API may
// not. A NaN coordinate anywhere (not only at the first particle, whose box once carried it)
// refuses the lattice instead of indexing it; so does an infinite one. The box is taken 8
// particles at a time: the last particle, past the last 8 of a share of 40 x 31 / 2 particles,
// is checked too.
TEST(CohesionGrid, ANonFinitePositionRefusesTheLattice) {
  for (double value : {double(NAN), double(INFINITY), -double(INFINITY)}) {
    for (int bad : {0, 37, -1}) {
      WetScene a(40, 4, 31);
      HairState grid = a.state;
      const int at = bad >= 0 ? bad : a.model.particleCount() - 1;
      grid.position[at].y() = value;
      computeDisplayCohesion(a.model, a.solver.cohesion, &grid, 2);
      EXPECT_EQ(grid.warnings.cohesion_grid_fallbacks, 1u) << value << " at particle " << at;
    }
  }
}

TEST(CohesionGrid, FallsBackToExactWhenTheLatticeIsTooSmall) {
  WetScene a(40);
  HairState exact = a.state, grid = a.state;
  CohesionConfig c = a.solver.cohesion;
  c.radius_m = 0.004;  // ten times the nodes per axis the lattice was sized for
  computeDisplayCohesion(a.model, c, &grid);
  EXPECT_EQ(grid.warnings.cohesion_grid_fallbacks, 1u);
  c.evaluation = "exact";
  computeDisplayCohesion(a.model, c, &exact);
  for (int i = 0; i < a.model.particleCount(); ++i)
    ASSERT_EQ(grid.wet_position[i], exact.wet_position[i]);
  std::string why;
  c.evaluation = "lattice";
  EXPECT_FALSE(c.validate("solver.cohesion.", &why));
  EXPECT_NE(why.find("solver.cohesion.evaluation"), std::string::npos) << why;
  c.evaluation = "grid";
  c.grid_cells_per_radius = 0;
  EXPECT_FALSE(c.validate("solver.cohesion.", &why));
  EXPECT_NE(why.find("solver.cohesion.grid_cells_per_radius"), std::string::npos) << why;
  c.grid_cells_per_radius = 3;
  c.gather_at = "followers";
  EXPECT_FALSE(c.validate("solver.cohesion.", &why));
  EXPECT_NE(why.find("solver.cohesion.gather_at"), std::string::npos) << why;
  c.gather_at = "all";
  c.refresh_period_s = -0.1;
  EXPECT_FALSE(c.validate("solver.cohesion.", &why));
  EXPECT_NE(why.find("solver.cohesion.refresh_period_s"), std::string::npos) << why;
}

TEST(Cohesion, BaselineForcesPullWetStrandsTogetherAndConserveMomentum) {
  for (const char* mode : {"lin", "kim"}) {
    Fixture f(0.01);
    std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
    CohesionConfig c;
    c.mode = mode;
    EXPECT_GT(computeCohesionForces(f.model, c, &f.state), 0) << mode;
    Vec3 total = Vec3::Zero();
    for (const Vec3& x : f.state.external_force) total += x;
    EXPECT_LT(total.norm(), 1e-12) << mode;
    EXPECT_GT(f.state.external_force[5].x(), 0.0) << mode << ": strand 0 pulled toward strand 1";
    EXPECT_EQ(f.state.external_force[25], Vec3::Zero()) << mode << ": isolated strand feels none";
  }
}

TEST(Metrics, ClumpDistanceTanglesAndCurlShape) {
  Fixture f(0.004);
  std::fill(f.state.saturation.begin(), f.state.saturation.end(), 1.0);
  MetricScratch grid;
  // Strands 0 and 1 are 4 mm apart; strand 2 is isolated and counts as the search radius.
  EXPECT_NEAR(clumpDistance(f.model, f.state.position, f.state.saturation, 0.02, &grid),
              (20 * 0.004 + 10 * 0.02) / 30.0, 1e-12);
  EXPECT_EQ(tangleCount(f.model, f.state.position, 0.0005, &grid), 0);
  // 4.2 mm contact: each of the 9 segment pairs side by side, and the 2 x 8 pairs offset by one
  // edge (they share an end height, so they are 4 mm apart too).
  EXPECT_EQ(tangleCount(f.model, f.state.position, 0.0021, &grid), 25);
  EXPECT_NEAR(segmentDistance(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 1, 1), Vec3(0.5, -1, 1)), 1.0,
              1e-15);
  // Curl shape of a generated helix comes back.
  Groom g;
  const Vec3List h = makeHelix(60, 0.006, 0.01, 0.03);
  g.points = h;
  g.strand_offsets = {0, 60};
  g.root_normals = {Vec3::UnitZ()};
  HairModel m;
  SolverConfig c;
  std::string why;
  ASSERT_TRUE(buildModel(g, GroomConfig().linear_density_kg_per_m, HeadShape(), c, &m, &why))
      << why;
  const CurlShape shape = tipCurlShape(m, h);
  EXPECT_NEAR(shape.radius_m, 0.01, 0.0005);
  EXPECT_NEAR(shape.pitch_m, 0.03, 0.0015);
}
