// HairModel: everything about the hair that is constant after load .
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/head_collider.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Guides and followers (followers.h): with a follow ratio K > 1 the model's strands are ordered
/// guides first: strands [0, guide_strands) are simulated, the others are followers, placed after
/// each step from their kFollowerGuides nearest guides in root space. Empty (guide_strands 0)
/// when every strand is simulated.
struct FollowerMap {
  int guide_strands = 0;  ///< simulated strands; 0: every strand (no followers).
  /// Per model strand, its index in the groom it was built from (guides first reorders them).
  std::vector<int> source_strand;
  /// Per follower strand f (model strand guide_strands + f): kFollowerGuides guides (model strand
  /// indices) and their root-space weights (sum 1; 0 for a guide that does not count).
  std::vector<int> guide;
  std::vector<double> weight;
  /// Per follower particle p (from the first follower particle) and guide n, at entry
  /// p * kFollowerGuides + n: the guide's particle (global index) that starts the segment holding
  /// the follower's normalized arc length, and the fraction along that segment.
  std::vector<uint32_t> sample_index;
  std::vector<double> sample_fraction;
  /// Per guide particle (edge slots, the last particle's unused): the frame of the edge on the
  /// rest shape smoothed over the core smoothing length (beta_core), transported from the root
  /// frame; a guide's current frames against these turn each follower's offset from it.
  Mat3List guide_rest_frame;
  /// Per strand: the rotation that takes the strand's helix (helix_edge) to its rest axis, for
  /// the exaggerated rest shape (exaggeratedRest).
  Mat3List curl_turn;
};

/// The per-particle constants the strand-block stepper reads on every substep (mass_kg, inv_mass,
/// rest_head_distance_m, rest_edge_m, core_rest_m, stretch_k, stretch_c, bend_local_target,
/// helix_edge), copied block by block into the SIMD lanes of one layout, so that a step reads
/// them where they lie instead of gathering 13 values per particle into its lanes
/// (docs/performance.md, "The constants laid in lanes once"). Derived from those arrays, as
/// MuJoCo's mj_setConst derives: layModelLanes makes it, every core function that changes them
/// lays it again (buildModel, updateSpringConstants, makeSagFree, applyWaterMass,
/// buildFollowerModel), and code that writes them by hand calls relayModelLanes afterwards. A
/// block without laid lanes (another layout, a block of unequal strands, a partial block run at
/// half width, width 0) is gathered at each step as before: the same lanes to the bit.
struct ModelLanes {
  struct alignas(64) Chunk {
    unsigned char bytes[64];
  };
  int width = 0;       ///< strands per block; 0: nothing laid.
  bool single = true;  ///< float lanes (else double).
  /// Per block of `width` simulated strands: its first chunk, -1 when not laid, and the particle
  /// count of its strands.
  std::vector<int64_t> block_offset;
  std::vector<int> block_particles;
  std::vector<Chunk> chunks;
};

/// Constant model. Per-particle arrays are indexed by the global particle index; per-edge arrays
/// too, by the edge's root-side particle (the slot of each strand's last particle is unused).
struct HairModel {
  std::vector<uint32_t> strand_offsets{0};  ///< strands + 1 entries.
  Vec3List rest_position_head;              ///< rest pose in the head frame, m.
  /// Per particle, rho (L_{i-1} + L_i) / 2 with the groom's edges (the root's half edge only:
  /// it is kinematic, the cohesion kernels still weigh it).
  std::vector<double> mass_kg;
  std::vector<double> inv_mass;        ///< 1 / mass, 0 for roots.
  std::vector<double> length_share_m;  ///< per particle, the strand length it stands for.
  /// Per particle, the signed distance of its rest position from the head (head frame): the
  /// head collision offset of a particle is at most this (collideHeadParticles).
  std::vector<double> rest_head_distance_m;
  std::vector<double> rest_edge_m;      ///< |e0_i| per edge (sag-free may shorten it).
  Vec3List bend_local_target;           ///< e0_i in its rest frame, F0_i^T e0_i (§2.5).
  std::vector<double> core_rest_m;      ///< |b0_i|, rest core difference lengths (eq. 5).
  std::vector<double> mean_edge_m;      ///< per strand, l of A3.
  std::vector<double> beta_bend;        ///< per strand, beta for alpha_b (eq. 2).
  std::vector<double> beta_core;        ///< per strand, beta for alpha_c.
  std::vector<double> strand_length_m;  ///< per strand, rest arc length.
  // Spring constants from the per-length parameters (docs/physics.md §2.11). Per edge: the
  // stretch spring over the groom's edge length L_i. Per strand, over its mean edge L (the IIR
  // curves of eq. 2 already treat a strand as uniform with that edge, A3): bend, core, curl.
  std::vector<double> stretch_k;  ///< k_s = EA / L_i, N/m.
  std::vector<double> stretch_c;  ///< c_s = C_s / L_i, N s/m.
  std::vector<double> bend_k;     ///< k_b = B / (L alpha_b^2), N/m.
  std::vector<double> bend_c;     ///< c_b = D_b / L, N s/m (raised to the flutter bound).
  std::vector<double> core_k;     ///< k_c = K_c / L, N/m.
  std::vector<double> core_c;     ///< c_c = C_c / L, N s/m.
  std::vector<double> curl_k;     ///< w_h = W / L at saturation 1, N/m.
  double linear_density_kg_per_m = 0.0;
  /// Strands whose alpha_b or c_b buildModel raised to the flutter bounds (config.h): the
  /// resolution was too coarse for the configured values.
  int bend_stabilized_strands = 0;
  /// The explicit integrator's largest stable substep, kExplicitStabilityFraction * 2 /
  /// omega_max with omega_max^2 bounded by max_i 2 (k_{i-1} + k_i) / m_i (Gershgorin), k the sum
  /// of every spring constant on the edge, s.
  double explicit_substep_bound_s = 0.0;
  /// Largest (damping constant of an edge) / (mass of one of its particles), 1/s: the explicit
  /// damping passes need tau <= 0.9 / (2 of it) (docs/physics.md §10.1).
  double max_damping_per_mass = 0.0;
  Mat3List root_frame_head;  ///< per strand, rest root frame in head frame.
  HeadShape head;            ///< head colliders, head frame.
  /// Curl exaggeration (eqs. 6-9): per edge the edge h_{i+1} - h_i of the strand's own helix
  /// (same particle count and mean edge length, A9), phase-matched to the rest pose; per strand
  /// the helix root-to-tip direction h^v (unit).
  Vec3List helix_edge;
  Vec3List helix_axis;
  int max_strand_size = 0;  ///< largest particle count of any strand.
  /// Lattice nodes makeState allocates for the "grid" cohesion evaluation: enough for the hair's
  /// largest possible extent (cohesionGridNodeBound); 0 when the evaluation is "exact".
  size_t cohesion_grid_nodes = 0;
  /// The particles per occupied cell at rest of the cohesion lattice (restParticlesPerCell at
  /// cohesion_rest_density_cells nodes per radius: the build's grid_cells_per_radius), for
  /// grid_wet_sums "auto" (cohesionLattice); 0 when not computed.
  double cohesion_rest_particles_per_cell = 0.0;
  int cohesion_rest_density_cells = 0;

  FollowerMap followers;  ///< guides and followers; empty when every strand is simulated.
  ModelLanes lanes;       ///< derived: the stepper's constants in its lanes (layModelLanes).

  int strandCount() const { return static_cast<int>(strand_offsets.size()) - 1; }
  /// Strands the dynamics advances: the guides, or every strand when there are no followers.
  int simulatedStrandCount() const {
    return followers.guide_strands > 0 ? followers.guide_strands : strandCount();
  }
  int particleCount() const { return static_cast<int>(rest_position_head.size()); }
  int strandBegin(int s) const { return static_cast<int>(strand_offsets[s]); }
  int strandSize(int s) const {
    return static_cast<int>(strand_offsets[s + 1] - strand_offsets[s]);
  }
};

/// Builds the model from a groom (head frame), its linear density (kg/m) and the solver config
/// (the smoothing lengths, masses and per-length spring constants enter the precompute of
/// docs/physics.md §9.1, §2.11). Returns false with a reason on bad input: a refusal names a
/// physical value (a strand that would hang past the strain limit under its own weight at any
/// resolution), or an explicit substep past the groom's stability bound (checkExplicitSubstep).
bool buildModel(const Groom& groom, double linear_density_kg_per_m, const HeadShape& head,
                const SolverConfig& config, HairModel* model, std::string* why);

/// The explicit integrator's stability (docs/physics.md §2.9): false, with the bound named in
/// *why, when config asks the explicit method for a substep past model.explicit_substep_bound_s.
/// A substep past it is refused, never run on velocity clamps or silently shortened, so that the
/// substep a run reports is the one it was given. Always true for the implicit methods.
bool checkExplicitSubstep(const HairModel& model, const SolverConfig& config, std::string* why);

/// Recomputes the spring constants (stretch_k ... curl_k, the stability bounds) of a built model
/// from the per-length parameters of `config`, the rest geometry unchanged: what a parameter
/// change that does not rebuild the model (stiffness, damping, curl weight) applies. Without
/// sag-free only: the sag-free rest state depends on the stiffnesses (io::applyParameters asks
/// for a rebuild then). Returns false with a reason on an invalid config or an explicit substep
/// past the new constants' stability bound (checkExplicitSubstep), model unchanged. Lays the
/// model's lanes (layModelLanes) in the layout config.integrator asks for.
bool updateSpringConstants(const SolverConfig& config, HairModel* model, std::string* why);

/// Lays model->lanes for the strand-block layout `integrator` resolves to (laneWidth, laneFloat;
/// nothing with strand_lanes off): every full block of equal strands among the simulated ones,
/// and a partial last block that runs at the full width.
void layModelLanes(const IntegratorConfig& integrator, HairModel* model);

/// Lays model->lanes again in the layout it already has (nothing when none is laid): after a
/// change to the arrays it copies.
void relayModelLanes(HairModel* model);

/// relayModelLanes for a change to mass_kg and inv_mass alone (applyWaterMass, every frame of a
/// scene whose water adds mass): the other 11 arrays stay as laid (applyWaterMass at 10,000 strands
/// x 32: 0.5 ms where relaying all of them made it 5.6).
void relayModelMassLanes(HairModel* model);

/// The helix of eq. (6) for one strand: `count` points with chord `edge_m` (A9), radius and rise
/// per turn from the curl config; a straight line along +z when the radius is 0.
Vec3List makeHelix(int count, double edge_m, double radius_m, double pitch_m);

/// buildModel without validating and without raising alpha_b and c_b to the flutter bounds: only
/// for tests that probe outside the valid range; the groom must still be structurally valid.
void buildModelUnchecked(const Groom& groom, double linear_density_kg_per_m, const HeadShape& head,
                         const SolverConfig& config, HairModel* model,
                         bool stabilize_bending = false);

}  // namespace wet_curly_hair
