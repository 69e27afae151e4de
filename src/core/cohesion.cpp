#include "wet_curly_hair/core/cohesion.h"

#include <cmath>
#include <cstdint>

#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {

void buildNeighborGrid(const Vec3List& positions, double cell_m, NeighborGrid* grid, int threads) {
  grid->cell_m = cell_m;
  const uint32_t table = static_cast<uint32_t>(grid->cell_start.size() - 1);
  const uint32_t mask = table - 1;
  std::fill(grid->cell_start.begin(), grid->cell_start.end(), 0u);
  const int64_t n = static_cast<int64_t>(positions.size());
  // Hashing in parallel; the counting sort stays serial so the order within a cell (and so
  // every sum over neighbours) is the same for any thread count.
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const Vec3& x = positions[i];
    grid->cell_of[i] = detail::cellHash(detail::cellCoord(x.x(), cell_m),
                                        detail::cellCoord(x.y(), cell_m),
                                        detail::cellCoord(x.z(), cell_m), mask);
  }
  for (int64_t i = 0; i < n; ++i) ++grid->cell_start[grid->cell_of[i] + 1];
  for (uint32_t c = 0; c < table; ++c) grid->cell_start[c + 1] += grid->cell_start[c];
  // Counting sort; cell_start[c] is used as the running cursor, then shifted back.
  for (int64_t i = 0; i < n; ++i) grid->sorted[grid->cell_start[grid->cell_of[i]]++] = static_cast<uint32_t>(i);
  for (uint32_t c = table; c > 0; --c) grid->cell_start[c] = grid->cell_start[c - 1];
  grid->cell_start[0] = 0;
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int64_t k = 0; k < n; ++k) {
    const uint32_t i = grid->sorted[k];
    const Vec3& x = positions[i];
    grid->sorted_key[k] = detail::cellKey(detail::cellCoord(x.x(), cell_m),
                                          detail::cellCoord(x.y(), cell_m),
                                          detail::cellCoord(x.z(), cell_m));
    grid->sorted_strand[k] = grid->strand_of[i];
    grid->sorted_position[k] = x;
  }
}

namespace {

bool anyWet(const HairState& state) {
  for (double s : state.saturation)
    if (s > 0.0) return true;
  return false;
}

/// SPH density of every particle near a wet one: all neighbours within h, other strands and own
/// strand alike (poly6 shape; the normalisation cancels in the Shepard weights).
void computeDensity(const HairModel& model, double h, HairState* state, int threads = 1) {
  const Vec3List& p = state->position;
  const double h2 = h * h;
  // Normalised poly6 (method.md §7.1) so that V = m / rho is a volume (the kim baseline's normals
  // need it; in the Shepard weights of eq. 10 the constant cancels).
  const double norm = 315.0 / (64.0 * M_PI * std::pow(h, 9));
  const double self = poly6Shape(0.0, h2);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256)
  for (int i = 0; i < model.particleCount(); ++i) {
    // Own strand: the neighbours along the strand within h.
    double rho = model.mass_kg[i] * self;
    const int s = static_cast<int>(state->grid.strand_of[i]);
    const int begin = model.strandBegin(s), end = begin + model.strandSize(s);
    for (int j = begin; j < end; ++j)
      if (j != i) rho += model.mass_kg[j] * poly6Shape((p[j] - p[i]).squaredNorm(), h2);
    forEachOtherStrandNeighbor(state->grid, p, s, p[i], h, [&](uint32_t j, double r2) {
      rho += model.mass_kg[j] * poly6Shape(r2, h2);
    });
    state->density[i] = norm * rho;
  }
}

}  // namespace

int computeDisplayCohesion(const HairModel& model, const CohesionConfig& c, HairState* state,
                           int threads) {
  const Vec3List& p = state->position;
  std::copy(p.begin(), p.end(), state->wet_position.begin());
  if (c.mode != "ours" || c.tightness <= 0.0 || !anyWet(*state)) return 0;
  const double h = c.radius_m, h2 = h * h;
  // Cells of h: measured, cells of h/2 or h/3 (fewer candidates, more cells and hash
  // collisions) cost 1.7x and 2.8x more on 100 wet strands.
  buildNeighborGrid(p, h, &state->grid, threads);
  computeDensity(model, h, state, threads);
  int clumped = 0;
  // Each particle writes only its own p^w: the result is the same for any thread count.
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256) reduction(+ : clumped)
  for (int i = 0; i < model.particleCount(); ++i) {
    if (state->saturation[i] <= 0.0) continue;  // dry particles keep p^w = p
    double weight_sum = 0.0;
    Vec3 pull = Vec3::Zero();
    forEachOtherStrandNeighbor(state->grid, p, state->grid.strand_of[i], p[i], h,
                               [&](uint32_t j, double r2) {
                                 const double w = model.mass_kg[j] / state->density[j] * poly6Shape(r2, h2);
                                 weight_sum += w;
                                 pull += w * state->saturation[j] * (p[j] - p[i]);
                               });
    // A13: the particle itself may join the Shepard sum (it pulls nowhere). Without it a single
    // distant neighbour gets the whole weight, so p^w jumps by up to lambda h as a neighbour
    // crosses the kernel support: measured as jitter under rotation (README).
    if (c.include_self && weight_sum > 0.0)
      weight_sum += model.mass_kg[i] / state->density[i] * poly6Shape(0.0, h2);
    if (weight_sum <= 0.0) continue;  // isolated: p^w = p (A13)
    state->wet_position[i] = p[i] + (c.tightness / weight_sum) * pull;
    ++clumped;
  }
  return clumped;
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
      forEachOtherStrandNeighbor(state->grid, p, state->grid.strand_of[i], p[i], h,
                                 [&](uint32_t j, double r2) {
                                   const double s = std::min(state->saturation[i], state->saturation[j]);
                                   const double r = std::sqrt(r2);
                                   if (s <= 0.0 || r < 1e-12) return;
                                   f[i] += (c.lin_stiffness_n_per_m * s * (r - rest) / r) * (p[j] - p[i]);
                                 });
    }
  } else {
    // Akinci et al. 2013 surface tension: normals from the colour field of the other strands'
    // particles (cubic spline gradient), then cohesion + curvature forces.
    computeDensity(model, h, state);
    const double kgrad = 48.0 / (M_PI * h * h * h);
    for (int i = 0; i < n; ++i) {
      Vec3 normal = Vec3::Zero();
      forEachOtherStrandNeighbor(state->grid, p, state->grid.strand_of[i], p[i], h,
                                 [&](uint32_t j, double r2) {
                                   const double r = std::sqrt(r2);
                                   if (r < 1e-12) return;
                                   const double q = r / h;
                                   const double g = q <= 0.5 ? kgrad * q * (3.0 * q - 2.0) / h
                                                             : -kgrad * (1.0 - q) * (1.0 - q) / h;
                                   normal += (model.mass_kg[j] / state->density[j]) * g * (p[i] - p[j]) / r;
                                 });
      // Outward (away from the neighbours), so that -gamma m (n_i - n_j) pulls a surface
      // particle back toward the clump; the colour-field gradient itself points inward.
      state->normal_scratch[i] = -h * normal;
    }
    for (int i = 0; i < n; ++i) {
      if (state->saturation[i] <= 0.0) continue;
      forEachOtherStrandNeighbor(state->grid, p, state->grid.strand_of[i], p[i], h,
                                 [&](uint32_t j, double r2) {
                                   const double s = 0.5 * (state->saturation[i] + state->saturation[j]);
                                   const double r = std::sqrt(r2);
                                   if (r < 1e-12) return;
                                   const Vec3 xij = (p[i] - p[j]) / r;
                                   const double g = c.kim_surface_tension * s;
                                   f[i] -= g * model.mass_kg[i] * model.mass_kg[j] *
                                           akinciCohesionKernel(r, h) * xij;
                                   f[i] -= g * model.mass_kg[i] *
                                           (state->normal_scratch[i] - state->normal_scratch[j]);
                                 });
    }
  }
  int active = 0;
  for (const Vec3& x : f) active += x.squaredNorm() > 0.0;
  return active;
}

}  // namespace wet_curly_hair
