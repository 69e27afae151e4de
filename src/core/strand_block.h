// The substep on a block of strands, one strand per SIMD lane, generic over the lane scalar S
// (lane_math.h): S = double is one strand at a time (the reference path), a GCC vector of W
// doubles or floats is a block of W strands. Every path runs this code; the laws it calls are
// the kernels of springs.h, frames.h, head_collider.h and wet_kernels.h. Private to the core.
//
// Why lanes: the recurrences of a strand run root to tip (IIR smoothing, frame transport, the
// block-Thomas solve, the strain limit), so they cannot be vectorised along the strand; across
// strands they are the same operations on independent data. A block is gathered into a
// structure of arrays once per step, stays in cache through all its substeps (strands couple
// only through per-step outputs) and is scattered back at the end. Positions in the block are
// relative to the head's position at the start of the step, so that float keeps 2^-24 of a
// strand length (~20 nm) wherever the head is; every stage is invariant under the shift and the
// obstacle field, in world coordinates, is read at position + origin.
//
// Lanes from `active` on (the last, partial block of the strands) repeat the last strand: they
// compute, but write nothing to the state, count nothing and skip the per-lane stages.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>

#include "model_lanes.h"
#include "solver_internal.h"
#include "wet_curly_hair/core/bend_gradient.h"
#include "wet_curly_hair/core/block_tridiagonal.h"
#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/head_collider.h"
#include "wet_curly_hair/core/lane_math.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/springs.h"
#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {
namespace detail {

/// The block's structure of arrays, carved from the thread's StrandScratch::lane_buffer.
template <typename S>
struct BlockArrays {
  V3<S>*p, *v, *f, *d, *b, *nu, *v_start, *rhs, *target;
  /// The forces of the parts the implicit solve holds (frame and filter gradients) at the start
  /// of the substep, kept for the corrector (correctGradientParts).
  V3<S>* held_force;
  M33<S>*block, *pivot_inverse;
  /// Per particle: the cross-strand forces' own block of the implicit solve (hair contact,
  /// HairContactState::external_block), zero on lanes without one.
  M33<S>* external_block;
  S *sigma, *factor;
  /// The model's constants (ConstantLanes, model_lanes.h): where the model laid them
  /// (HairModel::lanes), or gathered into constant_buffer at each step.
  const S *m, *inv_m, *rest, *core_rest;
  const S *stretch_k, *stretch_c;  ///< per edge (HairModel::stretch_k, stretch_c).
  const S* rest_head_distance;     ///< per particle (HairModel::rest_head_distance_m).
  const V3<S>*local_target, *helix_edge;
  S* constant_buffer;  ///< room for a block's constants (constantLaneValues) when not laid.
  /// Per edge: axialLength of the edge and of the smoothed difference b, as elasticForces formed
  /// them for the stretch and core forces; the implicit terms reuse them (same positions).
  AxialLength<S>*edge_length, *core_length;
  /// Distance caches (distanceNeeded): where each particle's obstacle and head distances were
  /// last evaluated, and how far it may move from there before either may act (negative:
  /// evaluate next time). The head's in the head frame.
  V3<S>*obstacle_anchor, *head_anchor;
  S *obstacle_slack, *head_slack;
  /// What the position updates lost to rounding (compensated summation, float layouts).
  V3<S>* p_carry;
  /// One lane in double, for the rare extra constraint rounds.
  V3<double>*p_one, *v_one;
};

template <typename S>
BlockArrays<S> carveBlockArrays(StrandScratch* scratch) {
  // Aligned to the vector size for the vector loads; the buffer has room for the widest layout.
  constexpr size_t kBytes = sizeof(S);
  char* bytes = reinterpret_cast<char*>(scratch->lane_buffer.data());
  bytes += (kBytes - reinterpret_cast<uintptr_t>(bytes) % kBytes) % kBytes;
  const size_t n = scratch->lane_capacity;
  auto take = [&](size_t scalars) {
    char* r = bytes;
    bytes += scalars * n * kBytes;
    return r;
  };
  auto v3 = [&]() { return reinterpret_cast<V3<S>*>(take(3)); };
  auto m3 = [&]() { return reinterpret_cast<M33<S>*>(take(9)); };
  auto s1 = [&]() { return reinterpret_cast<S*>(take(1)); };
  BlockArrays<S> a;
  a.p = v3(), a.v = v3(), a.f = v3(), a.d = v3(), a.b = v3(), a.nu = v3(), a.v_start = v3();
  a.rhs = v3(), a.target = v3(), a.held_force = v3();
  a.block = m3(), a.pivot_inverse = m3(), a.external_block = m3();
  a.sigma = s1(), a.factor = s1();
  // 13 lane values per particle hold constantLaneValues(n) = 3 n + 10 (n - 1).
  a.constant_buffer = reinterpret_cast<S*>(take(13));
  a.edge_length = reinterpret_cast<AxialLength<S>*>(take(2));
  a.core_length = reinterpret_cast<AxialLength<S>*>(take(2));
  a.obstacle_anchor = v3(), a.obstacle_slack = s1(), a.p_carry = v3();
  a.head_anchor = v3(), a.head_slack = s1();
  bytes += (8 - reinterpret_cast<uintptr_t>(bytes) % 8) % 8;
  a.p_one = reinterpret_cast<V3<double>*>(bytes);
  a.v_one = a.p_one + n;
  return a;
}

/// Everything a stage of the block needs, fixed for the step.
template <typename S>
struct Block {
  static constexpr int kWidth = kLaneWidth<S>;
  static constexpr bool kFloat = std::is_same<typename LaneTraits<S>::Elem, float>::value;
  using Mask = LaneMask<S>;

  const HairModel& model;
  const SolverConfig& config;
  const StepInputs& inputs;
  const SolverPlan& plan;
  HairState* state;
  StrandScratch* scratch;
  StepStats* stats;
  double h;
  int n = 0, edges = 0, active = 0;
  int strand[kWidth], begin[kWidth];
  const StrandFlags* flags;
  Vec3 origin;  ///< the head's position at the start of the step; block positions are relative.
  BlockArrays<S> a;
  // Per-lane stage switches, the same as one strand's.
  bool curl_on[kWidth], obstacle_on[kWidth], adhesion_on[kWidth], stiffness_on[kWidth];
  bool any_curl = false, any_obstacle = false, any_adhesion = false, any_stiffness = false;
  bool any_external = false;
  bool any_external_block = false;  ///< a lane's cross-strand forces have an implicit block.
  Mask curl_mask, stiffness_mask;
  S beta_bend, beta_core, core_gain;
  // Per-strand spring constants (HairModel::bend_k ...): curl_weight is w_h (W / L) on a wet
  // lane, curl_stiffness the same in spring mode only (the implicit block's share).
  S bend_k, bend_c, core_k, core_c, curl_weight, curl_stiffness;
  Mat3 root_frame[kWidth];  ///< the frame of edge 0 at the start of the substep, per lane.
  bool any_core_damping = false;
  S max_strain;
  /// Beyond this distance neither obstacle collision (offset) nor adhesion (kernel support) acts.
  double obstacle_reach = 0.0;

  Block(const HairModel& m, const SolverConfig& c, const StepInputs& in, const SolverPlan& p,
        HairState* st, StrandScratch* scr, StepStats* stt, double step_h)
      : model(m), config(c), inputs(in), plan(p), state(st), scratch(scr), stats(stt), h(step_h) {}

  bool realLane(int l) const { return l < active; }
  uint64_t countActive(const Mask& m) const {
    uint64_t c = 0;
    for (int l = 0; l < active; ++l) c += maskLane(m, l);
    return c;
  }
};

template <typename M>
WCH_INLINE M maskFromBools(const bool* on) {
  if constexpr (std::is_same<M, bool>::value) {
    return on[0];
  } else {
    M r;
    for (int l = 0; l < maskWidth<M>(); ++l) r[l] = on[l] ? -1 : 0;
    return r;
  }
}

// ------------------------------------------------------------------ per-step setup

/// Which optional stages run on which lane, and the per-strand constants.
template <typename S>
void planBlockStages(Block<S>& blk) {
  const SolverConfig& config = blk.config;
  const bool have_obstacles = blk.inputs.obstacles && !blk.inputs.obstacles->empty();
  for (int l = 0; l < Block<S>::kWidth; ++l) {
    const StrandFlags& fl = blk.flags[l];
    blk.curl_on[l] = fl.wet && config.curl.enabled && config.curl.weight_n > 0.0;
    blk.obstacle_on[l] = fl.near_obstacle && have_obstacles && blk.realLane(l);
    blk.adhesion_on[l] = blk.obstacle_on[l] && fl.wet && config.adhesion.enabled &&
                         config.adhesion.peak_acceleration_m_s2 > 0.0;
    blk.stiffness_on[l] = stiffnessActive(config, fl);
    blk.any_curl |= blk.curl_on[l];
    blk.any_obstacle |= blk.obstacle_on[l] && config.obstacle.enabled;
    blk.any_adhesion |= blk.adhesion_on[l];
    blk.any_stiffness |= blk.stiffness_on[l];
    blk.any_external |= fl.external_force && blk.realLane(l);
    blk.any_external_block |= fl.external_force && blk.realLane(l) && blk.plan.implicit &&
                              config.hair_contact.enabled &&
                              !blk.state->hair_contact.external_block.empty();
    const HairModel& model = blk.model;
    const int s = blk.strand[l];
    setLaneValue(&blk.beta_bend, l, model.beta_bend[s]);
    setLaneValue(&blk.beta_core, l, model.beta_core[s]);
    setLaneValue(&blk.core_gain, l, coreLocalGain(model.beta_core[s]));
    setLaneValue(&blk.bend_k, l, model.bend_k[s]);
    setLaneValue(&blk.bend_c, l, model.bend_c[s]);
    setLaneValue(&blk.core_k, l, model.core_k[s]);
    setLaneValue(&blk.core_c, l, model.core_c[s]);
    blk.any_core_damping |= model.core_c[s] > 0.0;
    setLaneValue(&blk.curl_weight, l, blk.curl_on[l] ? model.curl_k[s] : 0.0);
    setLaneValue(&blk.curl_stiffness, l,
                 blk.curl_on[l] && blk.plan.curl_spring ? model.curl_k[s] : 0.0);
  }
  blk.curl_mask = maskFromBools<LaneMask<S>>(blk.curl_on);
  blk.stiffness_mask = maskFromBools<LaneMask<S>>(blk.stiffness_on);
  blk.max_strain = splat<S>(0.0);
  blk.obstacle_reach = std::max(config.obstacle.offset_m, config.adhesion.radius_m);
}

/// gatherArrays' copies of the state, array by array and lane by lane (each lane reads one
/// strand's run of one array in order): positions relative to the origin with what rounding
/// them into the lanes lost (the carry), velocities and saturations. Particle by particle in
/// scalars (every lane's value of every array, 8 strands x 16 arrays read side by side) the
/// gather and scatter cost 1.3x as much at 10,000 strands (AMD EPYC with AVX2, theta 1/240 s:
/// 0.75-0.78 against 0.59-0.60 s per simulated second on one thread, 0.81-1.14 against
/// 0.62-0.66 CPU s on two), with the same lanes to the bit.
template <typename S>
void gatherStateByLane(Block<S>& blk) {
  BlockArrays<S>& a = blk.a;
  const HairState& state = *blk.state;
  constexpr int kWidth = Block<S>::kWidth;
  const int n = blk.n;
  // The carry starts as what rounding the position into the lane lost, and goes back out at the
  // scatter: the position keeps double's resolution from step to step.
  for (int l = 0; l < kWidth; ++l) {
    const Vec3* run = state.position.data() + blk.begin[l];
    for (int i = 0; i < n; ++i) {
      const Vec3 relative = run[i] - blk.origin;
      setLane(&a.p[i], l, relative);
      // Axis by axis: GCC 12 at -O3 compiled the Eigen form lane(a.p[i], l) - relative to zero on
      // the x and y axes, as if the store had not rounded (StrandBlock.TheCarryKeeps... tests).
      const Vec3 held = lane(a.p[i], l);
      setLaneValue(&a.p_carry[i].x, l, held.x() - relative.x());
      setLaneValue(&a.p_carry[i].y, l, held.y() - relative.y());
      setLaneValue(&a.p_carry[i].z, l, held.z() - relative.z());
    }
  }
  for (int l = 0; l < kWidth; ++l) {
    const Vec3* velocity = state.velocity.data() + blk.begin[l];
    const double* saturation = state.saturation.data() + blk.begin[l];
    for (int i = 0; i < n; ++i) setLane(&a.v[i], l, velocity[i]);
    for (int i = 0; i < n; ++i) setLaneValue(&a.sigma[i], l, saturation[i]);
  }
}

#if defined(__AVX512F__)
/// 16 doubles, base[index[l]] for lane l, fetched by two gathers of 8.
struct GatheredRow {
  __m512d low, high;  ///< lanes 0-7 and 8-15
};
WCH_INLINE GatheredRow gatherRow(const double* base, __m512i index) {
  return {_mm512_i32gather_pd(_mm512_castsi512_si256(index), base, 8),
          _mm512_i32gather_pd(_mm512_extracti64x4_epi64(index, 1), base, 8)};
}
/// A gathered row rounded to float, as setLaneValue rounds each lane.
WCH_INLINE LaneFloat16 roundRow(const GatheredRow& r) {
  const __m256d low = _mm256_castps_pd(_mm512_cvtpd_ps(r.low));
  const __m256d high = _mm256_castps_pd(_mm512_cvtpd_ps(r.high));
  return reinterpret_cast<LaneFloat16>(_mm512_insertf64x4(_mm512_castpd256_pd512(low), high, 1));
}
/// The float lanes back in double, less a row: what rounding it into the lanes lost.
WCH_INLINE GatheredRow roundingLoss(const LaneFloat16& rounded, const GatheredRow& r) {
  const __m512 f = reinterpret_cast<__m512>(rounded);
  const __m512d low = _mm512_cvtps_pd(_mm512_castps512_ps256(f));
  const __m512d high =
      _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(f), 1)));
  return {_mm512_sub_pd(low, r.low), _mm512_sub_pd(high, r.high)};
}

/// gatherStateByLane on 16 float lanes, a particle's row at a time: each array's 16 doubles of
/// the row gathered into registers, shifted, rounded and stored as one vector, where the lane
/// by lane copy stored each float on its own (ten stores per particle and lane). The same
/// subtractions and roundings: the same lanes to the bit (StrandBlock.TheRowGather... tests).
/// Indices are 32-bit: for models of fewer than 2^31 / 3 particles (rowGatherFits).
inline void gatherStateByRow(Block<LaneFloat16>& blk) {
  BlockArrays<LaneFloat16>& a = blk.a;
  const HairState& state = *blk.state;
  const double* position = state.position.data()->data();
  const double* velocity = state.velocity.data()->data();
  const double* saturation = state.saturation.data();
  const __m512i begin = _mm512_loadu_si512(blk.begin);
  for (int i = 0; i < blk.n; ++i) {
    const __m512i particle = _mm512_add_epi32(begin, _mm512_set1_epi32(i));
    const __m512i first = _mm512_mullo_epi32(particle, _mm512_set1_epi32(3));
    LaneFloat16* p[3] = {&a.p[i].x, &a.p[i].y, &a.p[i].z};
    LaneFloat16* carry[3] = {&a.p_carry[i].x, &a.p_carry[i].y, &a.p_carry[i].z};
    LaneFloat16* v[3] = {&a.v[i].x, &a.v[i].y, &a.v[i].z};
    for (int axis = 0; axis < 3; ++axis) {
      const __m512i index = _mm512_add_epi32(first, _mm512_set1_epi32(axis));
      GatheredRow relative = gatherRow(position, index);
      const __m512d origin = _mm512_set1_pd(blk.origin[axis]);
      relative = {_mm512_sub_pd(relative.low, origin), _mm512_sub_pd(relative.high, origin)};
      *p[axis] = roundRow(relative);
      *carry[axis] = roundRow(roundingLoss(*p[axis], relative));
      *v[axis] = roundRow(gatherRow(velocity, index));
    }
    a.sigma[i] = roundRow(gatherRow(saturation, particle));
  }
}

/// The row gather's indices fit in 32 bits.
inline bool rowGatherFits(const HairModel& model) {
  return 3 * static_cast<int64_t>(model.particleCount()) < (int64_t{1} << 31);
}
#endif

/// gatherBlock's copies of the state (gatherStateByLane), by rows where this build has them, and
/// the model's per-particle constants, read where the model laid them in lanes
/// (HairModel::lanes) or copied the same way.
template <typename S>
void gatherArrays(Block<S>& blk) {
  BlockArrays<S>& a = blk.a;
  const HairModel& model = blk.model;
  const int n = blk.n;
  for (int i = 0; i < n; ++i) {
    a.obstacle_slack[i] = splat<S>(-1.0);  // the distance caches start empty every step
    a.head_slack[i] = splat<S>(-1.0);
  }
  bool by_rows = false;
#if defined(__AVX512F__)
  if constexpr (std::is_same<S, LaneFloat16>::value) {
    by_rows = rowGatherFits(model);
    if (by_rows) gatherStateByRow(blk);
  }
#endif
  if (!by_rows) gatherStateByLane(blk);
  // The constants where the model laid them (the same lanes to the bit), else gathered here.
  const S* laid = laidConstantLanes<S>(model, blk.strand[0], n);
  const ConstantLanes<S> c =
      laid ? constantLanesAt(laid, n) : writeConstantLanes(model, blk.begin, n, a.constant_buffer);
  a.m = c.m, a.inv_m = c.inv_m, a.rest_head_distance = c.rest_head_distance;
  a.rest = c.rest, a.core_rest = c.core_rest, a.stretch_k = c.stretch_k, a.stretch_c = c.stretch_c;
  a.local_target = c.local_target, a.helix_edge = c.helix_edge;
}

/// State and the model's per-particle constants into the lanes.
template <typename S>
void gatherBlock(Block<S>& blk) {
  BlockArrays<S>& a = blk.a;
  const HairModel& model = blk.model;
  for (int l = 0; l < Block<S>::kWidth; ++l) {
    // A padding lane repeats the last real strand, whose factors the scratch already holds.
    if (blk.realLane(l))
      prepareStrandStep(model, blk.config, blk.plan, blk.strand[l], blk.flags[l], blk.h, blk.state,
                        blk.scratch);
    for (int i = 0; i < blk.n; ++i)
      setLaneValue(&a.factor[i], l, blk.stiffness_on[l] ? blk.scratch->velocity_factor[i] : 1.0);
  }
  gatherArrays(blk);
}

/// Lane l's strand out of the lanes, as the state holds it: world positions and velocities in
/// double, into p and v (blk.n each).
template <typename S>
void scatterLane(const Block<S>& blk, int l, Vec3* p, Vec3* v) {
  const BlockArrays<S>& a = blk.a;
  for (int i = 0; i < blk.n; ++i) {
    p[i] = (lane(a.p[i], l) - lane(a.p_carry[i], l)) + blk.origin;
    v[i] = lane(a.v[i], l);
  }
  if constexpr (Block<S>::kFloat) {
    // The limit holds to float's resolution in the lanes (a position to ~2^-24 of its distance
    // from the head, 1e-8 m, is 2e-6 of an 8 mm edge): the scatter applies it once more in
    // double, root to tip, so that no output edge is longer than the limit. A projection by at
    // most that resolution: positions only, the velocities are the dynamics'.
    const double* rest = &blk.model.rest_edge_m[blk.begin[l]];
    for (int i = 0; i < blk.edges; ++i)
      p[i + 1] +=
          limitEdgeLength(p[i], p[i + 1], (1.0 + blk.config.stretch.strain_limit) * rest[i]);
  }
}

#if defined(__AVX512F__)
/// Half `half` of a float16 row (lanes 0-7 or 8-15) in double.
WCH_INLINE LaneDouble8 widenHalf(const LaneFloat16& row, int half) {
  const __m512 f = reinterpret_cast<__m512>(row);
  const __m256 part = half == 0 ? _mm512_castps512_ps256(f)
                                : _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(f), 1));
  return _mm512_cvtps_pd(part);
}

/// Lane l's run of n particles out of rows of 16 lanes in double (row i, axis a, lane l at
/// rows[48 i + 16 a + l]) into `to`: eight particles (24 doubles) at a time by three gathers of
/// eight, the rest one by one. Element by element, the copy made the scatter 6.5 % of a profile
/// of 160 strands in cache; by gathers, 4.2 %.
WCH_INLINE void copyLaneOutOfRows(const double* rows, int l, int n, Vec3* to) {
  // Output k of a group (particle k / 3, axis k % 3) sits 48 (k / 3) + 16 (k % 3) = 16 k past the
  // group's first row, lane l.
  const __m256i at[3] = {_mm256_setr_epi32(0, 16, 32, 48, 64, 80, 96, 112),
                         _mm256_setr_epi32(128, 144, 160, 176, 192, 208, 224, 240),
                         _mm256_setr_epi32(256, 272, 288, 304, 320, 336, 352, 368)};
  double* out = to->data();
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const double* base = rows + 48 * i + l;
    for (int part = 0; part < 3; ++part)
      _mm512_storeu_pd(out + 3 * i + 8 * part, _mm512_i32gather_pd(at[part], base, 8));
  }
  for (; i < n; ++i) {
    const int row = 48 * i + l;
    to[i] = Vec3(rows[row], rows[row + 16], rows[row + 32]);
  }
}

/// scatterLane on 16 float lanes, a particle's row at a time, eight lanes in double at once: the
/// same subtractions and additions, and the output edge limit of limitEdgeLength on 8 lanes, root
/// to tip (lane by lane it took each lane's 9 floats out of the vectors one at a time and limited
/// each edge in scalars). On the way it forms the post-step check's verdict on what it outputs,
/// by its laws (finiteValue and edgeLongerThan, as strandFinite and strandStrainOk do). The rows
/// go to the block's free arrays in double (the implicit solve's, unused after the substeps),
/// then each strand is written out from there: a healthy one straight into the state, the
/// others into their scratch runs for commitStrandAfterStep. Returns the lanes written to the
/// state (bit l), whose strands the caller need not commit: the same verdict and the same values,
/// to the bit, as scatterLane with the check (StrandBlock.TheRowScatter... test).
inline uint32_t scatterStateByRow(Block<LaneFloat16>& blk) {
  typedef LaneDouble8 D;
  const BlockArrays<LaneFloat16>& a = blk.a;
  const int n = blk.n;
  // Row i's lanes in double, axis by axis: 2 halves of 8 per axis; positions in the block
  // matrices' room (9 vectors of 16 floats per particle), velocities in the pivots'.
  D* out_p = reinterpret_cast<D*>(a.block);
  D* out_v = reinterpret_cast<D*>(a.pivot_inverse);
  static_assert(sizeof(M33<LaneFloat16>) >= 6 * sizeof(D), "a row fits a particle's matrix");
  const double* rest = blk.model.rest_edge_m.data();
  const D stretch_bound = splat<D>(1.0 + blk.config.stretch.strain_limit);
  const D check_bound = splat<D>(1.0 + 3.0 * blk.config.stretch.strain_limit);
  const D origin[3] = {splat<D>(blk.origin.x()), splat<D>(blk.origin.y()),
                       splat<D>(blk.origin.z())};
  // The two halves of the row (lanes 0-7 and 8-15) side by side: two independent chains of the
  // limit's square root and division from root to tip.
  __m256i first_edge[2];
  for (int half = 0; half < 2; ++half)
    first_edge[half] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(blk.begin + 8 * half));
  // The lanes' rest lengths, edge by edge, gathered ahead of the chain that reads them.
  D* rest_rows = reinterpret_cast<D*>(a.rhs);
  static_assert(sizeof(V3<LaneFloat16>) >= 2 * sizeof(D), "an edge's rows fit a particle's vector");
  for (int i = 0; i + 1 < n; ++i)
    for (int half = 0; half < 2; ++half)
      rest_rows[2 * i + half] =
          _mm512_i32gather_pd(_mm256_add_epi32(first_edge[half], _mm256_set1_epi32(i)), rest, 8);
  LaneMask<D> ok[2] = {LaneMask<D>{} - 1, LaneMask<D>{} - 1};
  V3<D> previous[2];
  for (int i = 0; i < n; ++i) {
    const LaneFloat16* p_rows[3] = {&a.p[i].x, &a.p[i].y, &a.p[i].z};
    const LaneFloat16* carry_rows[3] = {&a.p_carry[i].x, &a.p_carry[i].y, &a.p_carry[i].z};
    const LaneFloat16* v_rows[3] = {&a.v[i].x, &a.v[i].y, &a.v[i].z};
    for (int half = 0; half < 2; ++half) {
      D p[3], v[3];
      for (int axis = 0; axis < 3; ++axis) {
        p[axis] =
            (widenHalf(*p_rows[axis], half) - widenHalf(*carry_rows[axis], half)) + origin[axis];
        v[axis] = widenHalf(*v_rows[axis], half);
      }
      V3<D> here{p[0], p[1], p[2]};
      if (i > 0) {
        const D rest_edge = rest_rows[2 * (i - 1) + half];
        // The limit moves nothing where every lane's edge is clearly within it (its square
        // root and division, a chain from root to tip, are then skipped).
        const D longest = stretch_bound * rest_edge;
        const V3<D> stretched = here - previous[half];
        if (anyLane(!(dot(stretched, stretched) < (longest * longest) * (1.0 - 1e-12))))
          here += limitEdgeLength(previous[half], here, longest);
        const V3<D> e = here - previous[half];
        ok[half] &= ~edgeLongerThan(e.x, e.y, e.z, check_bound * rest_edge);
      }
      const D position[3] = {here.x, here.y, here.z};
      for (int axis = 0; axis < 3; ++axis) {
        ok[half] &= finiteValue(position[axis]) & finiteValue(v[axis]);
        out_p[(3 * i + axis) * 2 + half] = position[axis];
        out_v[(3 * i + axis) * 2 + half] = v[axis];
      }
      previous[half] = here;
    }
  }
  // Each strand out of the rows, to the state or to its scratch run.
  const double* row_p = reinterpret_cast<const double*>(out_p);
  const double* row_v = reinterpret_cast<const double*>(out_v);
  StrandScratch& scr = *blk.scratch;
  uint32_t written = 0;
  for (int l = 0; l < blk.active; ++l) {
    const bool healthy = ok[l / 8][l % 8] != 0;
    Vec3* to_p = healthy ? &blk.state->position[blk.begin[l]] : &scr.step_position[size_t(l) * n];
    Vec3* to_v = healthy ? &blk.state->velocity[blk.begin[l]] : &scr.step_velocity[size_t(l) * n];
    copyLaneOutOfRows(row_p, l, n, to_p);
    copyLaneOutOfRows(row_v, l, n, to_v);
    written |= uint32_t(healthy) << l;
  }
  return written;
}
#endif

/// The lanes into the scratch (StrandScratch::step_position), strand after strand, where the
/// post-step check reads them before they reach the state (commitStrandAfterStep). Returns the
/// lanes whose strands it already checked and wrote to the state (bit l; none lane by lane).
template <typename S>
uint32_t scatterBlock(Block<S>& blk) {
#if defined(__AVX512F__)
  if constexpr (std::is_same<S, LaneFloat16>::value) return scatterStateByRow(blk);
#endif
  StrandScratch& scr = *blk.scratch;
  for (int l = 0; l < blk.active; ++l)
    scatterLane(blk, l, &scr.step_position[size_t(l) * blk.n],
                &scr.step_velocity[size_t(l) * blk.n]);
  return 0;
}

// ------------------------------------------------------------------ the stages of a substep

/// 1-2. Roots carried rigidly by the head to the end of the substep (their velocity lands them
/// there exactly), the smoothed curves, frames parallel-transported along the alpha_b curve and
/// the bend targets t_i = F_i e_i^loc (physics.md §2.3-2.5, §9.2 steps 1-2).
template <typename S>
V3<S> rootsFramesTargets(Block<S>& blk, const SubstepMotion& motion) {
  BlockArrays<S>& a = blk.a;
  V3<S> root_next;
  M33<S> frame;
  for (int l = 0; l < Block<S>::kWidth; ++l) {
    setLane(&root_next, l,
            motion.pose1.apply(blk.model.rest_position_head[blk.begin[l]]) - blk.origin);
    blk.root_frame[l] = motion.r0 * blk.model.root_frame_head[blk.strand[l]];
    setLane(&frame, l, blk.root_frame[l]);
  }
  a.v[0] = (root_next - a.p[0]) / splat<S>(blk.h);
  smoothDifferences(a.p, blk.n, blk.beta_bend, a.d);
  V3<S> tangent = column(frame, 0), normal = column(frame, 1);
  a.target[0] = frame * a.local_target[0];
  for (int i = 1; i < blk.edges; ++i) {
    transportFrame(a.d[i - 1], i, &tangent, &normal);
    a.target[i] = inFrame(tangent, normal, a.local_target[i]);
  }
  smoothDifferences(a.p, blk.n, blk.beta_core, a.b);
  return root_next;
}

/// 3. Gravity (and the force-based cohesion baselines' cross-strand forces), stretch, bend and
/// core springs, eqs. (1), (4), (5); segment convention F_i += f, F_{i+1} -= f (A1).
template <typename S>
void elasticForces(Block<S>& blk) {
  BlockArrays<S>& a = blk.a;
  const V3<S> gravity = splat3<S>(blk.config.gravity_m_s2);
  for (int i = 0; i < blk.n; ++i) a.f[i] = a.m[i] * gravity;
  if (blk.any_external)
    for (int l = 0; l < blk.active; ++l)
      if (blk.flags[l].external_force)
        for (int i = 0; i < blk.n; ++i)
          setLane(&a.f[i], l, lane(a.f[i], l) + blk.state->external_force[blk.begin[l] + i]);
  const bool core_local = !blk.plan.core_filter_gradient;
  for (int i = 0; i < blk.edges; ++i) {
    const V3<S> e = a.p[i + 1] - a.p[i];
    a.edge_length[i] = axialLength(e);
    a.core_length[i] = axialLength(a.b[i]);
    V3<S> fs = stretchForce(e, a.edge_length[i], a.rest[i], a.stretch_k[i]) +
               bendForce(e, a.target[i], blk.bend_k);
    if (core_local) fs += coreForce(a.b[i], a.core_length[i], a.core_rest[i], blk.core_k);
    a.f[i] += fs;
    a.f[i + 1] -= fs;
  }
  if (core_local && !blk.plan.bend_frame_gradient) return;
  // The parts through the filter and the frames: kept apart for the implicit corrector
  // (correctGradientParts), straight into the forces for the explicit method.
  V3<S>* parts = blk.plan.implicit ? a.held_force : a.f;
  if (blk.plan.implicit)
    for (int i = 0; i < blk.n; ++i) parts[i] = zero3<S>();
  if (!core_local) {
    // a.nu is free until the damping recomputes it.
    for (int i = 0; i < blk.edges; ++i)
      a.nu[i] = coreForce(a.b[i], a.core_length[i], a.core_rest[i], blk.core_k);
    applyEdgeForcesThroughFilter(blk, a.nu, parts);
  }
  if (blk.plan.bend_frame_gradient) bendFrameGradientForces(blk, a.p, parts);
  if (blk.plan.implicit)
    for (int i = 0; i < blk.n; ++i) a.f[i] += parts[i];
}

/// Forces g_i computed on the alpha_c-smoothed differences b_i (eq. 5) applied to the edges through
/// the filter's transpose (smoothDifferencesAdjoint), so that the core spring is the gradient of
/// its energy sum 1/2 k_c (|b_i| - |b0_i|)^2 (CoreSpringConfig::filter_gradient): added to the
/// particle forces f. g is overwritten.
template <typename S>
void applyEdgeForcesThroughFilter(Block<S>& blk, V3<S>* g, V3<S>* f) {
  smoothDifferencesAdjoint(g, blk.n, blk.beta_core, g);
  for (int i = 0; i < blk.edges; ++i) {
    f[i] += g[i];
    f[i + 1] -= g[i];
  }
}

/// The bending force's part through the frames (BendConfig::frame_gradient, bend_gradient.h) at
/// the positions x, lane by lane in double, added to the particle forces f.
template <typename S>
void bendFrameGradientForces(Block<S>& blk, const V3<S>* x, V3<S>* f) {
  BlockArrays<S>& a = blk.a;
  StrandScratch& scr = *blk.scratch;
  for (int l = 0; l < blk.active; ++l) {
    for (int i = 0; i < blk.n; ++i) {
      scr.bend_p[i] = lane(x[i], l) - lane(a.p_carry[i], l);
      scr.bend_force[i].setZero();
    }
    addBendFrameGradientForce(scr.bend_p.data(), blk.n, laneValue(blk.beta_bend, l),
                              blk.root_frame[l], &blk.model.bend_local_target[blk.begin[l]],
                              laneValue(blk.bend_k, l), scr.frame.data(), scr.smooth_bend.data(),
                              scr.bend_adjoint.data(), scr.bend_force.data());
    for (int i = 1; i < blk.n; ++i) setLane(&f[i], l, lane(f[i], l) + scr.bend_force[i]);
  }
}

/// Curl exaggeration, eqs. (6)-(9) (A6-A10), on the wet lanes: each strand's helix edges turned
/// by M (helix root-to-tip onto the hair's, A7), pulled on with the saturation of the edge.
/// Returns the particles it ran on.
template <typename S>
uint64_t curlForces(Block<S>& blk) {
  BlockArrays<S>& a = blk.a;
  M33<S> rot = splat33<S>(Mat3::Identity());
  Vec3 root_to_tip[Block<S>::kWidth];
  bool update[Block<S>::kWidth];
  for (int l = 0; l < Block<S>::kWidth; ++l) {
    update[l] = blk.curl_on[l] && blk.realLane(l);
    root_to_tip[l] = lane(a.p[blk.n - 1], l) - lane(a.p[0], l);
  }
  updateCurlRotations(blk.model, blk.strand, root_to_tip, update, Block<S>::kWidth,
                      curlFollowFraction(blk.config.curl, blk.h), blk.state);
  for (int l = 0; l < Block<S>::kWidth; ++l)
    if (blk.curl_on[l])
      setLane(&rot, l, blk.state->curl_rotation[blk.strand[l]].toRotationMatrix());
  const S w = blk.curl_weight;
  for (int i = 0; i < blk.edges; ++i) {
    const S s = splat<S>(0.5) * (a.sigma[i] + a.sigma[i + 1]);
    const auto on = blk.curl_mask && (s > splat<S>(0.0));
    const V3<S> u =
        curlForce(rot * a.helix_edge[i], a.p[i + 1] - a.p[i], w * s, blk.plan.curl_spring);
    const V3<S> masked = select(on, u, zero3<S>());
    a.f[i + 1] += masked;
    a.f[i] -= masked;
  }
  uint64_t lanes_on = 0;
  for (int l = 0; l < blk.active; ++l) lanes_on += blk.curl_on[l];
  const uint64_t particles = uint64_t(blk.n) * lanes_on;
  blk.stats->curl_particle_substeps += particles;
  return particles;
}

/// The obstacles' distance at particle i on the lanes of `lanes`, remembered there for the cache
/// above. L = 1 for the analytic shapes (and the field's extension outside its box), L <= sqrt(3)
/// for the trilinear field (each partial derivative is a weighted mean of sample differences
/// over one voxel, at most one voxel each): the slack takes L = 2.
template <typename S>
S obstacleDistance(Block<S>& blk, int i, const LaneMask<S>& lanes, V3<S>* normal) {
  BlockArrays<S>& a = blk.a;
  const S dist = blk.inputs.obstacles->distance(a.p[i], blk.origin, lanes, normal);
  a.obstacle_anchor[i] = select(lanes, a.p[i], a.obstacle_anchor[i]);
  a.obstacle_slack[i] =
      select(lanes, splat<S>(0.5) * (dist - splat<S>(blk.obstacle_reach)), a.obstacle_slack[i]);
  return dist;
}

/// Adhesion, eqs. (11)-(12) (A15-A16): wet particles between h/2 and h from an obstacle surface
/// are pulled toward it, with peak acceleration sigma * peak at 3h/4. Returns the particles
/// evaluated.
template <typename S>
uint64_t adhesionForces(Block<S>& blk) {
  BlockArrays<S>& a = blk.a;
  const AdhesionConfig& ad = blk.config.adhesion;
  const S scale =
      splat<S>(ad.peak_acceleration_m_s2 / adhesionKernelPeak(ad.radius_m, ad.literal_polynomial));
  const double norm = adhesionNorm(ad.radius_m);
  const LaneMask<S> on = maskFromBools<LaneMask<S>>(blk.adhesion_on);
  LaneCounts<S> evaluated, pulled_count;
  for (int i = 1; i < blk.n; ++i) {
    const LaneMask<S> needed = on && (a.sigma[i] > splat<S>(0.0)) &&
                               distanceNeeded(a.p[i], a.obstacle_anchor[i], a.obstacle_slack[i]);
    if (!anyLane(needed)) continue;
    V3<S> normal;
    const S dist = obstacleDistance(blk, i, needed, &normal);
    const S ak = adhesionKernel(dist, ad.radius_m, norm, ad.literal_polynomial);
    const LaneMask<S> pulled = needed && (ak > splat<S>(0.0));
    a.f[i] -= select(pulled, (a.sigma[i] * a.m[i] * scale * ak) * normal, zero3<S>());
    evaluated.add(needed);
    pulled_count.add(pulled);
  }
  blk.stats->adhesion_active += pulled_count.total();
  blk.stats->adhesion_particle_substeps += evaluated.total();
  return evaluated.total();
}

/// 4-5 explicit: semi-implicit Euler on the forces, roots excluded, then the damping passes with
/// tau = h / n_d (the damping terms of eqs. 1, 4, 5; physics.md §9.2 step 5) and the velocity
/// clamp root -> tip (Iben §2.2a). The perpendicular relative velocity of eq. (4) is measured in
/// the frame turning with the head: a strand co-rotating rigidly with it has dv = omega x e,
/// which the literal term would drag on (bending steadily spinning hair by c_b omega / k_b,
/// 0.6 % of the strand length at 0.25 rev/s, measured); subtracting omega x e makes the damping
/// vanish on rigid co-rotation and leaves it unchanged on a still head.
template <typename S>
void explicitVelocityUpdate(Block<S>& blk, const V3<S>& omega) {
  BlockArrays<S>& a = blk.a;
  const int n = blk.n;
  const bool core_damping = blk.any_core_damping;
  for (int i = 1; i < n; ++i) a.v[i] += (splat<S>(blk.h) * a.inv_m[i]) * a.f[i];
  const int passes = blk.plan.damping_passes;
  const S tau = splat<S>(blk.h / passes);
  for (int pass = 0; pass < passes; ++pass) {
    if (core_damping) smoothDifferences(a.v, n, blk.beta_core, a.nu);
    for (int i = 0; i < n; ++i) a.f[i] = zero3<S>();
    for (int i = 0; i < blk.edges; ++i) {
      const V3<S> e = a.p[i + 1] - a.p[i];
      const V3<S> dv = a.v[i + 1] - a.v[i];
      V3<S> fd = stretchDampingForce(e, dv, a.stretch_c[i]) +
                 bendDampingForce(e, dv - cross(omega, e), blk.bend_c);
      if (core_damping && !blk.plan.core_filter_gradient)
        fd += coreDampingForce(a.b[i], a.nu[i], blk.core_c);
      a.f[i] += fd;
      a.f[i + 1] -= fd;
    }
    if (core_damping && blk.plan.core_filter_gradient) {
      // Through the filter's transpose, as the core spring (elasticForces): then the damping's
      // power is -c_c sum (nu_i . b^_i)^2, never positive.
      for (int i = 0; i < blk.edges; ++i) a.rhs[i] = coreDampingForce(a.b[i], a.nu[i], blk.core_c);
      applyEdgeForcesThroughFilter(blk, a.rhs, a.f);
    }
    for (int i = 1; i < n; ++i) a.v[i] += (tau * a.inv_m[i]) * a.f[i];
  }
  // The clamp is explicit only: it keeps the explicit stretch spring stable. Applied to v+ of a
  // theta method it breaks the scheme's consistency (measured: midpoint at 1e-3 s on the
  // built-in scene reached strain 13.6 before limiting with it, 0.035 without).
  const S rate = splat<S>(blk.config.stretch.strain_rate_limit_per_substep / blk.h);
  for (int i = 0; i < blk.edges; ++i) {
    const V3<S> vnew =
        clampAxialRelativeVelocity(a.p[i + 1] - a.p[i], a.v[i], a.v[i + 1], rate * a.rest[i]);
    const auto changed =
        (vnew.x != a.v[i + 1].x) || (vnew.y != a.v[i + 1].y) || (vnew.z != a.v[i + 1].z);
    if (!anyLane(changed)) continue;
    a.v[i + 1] = vnew;
    blk.stats->velocity_clamps += blk.countActive(changed);
  }
}

/// The cross-strand forces' own implicit blocks (hair contact) into the lanes that have them.
template <typename S>
void gatherExternalBlocks(Block<S>& blk) {
  const Mat3List& ext = blk.state->hair_contact.external_block;
  for (int l = 0; l < Block<S>::kWidth; ++l) {
    const bool on = blk.realLane(l) && blk.flags[l].external_force;
    for (int i = 0; i < blk.n; ++i)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          setLaneValue(&blk.a.external_block[i].m[r][c], l, on ? ext[blk.begin[l] + i](r, c) : 0.0);
  }
}

/// The implicit system of the block's strands (solveSymmetricBlockTridiagonal): a.rhs
/// eliminated, the solution u into a.v[1 .. n-1].
template <typename S>
void solveBlockTridiagonal(Block<S>& blk) {
  BlockArrays<S>& a = blk.a;
  solveSymmetricBlockTridiagonal(blk.n, a.m, a.block,
                                 blk.any_external_block ? a.external_block : nullptr, a.rhs,
                                 a.pivot_inverse, a.v);
}

/// The largest change of an edge over the corrector's lead, relative to the edge, at which the
/// corrector still acts (it fades to nothing there): 5 % of an edge per half substep.
/// Measured on the 4 Hz shake (docs/physics.md §2.6): with no such limit the corrector blows up
/// at 1 ms and 1/240 s; with 2 %, 5 % or 10 % every method stays as bounded as with the parts
/// taken at the start of the substep.
constexpr double kGradientCorrectorTrust = 0.05;

/// How far lane by lane the predicted half step x + lead u0 can be trusted: 1 - (r / trust)^2
/// for the largest change r of an edge relative to its length, 0 from r = kGradientCorrectorTrust.
template <typename S>
S correctorTrust(const Block<S>& blk, const S& lead) {
  const BlockArrays<S>& a = blk.a;
  S worst = splat<S>(0.0);
  for (int i = 0; i < blk.edges; ++i) {
    const V3<S> e = a.p[i + 1] - a.p[i];
    const V3<S> de = lead * (a.v[i + 1] - a.v[i]);
    worst = vmax(worst, dot(de, de) / vmax(dot(e, e), splat<S>(1e-24)));
  }
  const double trust2 = kGradientCorrectorTrust * kGradientCorrectorTrust;
  return vmax(splat<S>(0.0), splat<S>(1.0) - worst / splat<S>(trust2));
}

/// The parts the implicit solve holds at the start of the substep (the bending force through the
/// frames, the core force through the filter: BendConfig::frame_gradient,
/// CoreSpringConfig::filter_gradient) taken instead at the predicted middle of the substep,
/// x + (h/2) u0, u0 the first solve's velocity in a.v: the change of those forces goes to the
/// right-hand side and the same system is solved once more (the root prescribed, so its change
/// is zero). At the middle of the step their work equals minus their energy's change to second
/// order, so midpoint, which has no numerical damping, settles at rest; scaled by correctorTrust,
/// since a far prediction makes the correction explode under violent motion. Overwrites a.f,
/// a.nu, a.rhs and a.target (free until the next substep).
template <typename S>
void correctGradientParts(Block<S>& blk, const S& theta_h) {
  BlockArrays<S>& a = blk.a;
  const int n = blk.n;
  const S lead = splat<S>(0.5 * blk.h);
  const S trust = correctorTrust(blk, lead);
  bool any = false;
  for (int l = 0; l < blk.active; ++l) any = any || laneValue(trust, l) > 0.0;
  if (!any) return;
  for (int i = 1; i < n; ++i) a.target[i - 1] = a.v[i];           // u0
  for (int i = 0; i < n; ++i) a.rhs[i] = a.p[i] + lead * a.v[i];  // the predicted middle
  // The change of the held parts: theirs at the middle minus theirs at the start (a.held_force).
  for (int i = 0; i < n; ++i) a.f[i] = splat<S>(-1.0) * a.held_force[i];
  if (blk.plan.core_filter_gradient) {
    smoothDifferences(a.rhs, n, blk.beta_core, a.nu);
    for (int i = 0; i < blk.edges; ++i) a.nu[i] = coreForce(a.nu[i], a.core_rest[i], blk.core_k);
    applyEdgeForcesThroughFilter(blk, a.nu, a.f);
  }
  if (blk.plan.bend_frame_gradient) bendFrameGradientForces(blk, a.rhs, a.f);
  for (int i = 1; i < n; ++i) a.rhs[i] = (trust * theta_h) * a.f[i];
  solveBlockTridiagonal(blk);  // the change of u, into a.v[1..n-1]
  for (int i = 1; i < n; ++i) a.v[i] = a.target[i - 1] + a.v[i];
}

/// 4-5 implicit: a theta method on the velocity u that moves the particles,
/// x+ = x + h u, v+ = v + (u - v) / theta, with the forces linearised about the start of the
/// substep: M (u - v) = theta h [f(x) + theta h K u + D(u)], D the damping. Per edge the coupling
/// block G (edgeImplicitTerms) gives
///   (m_i + G_{i-1} + G_i) u_i - G_{i-1} u_{i-1} - G_i u_{i+1} = m_i v_i + theta h f_i,
/// a block-tridiagonal system solved root to tip (block Thomas), the root's u prescribed.
template <typename S>
void implicitVelocitySolve(Block<S>& blk, const V3<S>& omega) {
  BlockArrays<S>& a = blk.a;
  const int n = blk.n;
  const double theta = blk.plan.theta;
  EdgeImplicitParams<S> q;
  q.k_b = blk.bend_k, q.k_c = blk.core_k, q.c_b = blk.bend_c, q.c_c = blk.core_c;
  q.core_damping = blk.any_core_damping;
  q.theta_h = splat<S>(theta * blk.h);
  if (q.core_damping) smoothDifferences(a.v, n, blk.beta_core, a.nu);
  for (int i = 0; i < blk.edges; ++i) {
    q.k_s = a.stretch_k[i], q.c_s = a.stretch_c[i];
    const S curl = blk.curl_stiffness * splat<S>(0.5) * (a.sigma[i] + a.sigma[i + 1]);
    const EdgeImplicitTerms<S> t = edgeImplicitTerms(
        q, a.p[i + 1] - a.p[i], a.edge_length[i], a.v[i + 1] - a.v[i], a.rest[i], a.b[i],
        a.core_length[i], a.core_rest[i], a.nu[i], blk.core_gain, curl, omega);
    a.block[i] = t.block;
    a.f[i] += t.explicit_force;
    a.f[i + 1] -= t.explicit_force;
  }
  for (int i = 0; i < n; ++i) a.v_start[i] = a.v[i];
  if (blk.any_external_block) gatherExternalBlocks(blk);
  const S th = q.theta_h;
  for (int i = 1; i < n; ++i) a.rhs[i] = a.m[i] * a.v[i] + th * a.f[i];
  a.rhs[1] += a.block[0] * a.v[0];  // the prescribed root velocity moved to the right-hand side
  solveBlockTridiagonal(blk);
  if (blk.plan.bend_frame_gradient || blk.plan.core_filter_gradient) correctGradientParts(blk, th);
  const S inv_theta = splat<S>(1.0 / theta);
  for (int i = 1; i < n; ++i) a.v[i] = a.v_start[i] + inv_theta * (a.v[i] - a.v_start[i]);
}

/// 6. Stiffness, eq. (13) (A17), on the lanes it acts on: v <- (xi zeta_i)^(h / h_ref) v, on the
/// velocity relative to the head's rigid motion (or the absolute velocity, literal option).
template <typename S>
void stiffenVelocities(Block<S>& blk, const SubstepMotion& motion, const V3<S>& omega) {
  BlockArrays<S>& a = blk.a;
  const bool relative = blk.config.stiffness.relative_to_head;
  const V3<S> head_velocity = splat3<S>(motion.head_velocity);
  const V3<S> head_origin = splat3<S>(Vec3(motion.pose0.translation - blk.origin));
  for (int i = 1; i < blk.n; ++i) {
    const V3<S> carried =
        relative ? head_velocity + cross(omega, a.p[i] - head_origin) : zero3<S>();
    a.v[i] = select(blk.stiffness_mask, stiffenVelocity(a.v[i], a.factor[i], carried), a.v[i]);
  }
}

/// p += dx. In float with Kahan's compensation: an increment h v is often below the resolution
/// of a position 0.1-0.3 m from the head (2^-24 of it, 1-2e-8 m, is h v at 1e-4 m/s and 2e-4 s),
/// and plain rounding would stall slow particles and leave hair at rest jittering by that much.
template <typename S>
inline void advancePosition(V3<S>* p, V3<S>* carry, const V3<S>& dx) {
  if constexpr (std::is_same<typename LaneTraits<S>::Elem, float>::value) {
    const V3<S> y = dx - *carry;
    const V3<S> t = *p + y;
    *carry = (t - *p) - y;
    *p = t;
  } else {
    *p += dx;
  }
}

/// 8. Positions: with the new velocity (explicit), with the theta-weighted one (implicit, equal
/// to the solved u unless eq. 13 changed v+).
template <typename S>
void advancePositions(Block<S>& blk, const V3<S>& root_next) {
  BlockArrays<S>& a = blk.a;
  const S h = splat<S>(blk.h);
  a.p[0] = root_next;
  if (!blk.plan.implicit) {
    for (int i = 1; i < blk.n; ++i) advancePosition(&a.p[i], &a.p_carry[i], h * a.v[i]);
  } else {
    const S w0 = splat<S>(1.0 - blk.plan.theta), w1 = splat<S>(blk.plan.theta);
    for (int i = 1; i < blk.n; ++i)
      advancePosition(&a.p[i], &a.p_carry[i], h * (w0 * a.v_start[i] + w1 * a.v[i]));
  }
}

/// What the head distance cache leaves of its slack for round-off: float lanes hold the
/// head-frame position and the bound to ~1e-7 m (2^-24 of a strand's reach from the head).
constexpr double kHeadCacheMargin_m = 1e-6;

/// 7. Head collision (physics.md §6) of particles 1..n-1 of every lane: projection to the offset
/// surface, inelastic, Coulomb friction, the head's velocity at the particle from the two poses.
/// Adds each lane's contacts to touched[lane]. A particle's offset is delta or its rest distance
/// from the head, whichever is smaller: near the root of a fine strand the rest pose lies inside
/// delta (particle 1 of a 256-particle strand is 1 mm from the scalp), where the projection out
/// to delta and the strain limit of the root edge would fight on every substep and pump
/// velocity (measured: 2.5 m/s, held). With anchor and slack (else null), a distance cache in
/// the head frame (distanceNeeded, L = 1: HeadShape::distance's lower bound) skips the rows no
/// lane of which can be in contact.
template <typename S>
void collideHeadParticles(const HairModel& model, const CollisionConfig& config,
                          const SubstepMotion& motion, const Vec3& origin, double h,
                          const S* rest_distance, V3<S>* anchor, S* slack, V3<S>* p, V3<S>* v,
                          int n, uint64_t* touched) {
  const M33<S> r0 = splat33<S>(motion.r0), r1 = splat33<S>(motion.r1);
  const M33<S> r1_inverse = splat33<S>(motion.r1_inverse);
  const V3<S> t0 = splat3<S>(Vec3(motion.pose0.translation - origin));
  const V3<S> t1 = splat3<S>(Vec3(motion.pose1.translation - origin));
  for (int i = 1; i < n; ++i) {
    const V3<S> x_head = r1_inverse * (p[i] - t1);
    if (anchor && !anyLane(distanceNeeded(x_head, anchor[i], slack[i]))) continue;
    V3<S> n_head;
    S bound;
    const S dist = model.head.distance(x_head, &n_head, anchor ? &bound : nullptr);
    const S offset = vmin(splat<S>(config.offset_m), vmax(rest_distance[i], splat<S>(0.0)));
    if (anchor) {
      anchor[i] = x_head;
      slack[i] = bound - offset - splat<S>(kHeadCacheMargin_m);
    }
    const auto contact = dist < offset;
    if (!anyLane(contact)) continue;
    const V3<S> v_head = (p[i] - (r0 * x_head + t0)) / splat<S>(h);
    collideParticle(contact, dist, r1 * n_head, offset, config.friction, v_head, &p[i], &v[i]);
    // Lane by lane on the rows that touch (few): a LaneCounts held through the loop, one more
    // register beside the head's three matrices, cost the stage 2 % (10,000 strands, Zen 4).
    for (int l = 0; l < kLaneWidth<S>; ++l) touched[l] += maskLane(contact, l);
  }
}

/// The same against the (static, world-frame) external obstacles, on the lanes of `on` where the
/// distance cache cannot rule a contact out (no cache: every particle); distance(i, lanes,
/// &normal) reads the obstacles at particle i. Returns the particles evaluated; adds contacts to
/// touched[lane].
template <typename S, typename DistanceFn>
uint64_t collideObstacleParticles(const ObstacleCollisionConfig& config, const bool* on,
                                  DistanceFn&& distance, const V3<S>* anchor, const S* slack,
                                  V3<S>* p, V3<S>* v, int n, uint64_t* touched) {
  const LaneMask<S> on_mask = maskFromBools<LaneMask<S>>(on);
  const S offset = splat<S>(config.offset_m);
  LaneCounts<S> evaluated, contacts;
  for (int i = 1; i < n; ++i) {
    LaneMask<S> needed = on_mask;
    if (anchor) needed = needed && distanceNeeded(p[i], anchor[i], slack[i]);
    if (!anyLane(needed)) continue;
    V3<S> normal;
    const S dist = distance(i, needed, &normal);
    const LaneMask<S> contact = needed && (dist < offset);
    evaluated.add(needed);
    contacts.add(contact);
    if (anyLane(contact))
      collideParticle(contact, dist, normal, offset, config.friction, zero3<S>(), &p[i], &v[i]);
  }
  for (int l = 0; l < kLaneWidth<S>; ++l) touched[l] += contacts.lane(l);
  return evaluated.total();
}

/// 9. Strain limiting root -> tip with velocity correction (Selle 2008, physics.md §2.2b), every
/// lane. Adds each lane's projected edges to projected[lane]; *max_strain takes the largest
/// strain before the projection.
template <typename S>
void limitStrainEdges(const S* rest, double strain_limit, bool inelastic, double h, V3<S>* p,
                      V3<S>* v, int n, S* max_strain, uint64_t* projected) {
  // The edges before the first row with a lane near or past the limit cannot move: their strains
  // are taken without the root-to-tip chain (each edge's square root and division waits on the
  // last edge's projection there), the same values in the same order. Clear of the limit: the
  // squared length below the squared limit less a margin far above float's rounding, where
  // clampEdgeLength's own test (on the rounded square root) is within too.
  const S clear = splat<S>((1.0 + strain_limit) * (1.0 + strain_limit) * (1.0 - 1e-5));
  int first = 0;
  for (; first + 1 < n; ++first) {
    const V3<S> e = p[first + 1] - p[first];
    const S length2 = dot(e, e);
    if (anyLane(!(length2 < clear * (rest[first] * rest[first])))) break;
    *max_strain = vmax(*max_strain, vsqrt(length2) / rest[first] - splat<S>(1.0));
  }
  for (int i = first; i + 1 < n; ++i) {
    const V3<S> e = p[i + 1] - p[i];
    *max_strain = vmax(*max_strain, vsqrt(dot(e, e)) / rest[i] - splat<S>(1.0));
    const V3<S> disp = limitEdgeLength(p[i], p[i + 1], splat<S>(1.0 + strain_limit) * rest[i]);
    const auto moved = dot(disp, disp) > splat<S>(0.0);
    if (!anyLane(moved)) continue;
    p[i + 1] = select(moved, p[i + 1] + disp, p[i + 1]);
    if (inelastic) {
      // Remove the edge's stretching relative velocity, from the tip-side particle (the root side
      // is final): nothing is added when a collider keeps pushing the particle back out every
      // substep, as the displacement would be. Not an impulse shared by the pair: where the root
      // side moves fast along the edge the tip side takes its speed (strands started on top of
      // each other, pushed apart by hair contact at 2e-4 s: peak energy 1.49 J against 0.41 J
      // with the displacement; docs/hair_contact.md), so "auto" takes the displacement while
      // contact is on. Shared by the pair, it pushed the edge before and the nod-and-shake
      // stretched 20 % before the limit at 1e-3 s, against 9.2 %.
      V3<S> edge = p[i + 1] - p[i];
      const S len2 = dot(edge, edge);
      edge = select(len2 > splat<S>(0.0), edge / vsqrt(len2), edge);
      const S along = dot(v[i + 1] - v[i], edge);
      v[i + 1] = select(moved && (along > splat<S>(0.0)), v[i + 1] - along * edge, v[i + 1]);
    } else {
      v[i + 1] = select(moved, v[i + 1] + disp / splat<S>(h), v[i + 1]);  // Selle: as an impulse
    }
    for (int l = 0; l < kLaneWidth<S>; ++l) projected[l] += maskLane(moved, l);
  }
}

/// Further collision + limit rounds on one lane after a substep's first
/// (CollisionConfig::constraint_rounds), where something touched and the limit then moved a
/// particle: only that can have pulled a projected particle back in. Project again and limit
/// again until nothing is inside or nothing moves (or the rounds run out); the strain limit runs
/// last, so the edge bound holds exactly. In double, on the lane's copy. Returns the rounds run.
template <typename S>
uint64_t extraConstraintRounds(Block<S>& blk, const SubstepMotion& motion, int l, uint64_t touched,
                               uint64_t projected) {
  BlockArrays<S>& a = blk.a;
  const SolverConfig& config = blk.config;
  const int n = blk.n;
  for (int i = 0; i < n; ++i)
    a.p_one[i] = toV3(lane(a.p[i], l)), a.v_one[i] = toV3(lane(a.v[i], l));
  const double* rest = &blk.model.rest_edge_m[blk.begin[l]];
  const bool obstacles = blk.obstacle_on[l] && config.obstacle.enabled;
  auto distance = [&](int i, bool lanes, V3<double>* normal) {
    return blk.inputs.obstacles->distance(a.p_one[i], blk.origin, lanes, normal);
  };
  uint64_t rounds = 0;
  for (int round = 0; touched > 0 && projected > 0 && round < config.collision.constraint_rounds;
       ++round) {
    touched = 0;
    if (config.collision.head_enabled)
      collideHeadParticles<double>(blk.model, config.collision, motion, blk.origin, blk.h,
                                   &blk.model.rest_head_distance_m[blk.begin[l]], nullptr, nullptr,
                                   a.p_one, a.v_one, n, &touched);
    if (obstacles)
      collideObstacleParticles<double>(config.obstacle, &obstacles, distance, nullptr, nullptr,
                                       a.p_one, a.v_one, n, &touched);
    if (touched == 0) break;
    double unused = 0.0;
    projected = 0;
    limitStrainEdges(rest, config.stretch.strain_limit, blk.plan.inelastic_limit, blk.h, a.p_one,
                     a.v_one, n, &unused, &projected);
    ++rounds;
  }
  for (int i = 1; i < n; ++i)
    setLane(&a.p[i], l, toEigen(a.p_one[i])), setLane(&a.v[i], l, toEigen(a.v_one[i]));
  return rounds;
}

/// 7 and 9: head and obstacle collision, then the strain limit, then the extra rounds where
/// they are needed.
template <typename S>
void collideAndLimit(Block<S>& blk, const SubstepMotion& motion, StageLaps& laps) {
  BlockArrays<S>& a = blk.a;
  const SolverConfig& config = blk.config;
  const int n = blk.n;
  uint64_t touched[Block<S>::kWidth] = {};
  if (config.collision.head_enabled) {
    collideHeadParticles(blk.model, config.collision, motion, blk.origin, blk.h,
                         a.rest_head_distance, a.head_anchor, a.head_slack, a.p, a.v, n, touched);
    for (int l = 0; l < blk.active; ++l) blk.stats->head_contacts += touched[l];
    laps.lap(kStageHeadCollision, uint64_t(n - 1) * blk.active);
  }
  if (blk.any_obstacle) {
    bool on[Block<S>::kWidth];
    for (int l = 0; l < Block<S>::kWidth; ++l)
      on[l] = blk.obstacle_on[l] && config.obstacle.enabled;
    uint64_t obstacle_touched[Block<S>::kWidth] = {};
    auto distance = [&](int i, const LaneMask<S>& lanes, V3<S>* normal) {
      return obstacleDistance(blk, i, lanes, normal);
    };
    const uint64_t evaluated =
        collideObstacleParticles<S>(config.obstacle, on, distance, a.obstacle_anchor,
                                    a.obstacle_slack, a.p, a.v, n, obstacle_touched);
    // Obstacle positions are world coordinates: the lambda reads at p + origin, and
    // collideParticle moved the lane's relative position by the same projection.
    for (int l = 0; l < blk.active; ++l) {
      blk.stats->obstacle_contacts += obstacle_touched[l];
      touched[l] += obstacle_touched[l];
    }
    blk.stats->obstacle_particle_substeps += evaluated;
    laps.lap(kStageObstacleCollision, evaluated);
  }
  uint64_t projected[Block<S>::kWidth] = {};
  limitStrainEdges(a.rest, config.stretch.strain_limit, blk.plan.inelastic_limit, blk.h, a.p, a.v,
                   n, &blk.max_strain, projected);
  for (int l = 0; l < blk.active; ++l) {
    blk.stats->strain_limited_edges += projected[l];
    if (touched[l] == 0 || projected[l] == 0 || config.collision.constraint_rounds == 0) continue;
    blk.stats->constraint_rounds += extraConstraintRounds(blk, motion, l, touched[l], projected[l]);
  }
  laps.lap(kStageStrainLimit, uint64_t(n - 1) * blk.active);
}

/// One substep of the block: the recipe of physics.md §9.2.
template <typename S>
void substepBlock(Block<S>& blk, const SubstepMotion& motion) {
  StageLaps laps(blk.inputs.clock, blk.stats);
  const uint64_t particles = uint64_t(blk.n) * blk.active;
  const V3<S> omega = splat3<S>(motion.omega);
  const V3<S> root_next = rootsFramesTargets(blk, motion);
  laps.lap(kStageFrames, particles);
  elasticForces(blk);
  laps.lap(kStageForces, particles);
  if (blk.any_curl) {
    laps.lap(kStageCurl, curlForces(blk));
  }
  if (blk.any_adhesion) laps.lap(kStageAdhesion, adhesionForces(blk));
  if (blk.plan.implicit)
    implicitVelocitySolve(blk, omega);
  else
    explicitVelocityUpdate(blk, omega);
  if (blk.any_stiffness) stiffenVelocities(blk, motion, omega);
  advancePositions(blk, root_next);
  laps.lap(kStageIntegrate, particles);
  collideAndLimit(blk, motion, laps);
}

/// Sets up the block of `active` strands from first_strand (flags: one per lane, the padding
/// lanes repeating the last strand's) and gathers it into the lanes.
template <typename S>
void initBlock(Block<S>* blk, int first_strand, int active, const StrandFlags* flags) {
  const HairModel& model = blk->model;
  blk->n = model.strandSize(first_strand);
  blk->edges = blk->n - 1;
  blk->active = active;
  blk->flags = flags;
  for (int l = 0; l < Block<S>::kWidth; ++l) {
    blk->strand[l] = first_strand + std::min(l, active - 1);
    blk->begin[l] = model.strandBegin(blk->strand[l]);
  }
  blk->origin = blk->inputs.head_start.translation;
  blk->a = carveBlockArrays<S>(blk->scratch);
  planBlockStages(*blk);
  gatherBlock(*blk);
}

/// Substeps k_begin .. k_end - 1 of a step of nsub substeps for the block of `active` strands
/// from first_strand. Returns the largest strain before limiting.
template <typename S>
double stepStrandBlock(const HairModel& model, const SolverConfig& config, const SolverPlan& plan,
                       const StepInputs& inputs, int first_strand, int active,
                       const StrandFlags* flags, int k_begin, int k_end, int nsub, double h,
                       HairState* state, StrandScratch* scratch, StepStats* stats) {
  Block<S> blk(model, config, inputs, plan, state, scratch, stats, h);
  StageLaps laps(inputs.clock, stats);
  initBlock(&blk, first_strand, active, flags);
  laps.lap(kStageLanes, uint64_t(blk.n) * active);
  for (int k = k_begin; k < k_end; ++k)
    substepBlock(blk, substepMotion(inputs, double(k) / nsub, double(k + 1) / nsub, h));
  laps.skip();  // the substeps charged their own stages
  const uint32_t written = scatterBlock(blk);
  laps.lap(kStageLanes, 0);
  // The post-step check, the strands in cache. The state still holds what the block started
  // from, at the start of substep k_begin: each strand goes there when healthy, else is restored
  // from it (with coupled strands, which step a substep at a time, every substep is checked).
  const Pose from =
      k_begin == 0
          ? inputs.head_start
          : substepMotion(inputs, double(k_begin) / nsub, double(k_begin + 1) / nsub, h).pose0;
  const Pose to =
      k_end == nsub
          ? inputs.head_end
          : substepMotion(inputs, double(k_end - 1) / nsub, double(k_end) / nsub, h).pose1;
  const StrandScratch& scr = *blk.scratch;
  for (int l = 0; l < active; ++l) {
    if (written >> l & 1u) continue;
    commitStrandAfterStep(model, config, from, to, (k_end - k_begin) * h, blk.strand[l],
                          &scr.step_position[size_t(l) * blk.n],
                          &scr.step_velocity[size_t(l) * blk.n], state, stats);
  }
  laps.lap(kStageRepair, uint64_t(blk.n) * active);
  double largest = laneValue(blk.max_strain, 0);
  for (int l = 1; l < active; ++l) largest = std::max(largest, laneValue(blk.max_strain, l));
  return largest;
}

}  // namespace detail
}  // namespace wet_curly_hair
