// Approximate evaluation of the stable cohesion of eq. (10) on a lattice
// (solver.cohesion.evaluation = "grid", docs/physics.md §7.3).
//
// Every kernel value W(|p_i - p_j|) of the exact sums is replaced by its trilinear interpolant
// over the lattice cell holding p_j: W~_ij = sum_n t_jn W(|p_i - x_n|), t_jn the trilinear
// weights of p_j at the 8 nodes x_n of its cell. Sums over all particles then become sums over
// the nodes within h of p_i of W times node values splatted once per step (particle-in-cell), so
// the cost per particle depends on h / spacing, not on how many neighbours there are:
//   pass 1: node mass -> rho_i = norm sum_n W(|p_i - x_n|) M_n, V_i = m_i / rho_i (all particles);
//   pass 2: node V, V sigma, V sigma (p - x_ref) (one reference node for the lattice) -> for each
//   wet particle the sums over ALL strands;
// the own strand's share is computed with the same functional from its particles (their 8 nodes
// each) and subtracted, so it cancels up to round-off; a particle whose other-strand weight is
// at most 1e-9 of its own strand's counts as isolated (p^w = p, A13).
// Splatting runs in slabs of node layers, one per thread, each adding in particle order (so every
// node sums in the same order as a serial loop), and each particle's gather writes only its own
// p^w: the result is bit-identical for any thread count. With grid_single_precision the gathers
// read float copies of the node sums (8 lanes per AVX2 register instead of 4 doubles), the own
// strand's share is summed in float in lattice units, and the particles where the own-strand
// cancellation would expose float round-off (other-strand weight below 1e-2 of the own
// strand's) have both sums redone in double.
#pragma once

#include <cstddef>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/state.h"

namespace wet_curly_hair {

/// Largest lattice preallocated (nodes; 5 doubles each): beyond it the grid evaluation is not
/// allocated and every step falls back to exact (counted in WarningStats).
constexpr size_t kMaxCohesionGridNodes = size_t{1} << 23;

/// Nodes allocated past the lattice: a row is read in vectors of 8 lanes, the lanes past its end
/// weighted 0.
constexpr size_t kCohesionGridPadding = 8;

/// Lanes of floats per vector: the float own-strand sums and the packed gathers use it, and the
/// float per-particle arrays carry as many particles past the last one for the last strand's
/// lanes. One register: 16 with AVX-512, 8 (AVX2) without, and 8 where AVX-512 runs on 256-bit
/// units (a fourth-generation AMD EPYC, Zen 4: the display pass 0.89-0.94x with 8 against 16;
/// on a fifth, Zen 5, 16 cost 0.70-0.97x of 8). The build sets WCH_COHESION_FLOAT_LANES from the
/// build machine's CPU (CMakeLists.txt; docs/physics.md §7.3).
#if defined(WCH_COHESION_FLOAT_LANES)
constexpr int kCohesionFloatLanes = WCH_COHESION_FLOAT_LANES;
#elif defined(__AVX512F__)
constexpr int kCohesionFloatLanes = 16;
#else
constexpr int kCohesionFloatLanes = 8;
#endif
static_assert(kCohesionFloatLanes == 8 || kCohesionFloatLanes == 16,
              "WCH_COHESION_FLOAT_LANES is 8 or 16");

/// The lattice a "grid" evaluation runs: its nodes per kernel radius and where eq. (10)'s sums
/// run (CohesionConfig::grid_wet_sums resolved).
struct CohesionLattice {
  int cells_per_radius = 0;
  bool node_sums = false;  ///< convolved at the nodes, else gathered at each particle
};

/// grid_wet_sums "auto" takes the node sums where the hair at rest holds at least this many
/// particles per occupied cell of the lattice: their convolution costs per node with mass, the
/// gathers per particle. Measured, the fully wet bench scene at 3 nodes per radius on a
/// fifth-generation AMD EPYC (docs/physics.md §7.3), node sums against gathers: 3.1x the cost at
/// 300 strands (2.4 particles per cell), 0.94x at 1,000 (5.6), 0.45x at 5,000 (22.7). 10,000
/// strands hold 42.7.
constexpr double kNodeSumsParticlesPerCell = 5.0;

/// The particles per occupied lattice cell of the model at rest (head frame), cells of h /
/// cells_per_radius: what the node sums' cost is measured against (kNodeSumsParticlesPerCell).
double restParticlesPerCell(const HairModel& model, double h, int cells_per_radius);

/// CohesionConfig::grid_wet_sums resolved for the model: "particles" and "nodes" as given;
/// "auto" at 3 nodes per radius the node sums when the hair at rest is dense enough
/// (HairModel::cohesion_rest_particles_per_cell, kNodeSumsParticlesPerCell: measured at that
/// lattice), else the gathers; at other lattices the gathers. The node volumes keep the gathers.
/// What "auto" runs stays within the bench's budgets against exact at every strand count
/// measured (docs/bench/defaults.txt).
CohesionLattice cohesionLattice(const HairModel& model, const CohesionConfig& config);

/// Lattice nodes that cover any bounding box the hair can have: each particle stays within its
/// strand's (strain-limited) length of its root, and the roots within their rest bounding
/// sphere, so every axis of the box spans at most 2 (root sphere radius + longest strand); plus
/// the kernel's reach on both sides. 0 unless config.cohesion.evaluation is "grid", or when the
/// bound exceeds kMaxCohesionGridNodes.
size_t cohesionGridNodeBound(const HairModel& model, const SolverConfig& config);

/// Eq. (10) by the lattice approximation into state->wet_position, every particle's (dry and
/// isolated ones get their positions), and into state->display_offset where config holds the
/// offsets between evaluations (refresh_period_s > 0). Returns the number of wet particles that
/// found other-strand neighbours, or -1 (nothing written) when the hair's current bounding box
/// needs more nodes than state->cohesion_grid holds or is not finite.
int computeDisplayCohesionGrid(const HairModel& model, const CohesionConfig& config,
                               HairState* state, int threads = 1);

}  // namespace wet_curly_hair
