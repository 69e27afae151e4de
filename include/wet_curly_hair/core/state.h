// HairState: the mutable, preallocated state of the simulation .
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Numerical trouble detected and repaired, never hidden.
struct WarningStats {
  uint64_t nonfinite_repairs = 0;  ///< strands restored because a value went NaN/Inf.
  uint64_t strain_repairs = 0;     ///< strands restored because strain ran past the bound.
  /// Of those, strands given their rest shape: the state they started the step from failed the
  /// same check (a caller wrote it so between steps).
  uint64_t rest_shape_repairs = 0;
  uint64_t nonfinite_values = 0;  ///< non-finite scalars found before those repairs.
  uint64_t head_jumps = 0;        ///< steps whose head motion was taken as a jump (teleport).
  /// Steps whose "grid" cohesion evaluation fell back to "exact": the hair's bounding box needed
  /// more lattice nodes than were preallocated (HairModel::cohesion_grid_nodes).
  uint64_t cohesion_grid_fallbacks = 0;
  /// Substeps without hair-contact forces because the pair list would have held more than
  /// kMaxListedPerSphere entries per sphere over a build range (a contact radius far too large for
  /// the groom's density; hair_contact.cpp).
  uint64_t hair_contact_overflows = 0;
  uint64_t total() const { return nonfinite_repairs + strain_repairs; }
};

/// One guide edge as its followers read it (followers.cpp, interpolateFromGuides), head frame:
/// the rotation of the edge's smoothed frame from rest, as columns, and its ends' positions less
/// their exaggerated rest positions so rotated (a follower sample at fraction t carries its rest
/// offset r to the mix of from and to plus turn r). Each as 4 doubles, one AVX2 register, so that
/// a sample is five vector multiply-adds: a column's fourth is 0, and the fourth of from and to
/// holds the edge's length over its rest length. 160 bytes, read together.
struct alignas(32) GuideEdgeCarry {
  double turn_column[3][4] = {{1.0, 0.0, 0.0, 0.0}, {0.0, 1.0, 0.0, 0.0}, {0.0, 0.0, 1.0, 0.0}};
  double from[4] = {0.0, 0.0, 0.0, 1.0}, to[4] = {0.0, 0.0, 0.0, 1.0};
  double edgeRatio() const { return from[3]; }
};

/// Scratch space for one strand, sized once for the longest strand.
struct StrandScratch {
  // The energy diagnostics' smoothed curves and frames (diagnostics.cpp); the stepper keeps its
  // own in lane_buffer.
  Vec3List smooth_bend;  ///< d of eq. (2) for alpha_b, per edge.
  Vec3List smooth_core;  ///< b of eq. (5), per edge.
  Mat3List frame;        ///< per edge.
  /// One lane's positions, the force through the frames and its adjoint (BendConfig::
  /// frame_gradient; with smooth_bend and frame).
  Vec3List bend_p, bend_force, bend_adjoint;
  /// Eq. (13) velocity factor per particle for the current strand and substep length (the
  /// saturation is constant within a step): computed once per strand and step, not per substep.
  std::vector<double> velocity_factor;
  /// Structure-of-arrays storage of the strand-block stepper (strand_block.h: one strand, or a
  /// block of strands in SIMD lanes), for strands of up to lane_capacity particles.
  std::vector<double> lane_buffer;
  int lane_capacity = 0;
  /// A block's strands out of the lanes after its substeps, strand after strand (lane_capacity
  /// particles each, up to kBlockStrands strands), checked here before they are written to the
  /// state (commitStrandAfterStep).
  static constexpr int kBlockStrands = 16;
  Vec3List step_position, step_velocity;
  void resize(int max_strand_size);
};

/// Uniform hash grid over particle positions for cross-strand neighbour queries (cohesion and
/// its force-based baselines), sized once: counting sort of particles into hashed cells.
struct NeighborGrid {
  double cell_m = 0.0;
  std::vector<uint32_t> cell_start;  ///< table size + 1 prefix offsets into `sorted`.
  std::vector<uint32_t> sorted;      ///< particle indices grouped by cell hash.
  std::vector<uint32_t> cell_of;     ///< per particle: its hashed cell.
  std::vector<uint32_t> strand_of;   ///< per particle: its strand.
  // In sorted order (by bucket, then cell key, then particle index), structure of arrays so the
  // neighbour loops over one cell's contiguous run vectorise: cell key, strand, coordinates, and
  // the particle's mass, volume m / rho and saturation (filled by the cohesion passes).
  std::vector<uint64_t> sorted_key;
  std::vector<uint32_t> sorted_strand;
  std::vector<double> sorted_strand_value;  ///< the strand index as a double (vector compares)
  std::vector<double> sorted_x, sorted_y, sorted_z;
  std::vector<double> sorted_mass, sorted_volume, sorted_saturation;
  void resize(int particles, const std::vector<uint32_t>& strand_offsets);
};

/// Hair-hair contact (hair_contact.h): the pruned spheres of a model for a radius and sparsity,
/// and the per-substep scratch. Built by prepareHairContact (allocates when the model or the
/// radius/sparsity change); the per-substep pass allocates only when its pair list outgrows its
/// capacity.
struct HairContactState {
  double radius_m = std::numeric_limits<double>::quiet_NaN();  ///< what the spheres were built for
  double sparsity = std::numeric_limits<double>::quiet_NaN();
  int particles = -1;
  std::vector<uint32_t> sphere_particle;  ///< per sphere, its particle.
  std::vector<uint32_t> sphere_offsets;   ///< strands + 1: the spheres of each strand.
  std::vector<double> sphere_length_m;    ///< per sphere, the strand length it stands for.
  std::vector<double> engagement;         ///< per sphere, the ramp variable a in [0, 1].
  std::vector<uint8_t> touching;          ///< per sphere, touching anything this substep.
  Vec3List sphere_position;               ///< per sphere, its particle's position (grid input).
  Vec3List built_position;                ///< per sphere, where it was when the list was built.
  NeighborGrid grid;                      ///< over the spheres (their strand ids per sphere).
  /// Verlet list in both directions (CSR): sphere a's candidates are
  /// neighbor[neighbor_start[a] .. neighbor_start[a + 1]), sorted.
  std::vector<uint32_t> neighbor_start, neighbor;
  std::vector<std::vector<uint32_t>> chunk_rows;  ///< per build thread: its rows, joined after.
  std::vector<uint8_t> strand_touching;  ///< per strand: any sphere touching (force applied).
  /// Per particle (written at the spheres' particles only, zero elsewhere): the contact's block
  /// (theta h^2 K + h C) of the implicit solve (hair_contact.h), zero with the explicit method.
  Mat3List external_block;
  bool list_valid = false;
  uint64_t list_builds = 0;     ///< Verlet list builds so far.
  uint64_t touching_pairs = 0;  ///< sphere pairs touching in the last substep.
  uint64_t listed_pairs = 0;    ///< sphere pairs in the list (each once).
  uint64_t active_spheres = 0;  ///< spheres touching in the last substep.
  void invalidate() { list_valid = false; }
};

/// Lattice of the approximate ("grid") cohesion evaluation (cohesion_grid.h), allocated once for
/// HairModel::cohesion_grid_nodes nodes; each step uses the part that covers the hair's current
/// bounding box. Node arrays in x-fastest order.
struct CohesionNodeGrid {
  std::vector<double> scalar;      ///< pass 1: splatted mass; pass 2: splatted volume V.
  std::vector<double> wet_volume;  ///< pass 1: node densities (unnormalised); pass 2: V sigma.
  std::vector<double> qx, qy, qz;  ///< pass 2: splatted V sigma (p - x_ref), one reference node.
  /// Pass 2's splat of V sigma and V sigma (p - x_ref), 4 per node side by side: a particle's
  /// corner then adds to one vector, not to four arrays (copied to wet_volume, qx, qy, qz after).
  std::vector<double> wet_splat;
  /// The second half of the particles' copies of scalar and wet_splat (the splat's halves,
  /// summed into the arrays above); with grid_node_volumes scalar_b then holds each node's
  /// inverse density.
  std::vector<double> scalar_b, wet_splat_b;
  /// Single-precision copies of the five node arrays above, read by the float gathers.
  std::vector<float> scalar_f, wet_volume_f, qx_f, qy_f, qz_f;
  // Per particle, as a structure of arrays (the own-strand sums run over them in SIMD lanes):
  /// V = m / rho from the lattice density (with grid_node_volumes: the gathered strands'
  /// particles only).
  std::vector<double> volume;
  /// V sigma (the gathered strands' particles only; with grid_node_volumes sigma, the corners
  /// carrying m / rho of their nodes). Not written with the sums convolved at the nodes, which
  /// form it per strand (their float own pairs in the thread's StrandScratch::lane_buffer).
  std::vector<double> wet_share;
  // The gathered strands' particles only (the passes over every particle compute these from
  // the positions):
  /// Position relative to the lattice origin, m: the cell and its fractions follow from it by
  /// the operations that formed them (the cohesion lattice's cellAxis). Written for the gathers
  /// only: the sums convolved at the nodes form it from the position where they need it.
  std::vector<double> rx, ry, rz;
  /// Single-precision lowest node of the particle's cell (kx_f..) and trilinear fractions in it
  /// (tx_f..), and copies of volume and wet_share, read by the gathers' float own-strand sums (in
  /// lattice units: cell indices are exact in float, fractions lose nothing that matters);
  /// written for the gathered strands' particles only (with gather_at "guides", the guides').
  /// Padded by kCohesionFloatLanes particles (zeros). The sums convolved at the nodes keep these
  /// and own_*_f per strand in the thread's scratch instead.
  std::vector<float> kx_f, ky_f, kz_f, tx_f, ty_f, tz_f, volume_f, wet_share_f;
  /// The own strand's share of each particle's sums, in float and lattice units (weight / c^6,
  /// pull / c^7).
  std::vector<float> own_weight_f, own_px_f, own_py_f, own_pz_f;
  void resize(size_t nodes, int particles);
};

/// Every kilogram of water the water stage (water.h) saw, totals since the state was made:
/// added = held + dripped + evaporated + removed, to round-off.
struct WaterLedger {
  double added_kg = 0.0;    ///< from sources, and by commands that raised a saturation.
  double removed_kg = 0.0;  ///< by commands that lowered a saturation.
  double dripped_kg = 0.0;
  double evaporated_kg = 0.0;
  uint64_t drips = 0;  ///< particle-steps that dripped.
};

/// Scratch of the water stage, sized once by makeState.
struct WaterScratch {
  std::vector<double> strand;  ///< 3 per particle of the longest strand: capacities, solve.
  std::vector<double> edge_m, downhill;  ///< per edge of the longest strand.
  /// One cell of the exchange: its key, water and capacity sums, first strand, whether another
  /// strand shares it (one struct, so that a particle's visit is one cache line).
  struct Slot {
    uint64_t key = ~uint64_t{0};
    double water = 0.0, capacity = 0.0;
    uint32_t strand = 0, mixed = 0;
  };
  /// The exchange's cells: an open-addressing table of at least 2 slots per particle, the slots
  /// in use, and each particle's slot.
  std::vector<Slot> slots;
  std::vector<uint32_t> used_slots, cell_of;
  /// Simulated time up to which the exchange has run (NaN: not yet), s.
  double exchange_until_s = std::numeric_limits<double>::quiet_NaN();
  Vec3List drip_points;  ///< where particles dripped in the last water step (world frame).
  void resize(int particles, int max_strand_size);
};

/// The inputs of eq. (13)'s velocity factor other than the saturation (NaN: none).
struct StiffnessFactorKey {
  double global_factor = std::numeric_limits<double>::quiet_NaN();
  double wet_factor = std::numeric_limits<double>::quiet_NaN();
  double dry_factor = std::numeric_limits<double>::quiet_NaN();
  double substep_s = std::numeric_limits<double>::quiet_NaN();
  double reference_step_s = std::numeric_limits<double>::quiet_NaN();
  bool operator==(const StiffnessFactorKey& o) const {
    return global_factor == o.global_factor && wet_factor == o.wet_factor &&
           dry_factor == o.dry_factor && substep_s == o.substep_s &&
           reference_step_s == o.reference_step_s;
  }
};

/// Mutable state. Allocated by makeState; step() never allocates.
struct HairState {
  Vec3List position;               ///< world frame, m.
  Vec3List velocity;               ///< world frame, m/s.
  std::vector<double> saturation;  ///< per particle, [0, 1].
  /// Per particle, water held, kg: the saturation's source when the water stage runs (water.h);
  /// unused (zero) otherwise.
  std::vector<double> water_kg;
  WaterLedger water_ledger;
  WaterScratch water_scratch;
  /// Cohesion display positions p^w of eq. (10), world frame, m: for output only, never read by
  /// the dynamics (A14). Equal to position where the particle is dry. Read them through
  /// displayPositions(): where the last display pass had nothing to display (display_is_position)
  /// this list is left as it was.
  Vec3List wet_position;
  /// The last display pass (updateDisplayCohesion) found p^w = p for every particle (cohesion
  /// mode not "ours", tightness 0, or no wet particle) and wrote nothing: a copy of every
  /// position each frame cost 4 % of the 10,000-strand dynamics (docs/performance.md).
  bool display_is_position = false;
  /// cohesion.refresh_period_s > 0: the display offsets p^w - p of the last evaluation, and its
  /// simulated time (NaN: none since the state was made or reset).
  Vec3List display_offset;
  double display_evaluated_s = std::numeric_limits<double>::quiet_NaN();
  /// Per strand: the last well-defined M of eq. (7) (A8), a unit quaternion (the filter of
  /// CurlConfig::rotation_time_constant_s slerps it).
  std::vector<Quat> curl_rotation;
  /// Eq. (13)'s velocity factor as last computed, per particle, with the saturation it was
  /// computed at (NaN: none yet), and per strand the rest of its inputs (StiffnessFactorKey):
  /// reused while all of them are the same (an exp and a log per particle and step otherwise).
  std::vector<double> stiffness_factor, stiffness_factor_saturation;
  std::vector<StiffnessFactorKey> stiffness_factor_key;
  Vec3List external_force;  ///< per particle: cross-strand forces of the baselines, N.
  /// Per particle: SPH density scratch (cohesion), kg/m^3-ish; with the lattice's node volumes
  /// (CohesionConfig::grid_node_volumes) written for the gathered particles only, and not at all
  /// with the lattice's sums convolved at its nodes (grid_wet_sums "nodes": no pass reads it).
  std::vector<double> density;
  Vec3List normal_scratch;  ///< per particle: Akinci surface normals (kim baseline).
  /// Per guide particle (followers.h; empty without followers), head frame: its position and its
  /// exaggerated rest position, m.
  Vec3List guide_position_head, guide_rest_head;
  /// Per guide particle but the last of each guide: what a follower sample on its edge reads.
  std::vector<GuideEdgeCarry> guide_edge_carry;
  /// Per follower particle (empty without followers), head frame: its exaggerated rest position
  /// (exaggeratedRest) as last computed, with the saturation it was computed at (NaN: none yet),
  /// and per follower strand the curl and bend constants it was computed with (2 per strand):
  /// reused while all of them are the same (most frames: the saturation changes with water and
  /// commands only).
  Vec3List follower_rest_head;
  std::vector<double> follower_rest_saturation, follower_rest_key;
  /// Per guide particle, cohesion.gather_at "guides": its display offset p^w - p of eq. (10),
  /// m, world frame, wet or dry (0 isolated): followers take theirs interpolated from these.
  Vec3List guide_clump_offset;
  NeighborGrid grid;
  CohesionNodeGrid cohesion_grid;
  HairContactState hair_contact;
  double time_s = 0.0;  ///< simulated time of the current positions, s.
  uint64_t step_count = 0;
  uint64_t substep_count = 0;
  WarningStats warnings;
  /// One per solver thread (config.integrator.threads <= kMaxSolverThreads).
  std::vector<StrandScratch> scratch;
};

/// The cohesion display positions p^w of eq. (10) after the last step: HairState::wet_position,
/// or the positions themselves where the display pass had nothing to display
/// (HairState::display_is_position).
inline const Vec3List& displayPositions(const HairState& state) {
  return state.display_is_position ? state.position : state.wet_position;
}

/// Allocates the state for a model and places the hair in its rest pose, carried by `head_pose`
/// and moving rigidly with the head (`head_twist`, world frame, about the head origin).
HairState makeState(const HairModel& model, const Pose& head_pose, const Twist& head_twist);

/// Puts an existing state back into the rest pose (no allocation).
void resetState(const HairModel& model, const Pose& head_pose, const Twist& head_twist,
                HairState* state);

}  // namespace wet_curly_hair
