// Cohesion of wet strands (Kim 2023 §III.3): the stable display-position cohesion of eq. (10)
// (A11-A14), and the force-based baselines the paper compares against, reconstructed (method.md
// §4 Kim et al. 2017, §5 Lin 2015: their exact laws are not public, these are our readings).
#pragma once

#include <cstdint>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/state.h"

namespace wet_curly_hair {

/// Sorts the particles into the hashed uniform grid with cell size cell_m (no allocation).
void buildNeighborGrid(const Vec3List& positions, double cell_m, NeighborGrid* grid);

/// Calls fn(j, r2) for every particle j of ANOTHER strand within radius_m of x (radius_m <= the
/// grid's cell size). Hash collisions are filtered by the distance test and each bucket is
/// visited once.
template <typename Fn>
void forEachOtherStrandNeighbor(const NeighborGrid& grid, const Vec3List& positions,
                                uint32_t strand, const Vec3& x, double radius_m, Fn fn);

/// Eq. (10) as resolved in A11-A14: for each wet particle i,
///   p^w_i = p_i + lambda sum_j w_ij sigma_j (p_j - p_i),  w_ij = V_j W_ij / sum_k V_k W_ik,
/// over particles j of other strands within h (poly6 kernel, V_j = m_j / rho_j, rho from all
/// particles within h, self included). Dry particles and isolated ones keep p^w = p. Writes
/// state->wet_position only; the dynamics never read it. Returns the number of wet particles
/// that found neighbours.
int computeDisplayCohesion(const HairModel& model, const CohesionConfig& config, HairState* state);

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
}  // namespace detail

template <typename Fn>
void forEachOtherStrandNeighbor(const NeighborGrid& grid, const Vec3List& positions,
                                uint32_t strand, const Vec3& x, double radius_m, Fn fn) {
  const uint32_t mask = static_cast<uint32_t>(grid.cell_start.size() - 2);
  const int64_t cx = detail::cellCoord(x.x(), grid.cell_m);
  const int64_t cy = detail::cellCoord(x.y(), grid.cell_m);
  const int64_t cz = detail::cellCoord(x.z(), grid.cell_m);
  uint32_t buckets[27];
  int count = 0;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const uint32_t b = detail::cellHash(cx + dx, cy + dy, cz + dz, mask);
        bool seen = false;
        for (int k = 0; k < count; ++k) seen = seen || buckets[k] == b;
        if (!seen) buckets[count++] = b;
      }
  const double r2max = radius_m * radius_m;
  for (int k = 0; k < count; ++k) {
    for (uint32_t idx = grid.cell_start[buckets[k]]; idx < grid.cell_start[buckets[k] + 1]; ++idx) {
      const uint32_t j = grid.sorted[idx];
      if (grid.strand_of[j] == strand) continue;
      const double r2 = (positions[j] - x).squaredNorm();
      if (r2 < r2max) fn(j, r2);
    }
  }
}

}  // namespace wet_curly_hair
