// Cohesion of wet strands (Kim 2023 §III.3): the stable display-position cohesion of eq. (10)
// (A11-A14), and the force-based baselines the paper compares against, reconstructed
// (docs/physics.md §4 Kim et al. 2017, §5 Lin 2015: their exact laws are not public, these are our
// readings).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/state.h"

namespace wet_curly_hair {

/// Sorts the particles into the hashed uniform grid with cell size cell_m (no allocation).
void buildNeighborGrid(const Vec3List& positions, double cell_m, NeighborGrid* grid,
                       int threads = 1);

/// Calls fn(begin, end) once for every grid cell within radius_m of x (cells wholly beyond it
/// skipped) with the range of that cell's entries in the grid's sorted arrays, in an order that
/// depends only on the positions (never on threads).
template <typename Fn>
void forEachCellRun(const NeighborGrid& grid, const Vec3& x, double radius_m, Fn fn);

/// Calls fn(j, r2) for every particle j of ANOTHER strand within radius_m of x (any radius).
template <typename Fn>
void forEachOtherStrandNeighbor(const NeighborGrid& grid, const Vec3List& positions,
                                uint32_t strand, const Vec3& x, double radius_m, Fn fn);

/// Eq. (10) as resolved in A11-A14: for each wet particle i,
///   p^w_i = p_i + lambda sum_j w_ij sigma_j (p_j - p_i),  w_ij = V_j W_ij / sum_k V_k W_ik,
/// over particles j of other strands within h (poly6 kernel, V_j = m_j / rho_j, rho from all
/// particles within h, self included). Dry particles and isolated ones keep p^w = p. Writes
/// state->wet_position, and the offsets p^w - p to state->display_offset where config holds them
/// between evaluations (refresh_period_s > 0); the dynamics never read either. With nothing to
/// display (mode not "ours", tightness 0 or no wet particle) it writes neither and sets
/// state->display_is_position: displayPositions() then reads the positions. Returns the number
/// of wet particles that found neighbours.
int computeDisplayCohesion(const HairModel& model, const CohesionConfig& config, HairState* state,
                           int threads = 1);

/// computeDisplayCohesion at most every config.refresh_period_s of simulated time: `time_s` is
/// the positions' time. Between evaluations each wet particle's p^w is its position plus the
/// offset p^w - p of the last evaluation (dry ones keep p^w = p); the first call after
/// makeState or resetState, a time before the last evaluation's, or period 0 evaluates.
/// Returns the wet particles displaced (clumped).
int updateDisplayCohesion(const HairModel& model, const CohesionConfig& config, double time_s,
                          HairState* state, int threads = 1);

/// Force-based baselines into state->external_force (N), zero for dry particles:
/// "lin" (reconstruction of Lin 2015): a spring between particles of different strands within
///   h, k min(sigma_i, sigma_j) (|x_ij| - h/4) toward each other;
/// "kim" (reconstruction of Kim et al. 2017): Akinci et al. 2013 surface tension between
///   particles of different strands, cohesion -gamma m_i m_j C(r) x^_ij plus curvature
///   -gamma m_i (n_i - n_j) with outward normals n, scaled by the mean saturation of the pair.
/// Returns the number of particles with a non-zero force.
int computeCohesionForces(const HairModel& model, const CohesionConfig& config, HairState* state);

// ---------------------------------------------------------------------------------------------

namespace detail {
inline uint32_t cellHash(int64_t ix, int64_t iy, int64_t iz, uint32_t mask) {
  return static_cast<uint32_t>((ix * 73856093) ^ (iy * 19349663) ^ (iz * 83492791)) & mask;
}
inline int64_t cellCoord(double x, double cell) {
  return static_cast<int64_t>(std::floor(x / cell));
}
/// A cell's identity (21 bits per axis, wrapping: cells 2^21 apart share a key and are told
/// apart by the distance test).
inline uint64_t cellKey(int64_t ix, int64_t iy, int64_t iz) {
  constexpr uint64_t m = (uint64_t{1} << 21) - 1;
  return (static_cast<uint64_t>(ix) & m) | ((static_cast<uint64_t>(iy) & m) << 21) |
         ((static_cast<uint64_t>(iz) & m) << 42);
}
}  // namespace detail

template <typename Fn>
void forEachCellRun(const NeighborGrid& grid, const Vec3& x, double radius_m, Fn fn) {
  const uint32_t mask = static_cast<uint32_t>(grid.cell_start.size() - 2);
  const double cell = grid.cell_m;
  const int64_t cx = detail::cellCoord(x.x(), cell);
  const int64_t cy = detail::cellCoord(x.y(), cell);
  const int64_t cz = detail::cellCoord(x.z(), cell);
  const int64_t reach = std::max<int64_t>(1, static_cast<int64_t>(std::ceil(radius_m / cell)));
  const double r2max = radius_m * radius_m;
  // Distance from x to the slab of cell offset d along one axis (0 inside).
  auto gap = [cell](double xc, int64_t c, int64_t d) {
    if (d == 0) return 0.0;
    const double lo = double(c + d) * cell;
    return d > 0 ? lo - xc : xc - (lo + cell);
  };
  for (int64_t dz = -reach; dz <= reach; ++dz) {
    const double gz = gap(x.z(), cz, dz);
    if (gz * gz >= r2max) continue;
    for (int64_t dy = -reach; dy <= reach; ++dy) {
      const double gy = gap(x.y(), cy, dy);
      if (gz * gz + gy * gy >= r2max) continue;
      for (int64_t dx = -reach; dx <= reach; ++dx) {
        const double gx = gap(x.x(), cx, dx);
        if (gz * gz + gy * gy + gx * gx >= r2max) continue;
        const uint64_t key = detail::cellKey(cx + dx, cy + dy, cz + dz);
        const uint32_t b = detail::cellHash(cx + dx, cy + dy, cz + dz, mask);
        // Within a bucket the entries are sorted by cell key: find this cell's run.
        uint32_t lo = grid.cell_start[b];
        const uint32_t end = grid.cell_start[b + 1];
        while (lo < end && grid.sorted_key[lo] < key) ++lo;
        uint32_t hi = lo;
        while (hi < end && grid.sorted_key[hi] == key) ++hi;
        if (hi > lo) fn(lo, hi);
      }
    }
  }
}

template <typename Fn>
void forEachOtherStrandNeighbor(const NeighborGrid& grid, const Vec3List& /*positions*/,
                                uint32_t strand, const Vec3& x, double radius_m, Fn fn) {
  const double r2max = radius_m * radius_m;
  forEachCellRun(grid, x, radius_m, [&](uint32_t lo, uint32_t hi) {
    for (uint32_t k = lo; k < hi; ++k) {
      if (grid.sorted_strand[k] == strand) continue;
      const double dx = grid.sorted_x[k] - x.x(), dy = grid.sorted_y[k] - x.y(),
                   dz = grid.sorted_z[k] - x.z();
      const double r2 = dx * dx + dy * dy + dz * dz;
      if (r2 < r2max) fn(grid.sorted[k], r2);
    }
  });
}

}  // namespace wet_curly_hair
