#include "wet_curly_hair/core/state.h"

#include <algorithm>
#include <limits>

#include "wet_curly_hair/core/cohesion_grid.h"
#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {

void StrandScratch::resize(int n) {
  smooth_bend.assign(n, Vec3::Zero());
  smooth_core.assign(n, Vec3::Zero());
  frame.assign(n, Mat3::Identity());
  for (Vec3List* v : {&bend_p, &bend_force, &bend_adjoint}) v->assign(n, Vec3::Zero());
  velocity_factor.assign(n, 1.0);
  // The strand block (strand_block.h, carveBlockArrays): per particle 15 lane vectors of 3 lane
  // values, 3 lane matrices of 9, 11 lane scalars and 2 axial lengths of 2, a lane value being at
  // most 64 bytes (8 doubles or 16 floats), then two 3-vectors of doubles for one lane, plus
  // alignment slack. The followers' placement and the lattice's per-strand own pairs
  // (cohesion_grid.cpp, 12 float arrays of a strand plus 16 each) use it between steps.
  lane_capacity = n;
  step_position.assign(static_cast<size_t>(kBlockStrands) * n, Vec3::Zero());
  step_velocity.assign(static_cast<size_t>(kBlockStrands) * n, Vec3::Zero());
  lane_buffer.assign(static_cast<size_t>(n) * ((15 * 3 + 3 * 9 + 11 + 2 * 2) * 8 + 2 * 3) + 16,
                     0.0);
}

void NeighborGrid::resize(int particles, const std::vector<uint32_t>& strand_offsets) {
  size_t table = 1;
  while (table < 2 * static_cast<size_t>(std::max(particles, 1))) table <<= 1;
  cell_start.assign(table + 1, 0);
  sorted.assign(particles, 0);
  cell_of.assign(particles, 0);
  strand_of.assign(particles, 0);
  sorted_key.assign(particles, 0);
  sorted_strand.assign(particles, 0);
  for (std::vector<double>* v : {&sorted_strand_value, &sorted_x, &sorted_y, &sorted_z,
                                 &sorted_mass, &sorted_volume, &sorted_saturation})
    v->assign(particles, 0.0);
  for (size_t s = 0; s + 1 < strand_offsets.size(); ++s)
    for (uint32_t i = strand_offsets[s]; i < strand_offsets[s + 1]; ++i) strand_of[i] = s;
}

void CohesionNodeGrid::resize(size_t nodes, int particles) {
  const size_t padded = nodes > 0 ? nodes + kCohesionGridPadding : 0;
  for (std::vector<double>* v : {&scalar, &scalar_b, &wet_volume, &qx, &qy, &qz})
    v->assign(padded, 0.0);
  wet_splat.assign(4 * padded, 0.0);
  wet_splat_b.assign(4 * padded, 0.0);
  for (std::vector<float>* v : {&scalar_f, &wet_volume_f, &qx_f, &qy_f, &qz_f})
    v->assign(padded, 0.0f);
  const size_t per_particle = nodes > 0 ? static_cast<size_t>(particles) : 0;
  for (std::vector<double>* v : {&volume, &wet_share, &rx, &ry, &rz}) v->assign(per_particle, 0.0);
  const size_t padded_particles = nodes > 0 ? per_particle + kCohesionFloatLanes : 0;
  for (std::vector<float>* v : {&kx_f, &ky_f, &kz_f, &tx_f, &ty_f, &tz_f, &volume_f, &wet_share_f,
                                &own_weight_f, &own_px_f, &own_py_f, &own_pz_f})
    v->assign(padded_particles, 0.0f);
}

void WaterScratch::resize(int particles, int max_strand_size) {
  strand.assign(3 * static_cast<size_t>(max_strand_size), 0.0);
  edge_m.assign(max_strand_size, 0.0);
  downhill.assign(max_strand_size, 0.0);
  size_t table = 1;
  while (table < 2 * static_cast<size_t>(std::max(particles, 1))) table <<= 1;
  slots.assign(table, Slot());
  exchange_until_s = std::numeric_limits<double>::quiet_NaN();
  used_slots.clear();
  used_slots.reserve(particles);
  cell_of.assign(particles, 0);
  drip_points.clear();
  drip_points.reserve(particles);
}

void resetState(const HairModel& model, const Pose& head_pose, const Twist& head_twist,
                HairState* state) {
  for (int i = 0; i < model.particleCount(); ++i) {
    state->position[i] = head_pose.apply(model.rest_position_head[i]);
    state->velocity[i] = head_twist.velocityAt(state->position[i], head_pose.translation);
  }
  state->wet_position = state->position;
  state->display_is_position = false;
  std::fill(state->display_offset.begin(), state->display_offset.end(), Vec3::Zero());
  state->display_evaluated_s = std::numeric_limits<double>::quiet_NaN();
  for (int s = 0; s < model.strandCount(); ++s) {
    const int begin = model.strandBegin(s);
    const Vec3 axis = state->position[begin + model.strandSize(s) - 1] - state->position[begin];
    state->curl_rotation[s] = axis.norm() > 1e-12
                                  ? helixToHairQuaternion(model.helix_axis[s], axis.normalized())
                                  : Quat::Identity();
  }
  // The followers' exaggerated rest shapes are computed again at the next placement.
  std::fill(state->follower_rest_saturation.begin(), state->follower_rest_saturation.end(),
            std::numeric_limits<double>::quiet_NaN());
  // Hair contact starts over: no pair engaged, the pair list rebuilt at the next substep.
  std::fill(state->hair_contact.engagement.begin(), state->hair_contact.engagement.end(), 0.0);
  state->hair_contact.invalidate();
}

HairState makeState(const HairModel& model, const Pose& head_pose, const Twist& head_twist) {
  HairState state;
  const int n = model.particleCount();
  state.position.assign(n, Vec3::Zero());
  state.velocity.assign(n, Vec3::Zero());
  state.saturation.assign(n, 0.0);
  state.water_kg.assign(n, 0.0);
  state.water_scratch.resize(n, model.max_strand_size);
  state.wet_position.assign(n, Vec3::Zero());
  state.display_offset.assign(n, Vec3::Zero());
  state.curl_rotation.assign(model.strandCount(), Quat::Identity());
  state.stiffness_factor.assign(n, 1.0);
  state.stiffness_factor_saturation.assign(n, std::numeric_limits<double>::quiet_NaN());
  state.stiffness_factor_key.assign(model.strandCount(), StiffnessFactorKey());
  state.external_force.assign(n, Vec3::Zero());
  state.density.assign(n, 0.0);
  state.normal_scratch.assign(n, Vec3::Zero());
  if (model.followers.guide_strands > 0) {
    const size_t guide_particles = model.strand_offsets[model.followers.guide_strands];
    state.guide_position_head.assign(guide_particles, Vec3::Zero());
    state.guide_rest_head.assign(guide_particles, Vec3::Zero());
    state.guide_edge_carry.assign(guide_particles, GuideEdgeCarry());
    state.guide_clump_offset.assign(guide_particles, Vec3::Zero());
    const size_t follower_particles = n - guide_particles;
    state.follower_rest_head.assign(follower_particles, Vec3::Zero());
    state.follower_rest_saturation.assign(follower_particles, 0.0);
    state.follower_rest_key.assign(2 * size_t(model.strandCount() - model.followers.guide_strands),
                                   0.0);
  }
  state.grid.resize(n, model.strand_offsets);
  state.cohesion_grid.resize(model.cohesion_grid_nodes, n);
  state.scratch.resize(kMaxSolverThreads);
  for (StrandScratch& scratch : state.scratch) scratch.resize(model.max_strand_size);
  resetState(model, head_pose, head_twist, &state);
  return state;
}

}  // namespace wet_curly_hair
