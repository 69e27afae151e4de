#include "wet_curly_hair/core/cohesion.h"

#include <cmath>
#include <cstdint>

#include "display_write.h"
#include "parallel.h"
#include "wet_curly_hair/core/cohesion_grid.h"
#include "wet_curly_hair/core/followers.h"
#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {

using detail::parallelFor;
using detail::parallelRegion;
using detail::parallelSum;
using detail::Schedule;

void buildNeighborGrid(const Vec3List& positions, double cell_m, NeighborGrid* grid, int threads) {
  grid->cell_m = cell_m;
  const uint32_t table = static_cast<uint32_t>(grid->cell_start.size() - 1);
  const uint32_t mask = table - 1;
  std::fill(grid->cell_start.begin(), grid->cell_start.end(), 0u);
  const int64_t n = static_cast<int64_t>(positions.size());
  // Hashing in parallel; the counting sort (a count, a prefix sum and a scatter: three plain
  // passes) stays serial so the order within a cell (and so every sum over neighbours) is the
  // same for any thread count.
  parallelFor(threads, Schedule::kStatic, 0, int64_t(n), [&](int64_t i) {
    const Vec3& x = positions[i];
    grid->cell_of[i] =
        detail::cellHash(detail::cellCoord(x.x(), cell_m), detail::cellCoord(x.y(), cell_m),
                         detail::cellCoord(x.z(), cell_m), mask);
  });
  for (int64_t i = 0; i < n; ++i) ++grid->cell_start[grid->cell_of[i] + 1];
  for (uint32_t c = 0; c < table; ++c) grid->cell_start[c + 1] += grid->cell_start[c];
  // Counting sort; cell_start[c] is used as the running cursor, then shifted back.
  for (int64_t i = 0; i < n; ++i)
    grid->sorted[grid->cell_start[grid->cell_of[i]]++] = static_cast<uint32_t>(i);
  for (uint32_t c = table; c > 0; --c) grid->cell_start[c] = grid->cell_start[c - 1];
  grid->cell_start[0] = 0;
  // Within each bucket, order the entries by cell key (then particle index): each cell becomes
  // one contiguous run. Buckets hold a few entries: insertion sort, deterministic; buckets are
  // independent, so keys and sorts run in parallel (the result is the same for any thread count).
  parallelFor(threads, Schedule::kStatic, 0, int64_t(n), [&](int64_t k) {
    const Vec3& x = positions[grid->sorted[k]];
    grid->sorted_key[k] =
        detail::cellKey(detail::cellCoord(x.x(), cell_m), detail::cellCoord(x.y(), cell_m),
                        detail::cellCoord(x.z(), cell_m));
  });
  parallelFor(threads, Schedule::kStatic, 1024, int64_t(int64_t(table)), [&](int64_t cell) {
    const uint32_t c = static_cast<uint32_t>(cell);
    const uint32_t lo = grid->cell_start[c], hi = grid->cell_start[c + 1];
    for (uint32_t a = lo + 1; a < hi; ++a) {
      const uint64_t key = grid->sorted_key[a];
      const uint32_t idx = grid->sorted[a];
      uint32_t b = a;
      while (b > lo && (grid->sorted_key[b - 1] > key ||
                        (grid->sorted_key[b - 1] == key && grid->sorted[b - 1] > idx))) {
        grid->sorted_key[b] = grid->sorted_key[b - 1];
        grid->sorted[b] = grid->sorted[b - 1];
        --b;
      }
      grid->sorted_key[b] = key;
      grid->sorted[b] = idx;
    }
  });
  parallelFor(threads, Schedule::kStatic, 0, int64_t(n), [&](int64_t k) {
    const uint32_t i = grid->sorted[k];
    const Vec3& x = positions[i];
    grid->sorted_strand[k] = grid->strand_of[i];
    grid->sorted_strand_value[k] = grid->strand_of[i];
    grid->sorted_x[k] = x.x();
    grid->sorted_y[k] = x.y();
    grid->sorted_z[k] = x.z();
  });
}

namespace {

bool anyWet(const HairState& state) {
  for (double s : state.saturation)
    if (s > 0.0) return true;
  return false;
}

/// SPH density of every particle: all particles within h, own strand and self included (poly6),
/// summed over the cells' contiguous runs in a loop that vectorises. Also fills the grid's
/// sorted mass, volume and saturation.
/// Sum over one cell's run of the sorted particles k = lo .. hi - 1 of m_k W(|x_k - x_i|) (the
/// poly6 shape). Explicit restrict pointers and a SIMD reduction: inside the neighbour lambda,
/// with the pointers captured by reference and no reduction clause, the compiler ran this loop
/// one neighbour at a time with gathers (12 us per wet particle-frame at 1,000 strands). The sum
/// order within a run is fixed by the vector width, not by the threads.
inline double densityRun(const double* __restrict sx, const double* __restrict sy,
                         const double* __restrict sz, const double* __restrict sm, size_t lo,
                         size_t hi, double xi, double yi, double zi, double h2) {
  double part = 0.0;
#pragma omp simd reduction(+ : part)
  for (size_t k = lo; k < hi; ++k) {
    const double dx = sx[k] - xi, dy = sy[k] - yi, dz = sz[k] - zi;
    const double q = std::max(0.0, h2 - (dx * dx + dy * dy + dz * dz));
    part += sm[k] * (q * q * q);
  }
  return part;
}

struct CohesionSums {
  double weight = 0.0, x = 0.0, y = 0.0, z = 0.0;
};

/// Over one cell's run: the sums of eq. (10) over other strands' particles, w = V_k W_ik and
/// w sigma_k (x_k - x_i). A 0/1 factor for "other strand" (exact) keeps the loads unconditional.
inline CohesionSums cohesionRun(const double* __restrict sx, const double* __restrict sy,
                                const double* __restrict sz, const double* __restrict sv,
                                const double* __restrict ss, const double* __restrict sstrand,
                                size_t lo, size_t hi, double xi, double yi, double zi, double h2,
                                double own) {
  double w_sum = 0.0, ax = 0.0, ay = 0.0, az = 0.0;
#pragma omp simd reduction(+ : w_sum, ax, ay, az)
  for (size_t k = lo; k < hi; ++k) {
    const double dx = sx[k] - xi, dy = sy[k] - yi, dz = sz[k] - zi;
    const double q = std::max(0.0, h2 - (dx * dx + dy * dy + dz * dz));
    const double other = sstrand[k] != own ? 1.0 : 0.0;
    const double w = other * (sv[k] * (q * q * q));
    const double ws = w * ss[k];
    w_sum += w;
    ax += ws * dx;
    ay += ws * dy;
    az += ws * dz;
  }
  return {w_sum, ax, ay, az};
}

void computeDensity(const HairModel& model, double h, HairState* state, int threads = 1) {
  const Vec3List& p = state->position;
  NeighborGrid& grid = state->grid;
  const double h2 = h * h;
  // Normalised poly6 (docs/physics.md §7.1) so that V = m / rho is a volume (the kim baseline's
  // normals need it; in the Shepard weights of eq. 10 the constant cancels).
  const double norm = 315.0 / (64.0 * M_PI * std::pow(h, 9));
  const int64_t n = model.particleCount();
  for (int64_t k = 0; k < n; ++k) grid.sorted_mass[k] = model.mass_kg[grid.sorted[k]];
  const double* __restrict sx = grid.sorted_x.data();
  const double* __restrict sy = grid.sorted_y.data();
  const double* __restrict sz = grid.sorted_z.data();
  const double* __restrict sm = grid.sorted_mass.data();
  parallelFor(threads, Schedule::kDynamic, 256, int64_t(n), [&](int64_t i) {
    const double xi = p[i].x(), yi = p[i].y(), zi = p[i].z();
    double rho = 0.0;
    forEachCellRun(grid, p[i], h, [&](uint32_t lo, uint32_t hi) {
      rho += densityRun(sx, sy, sz, sm, lo, hi, xi, yi, zi, h2);
    });
    state->density[i] = norm * rho;
  });
  for (int64_t k = 0; k < n; ++k) {
    const uint32_t j = grid.sorted[k];
    grid.sorted_volume[k] = model.mass_kg[j] / state->density[j];
    grid.sorted_saturation[k] = state->saturation[j];
  }
}

}  // namespace

int computeDisplayCohesion(const HairModel& model, const CohesionConfig& c, HairState* state,
                           int threads) {
  const Vec3List& p = state->position;
  const detail::DisplayWrite write = detail::displayWrite(c, state);
  // Nothing to display: p^w = p everywhere, read from the positions (displayPositions).
  state->display_is_position = !(c.mode == "ours" && c.tightness > 0.0 && anyWet(*state));
  if (state->display_is_position) return 0;
  // The lattice writes every particle's p^w (and held offset) itself; the others start at p.
  if (c.evaluation == "grid") {
    const int clumped = computeDisplayCohesionGrid(model, c, state, threads);
    if (clumped >= 0) return clumped;
    ++state->warnings.cohesion_grid_fallbacks;  // lattice too small for the hair's box: exact
  }
  parallelFor(threads, Schedule::kStatic, 0, static_cast<int>(p.size()),
              [&](int i) { write.unmoved(i, p[i]); });
  const double h = c.radius_m, h2 = h * h;
  // Cells of h: measured, cells of h/2 or h/3 (fewer candidates, more cells and hash
  // collisions) cost 1.7x and 2.8x more on 100 wet strands.
  buildNeighborGrid(p, h, &state->grid, threads);
  computeDensity(model, h, state, threads);
  const NeighborGrid& grid = state->grid;
  const double* __restrict sx = grid.sorted_x.data();
  const double* __restrict sy = grid.sorted_y.data();
  const double* __restrict sz = grid.sorted_z.data();
  const double* __restrict sv = grid.sorted_volume.data();
  const double* __restrict ss = grid.sorted_saturation.data();
  const double* __restrict sstrand = grid.sorted_strand_value.data();
  // With gather_at "guides" the sums run over the guide particles only, wet or dry (the
  // densities stay exact at every particle: this is the reference).
  const int guide_strands = model.followers.guide_strands;
  const bool at_guides = c.gather_at == "guides" && guide_strands > 0;
  const int gathered =
      at_guides ? static_cast<int>(model.strandBegin(guide_strands)) : model.particleCount();
  // Each particle writes only its own p^w: the result is the same for any thread count.
  const int clumped = static_cast<int>(parallelSum(threads, 256, gathered, [&](int i) -> int {
    const bool wet = state->saturation[i] > 0.0;
    if (!wet && !at_guides) return 0;  // dry particles keep p^w = p
    const double xi = p[i].x(), yi = p[i].y(), zi = p[i].z();
    const double own = grid.strand_of[i];
    // Sums over other strands' particles within h of w = V_j W_ij and of w sigma_j (p_j - p_i).
    double weight_sum = 0.0, px = 0.0, py = 0.0, pz = 0.0;
    forEachCellRun(grid, p[i], h, [&](uint32_t lo, uint32_t hi) {
      const CohesionSums run =
          cohesionRun(sx, sy, sz, sv, ss, sstrand, lo, hi, xi, yi, zi, h2, own);
      weight_sum += run.weight;
      px += run.x;
      py += run.y;
      pz += run.z;
    });
    const Vec3 pull(px, py, pz);
    // A13: the particle itself may join the Shepard sum (it pulls nowhere). Without it a single
    // distant neighbour gets the whole weight, so p^w jumps by up to lambda h as a neighbour
    // crosses the kernel support: measured as jitter under rotation (docs/physics.md §1.3).
    if (c.include_self && weight_sum > 0.0)
      weight_sum += model.mass_kg[i] / state->density[i] * poly6Shape(0.0, h2);
    const Vec3 offset =
        weight_sum > 0.0 ? clumpOffset(pull, weight_sum, c.tightness) : Vec3(Vec3::Zero());
    if (at_guides) state->guide_clump_offset[i] = offset;
    if (weight_sum <= 0.0 || !wet) return 0;  // isolated: p^w = p (A13)
    write(i, p[i], offset);
    return 1;
  }));
  return at_guides ? clumped + displayFollowersFromGuides(model, c, state, threads) : clumped;
}

int updateDisplayCohesion(const HairModel& model, const CohesionConfig& c, double time_s,
                          HairState* state, int threads) {
  const double period = c.refresh_period_s;
  // Round-off of the frame times must not skip an evaluation that is due.
  const double since = time_s - state->display_evaluated_s;
  const bool hold = period > 0.0 && since >= 0.0 && since < period * (1.0 - 1e-9);
  // The evaluation held had nothing to display: its offsets are all zero.
  if (hold && state->display_is_position) return 0;
  if (!hold) {
    // With period > 0 this writes the held offsets too (DisplayWrite).
    const int clumped = computeDisplayCohesion(model, c, state, threads);
    if (period > 0.0) state->display_evaluated_s = time_s;
    return clumped;
  }
  // A pass over every particle that only moves memory: plain arrays, each coordinate selected
  // without a branch, chunks of 4,096 particles (0.55-0.6x the time of Vec3 loads and chunks of
  // 256: 0.77-0.80 against 1.20-1.47 ms per held frame on dense_10k, 2 threads, AMD EPYC).
  static_assert(sizeof(Vec3) == 3 * sizeof(double), "a Vec3 list is 3 doubles per particle");
  const double* __restrict p = reinterpret_cast<const double*>(state->position.data());
  const double* __restrict offset = reinterpret_cast<const double*>(state->display_offset.data());
  const double* __restrict saturation = state->saturation.data();
  double* __restrict wet = reinterpret_cast<double*>(state->wet_position.data());
  return static_cast<int>(parallelSum(threads, 4096, model.particleCount(), [&](int i) -> int {
    const double* o = offset + 3 * size_t(i);
    const bool moved = saturation[i] > 0.0 && (o[0] != 0.0 || o[1] != 0.0 || o[2] != 0.0);
    for (int a = 0; a < 3; ++a)
      wet[3 * size_t(i) + a] = moved ? p[3 * size_t(i) + a] + o[a] : p[3 * size_t(i) + a];
    return moved ? 1 : 0;
  }));
}

int computeCohesionForces(const HairModel& model, const CohesionConfig& c, HairState* state) {
  Vec3List& f = state->external_force;
  std::fill(f.begin(), f.end(), Vec3::Zero());
  if ((c.mode != "lin" && c.mode != "kim") || !anyWet(*state)) return 0;
  const Vec3List& p = state->position;
  const double h = c.radius_m;
  buildNeighborGrid(p, h, &state->grid);
  const int n = model.particleCount();
  if (c.mode == "lin") {
    const double rest = 0.25 * h;
    for (int i = 0; i < n; ++i) {
      if (state->saturation[i] <= 0.0) continue;
      forEachOtherStrandNeighbor(
          state->grid, p, state->grid.strand_of[i], p[i], h, [&](uint32_t j, double r2) {
            const double s = std::min(state->saturation[i], state->saturation[j]);
            const double r = std::sqrt(r2);
            if (s <= 0.0 || r < 1e-12) return;
            // Per length (docs/physics.md §2.11): the pair stands for l_i l_j of strand.
            const double k =
                c.lin_stiffness_n_per_m3 * model.length_share_m[i] * model.length_share_m[j];
            f[i] += (k * s * (r - rest) / r) * (p[j] - p[i]);
          });
    }
  } else {
    // Akinci et al. 2013 surface tension: normals from the colour field of the other strands'
    // particles (cubic spline gradient), then cohesion + curvature forces.
    computeDensity(model, h, state);
    const double kgrad = 48.0 / (M_PI * h * h * h);
    for (int i = 0; i < n; ++i) {
      Vec3 normal = Vec3::Zero();
      forEachOtherStrandNeighbor(
          state->grid, p, state->grid.strand_of[i], p[i], h, [&](uint32_t j, double r2) {
            const double r = std::sqrt(r2);
            if (r < 1e-12) return;
            const double q = r / h;
            const double g =
                q <= 0.5 ? kgrad * q * (3.0 * q - 2.0) / h : -kgrad * (1.0 - q) * (1.0 - q) / h;
            normal += (model.mass_kg[j] / state->density[j]) * g * (p[i] - p[j]) / r;
          });
      // Outward (away from the neighbours), so that -gamma m (n_i - n_j) pulls a surface
      // particle back toward the clump; the colour-field gradient itself points inward.
      state->normal_scratch[i] = -h * normal;
    }
    for (int i = 0; i < n; ++i) {
      if (state->saturation[i] <= 0.0) continue;
      forEachOtherStrandNeighbor(
          state->grid, p, state->grid.strand_of[i], p[i], h, [&](uint32_t j, double r2) {
            const double s = 0.5 * (state->saturation[i] + state->saturation[j]);
            const double r = std::sqrt(r2);
            if (r < 1e-12) return;
            const Vec3 xij = (p[i] - p[j]) / r;
            const double g = c.kim_surface_tension * s;
            f[i] -= g * model.mass_kg[i] * model.mass_kg[j] * akinciCohesionKernel(r, h) * xij;
            f[i] -= g * model.mass_kg[i] * (state->normal_scratch[i] - state->normal_scratch[j]);
          });
    }
  }
  int active = 0;
  for (const Vec3& x : f) active += x.squaredNorm() > 0.0;
  return active;
}

}  // namespace wet_curly_hair
