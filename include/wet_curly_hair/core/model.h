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

/// Constant model. Per-particle arrays are indexed by the global particle index; per-edge arrays
/// too, by the edge's root-side particle (the slot of each strand's last particle is unused).
struct HairModel {
  std::vector<uint32_t> strand_offsets{0};  ///< strands + 1 entries.
  Vec3List rest_position_head;              ///< rest pose in the head frame, m.
  std::vector<double> mass_kg;              ///< per particle (the root's is unused: kinematic).
  std::vector<double> inv_mass;             ///< 1 / mass, 0 for roots.
  std::vector<double> rest_edge_m;          ///< |e0_i| per edge.
  Vec3List bend_local_target;               ///< e0_i in its rest frame, F0_i^T e0_i (§2.5).
  std::vector<double> core_rest_m;          ///< |b0_i|, rest core difference lengths (eq. 5).
  std::vector<double> mean_edge_m;          ///< per strand, l of A3.
  std::vector<double> beta_bend;            ///< per strand, beta for alpha_b (eq. 2).
  std::vector<double> beta_core;            ///< per strand, beta for alpha_c.
  std::vector<double> strand_length_m;      ///< per strand, rest arc length.
  Mat3List root_frame_head;                 ///< per strand, rest root frame in head frame.
  HeadShape head;                           ///< head colliders, head frame.
  /// Curl exaggeration (eqs. 6-9): per edge the edge h_{i+1} - h_i of the strand's own helix
  /// (same particle count and mean edge length, A9), phase-matched to the rest pose; per strand
  /// the helix root-to-tip direction h^v (unit).
  Vec3List helix_edge;
  Vec3List helix_axis;
  int max_strand_size = 0;   ///< largest particle count of any strand.
  double min_mass_kg = 0.0;  ///< smallest non-root particle mass.
  /// Lattice nodes makeState allocates for the "grid" cohesion evaluation: enough for the hair's
  /// largest possible extent (cohesionGridNodeBound); 0 when the evaluation is "exact".
  size_t cohesion_grid_nodes = 0;

  int strandCount() const { return static_cast<int>(strand_offsets.size()) - 1; }
  int particleCount() const { return static_cast<int>(rest_position_head.size()); }
  int strandBegin(int s) const { return static_cast<int>(strand_offsets[s]); }
  int strandSize(int s) const {
    return static_cast<int>(strand_offsets[s + 1] - strand_offsets[s]);
  }
};

/// Builds the model from a groom (head frame) and the solver config (the smoothing lengths and
/// masses enter the precompute of docs/physics.md §9.1). Returns false with a reason on bad input.
bool buildModel(const Groom& groom, double particle_mass_kg, const HeadShape& head,
                const SolverConfig& config, HairModel* model, std::string* why);

/// The helix of eq. (6) for one strand: `count` points with chord `edge_m` (A9), radius and rise
/// per turn from the curl config; a straight line along +z when the radius is 0.
Vec3List makeHelix(int count, double edge_m, double radius_m, double pitch_m);

/// buildModel without validating: only for tests that probe outside the valid range (the
/// flutter bound); the groom must still be structurally valid.
void buildModelUnchecked(const Groom& groom, double particle_mass_kg, const HeadShape& head,
                         const SolverConfig& config, HairModel* model);

}  // namespace wet_curly_hair
