// The model's per-particle constants in the strand-block stepper's lanes: one writer for a
// block's lanes, used both by layModelLanes (the copy the model keeps, ModelLanes) and by the
// step's own gather when the model has no such copy for the block. Private to the core library.
#pragma once

#include <cstddef>
#include <type_traits>

#include "wet_curly_hair/core/lane_math.h"
#include "wet_curly_hair/core/model.h"

namespace wet_curly_hair {
namespace detail {

/// One block's constants, lane l holding strand l's: per particle the mass, its inverse and the
/// rest distance from the head; per edge the rest length, the rest core length, the stretch
/// spring's k and c, the bend target in its rest frame and the helix edge.
template <typename S>
struct ConstantLanes {
  const S *m, *inv_m, *rest_head_distance;
  const S *rest, *core_rest, *stretch_k, *stretch_c;
  const V3<S>*local_target, *helix_edge;
};

/// Lane values a block of strands of n particles takes: 3 per particle, 10 per edge.
inline size_t constantLaneValues(int n) { return 3 * size_t(n) + 10 * size_t(n - 1); }

/// Where each array of a block's constants lies in a run of constantLaneValues(n) lane values
/// from `base`, for strands of n particles: the one order the writer and every reader share.
template <typename S>
ConstantLanes<S> constantLanesAt(const S* base, int n) {
  const int edges = n - 1;
  ConstantLanes<S> c;
  c.m = base;
  c.inv_m = c.m + n;
  c.rest_head_distance = c.inv_m + n;
  c.rest = c.rest_head_distance + n;
  c.core_rest = c.rest + edges;
  c.stretch_k = c.core_rest + edges;
  c.stretch_c = c.stretch_k + edges;
  c.local_target = reinterpret_cast<const V3<S>*>(c.stretch_c + edges);
  c.helix_edge = c.local_target + edges;
  return c;
}

/// Writes the constants of the strands whose runs start at begin[0 .. width) (n particles each)
/// to out[0 .. constantLaneValues(n)), array by array and lane by lane (each lane reads one
/// strand's run of one array in order), and returns where each array landed. `masses_only`:
/// the mass and its inverse alone (the rest already there).
template <typename S>
ConstantLanes<S> writeConstantLanes(const HairModel& model, const int* begin, int n, S* out,
                                    bool masses_only = false) {
  constexpr int kWidth = kLaneWidth<S>;
  const int edges = n - 1;
  const ConstantLanes<S> c = constantLanesAt(out, n);
  // The lanes are out's own (the const in ConstantLanes is for the readers).
  auto scalars = [&](const S* at, const double* from, int count) {
    S* to = const_cast<S*>(at);
    for (int l = 0; l < kWidth; ++l) {
      const double* run = from + begin[l];
      for (int i = 0; i < count; ++i) setLaneValue(&to[i], l, run[i]);
    }
  };
  auto vectors = [&](const V3<S>* at, const Vec3* from, int count) {
    V3<S>* to = const_cast<V3<S>*>(at);
    for (int l = 0; l < kWidth; ++l) {
      const Vec3* run = from + begin[l];
      for (int i = 0; i < count; ++i) setLane(&to[i], l, run[i]);
    }
  };
  scalars(c.m, model.mass_kg.data(), n);
  scalars(c.inv_m, model.inv_mass.data(), n);
  if (masses_only) return c;
  scalars(c.rest_head_distance, model.rest_head_distance_m.data(), n);
  scalars(c.rest, model.rest_edge_m.data(), edges);
  scalars(c.core_rest, model.core_rest_m.data(), edges);
  scalars(c.stretch_k, model.stretch_k.data(), edges);
  scalars(c.stretch_c, model.stretch_c.data(), edges);
  vectors(c.local_target, model.bend_local_target.data(), edges);
  vectors(c.helix_edge, model.helix_edge.data(), edges);
  return c;
}

/// The laid constants of the block of strands from first_strand, if the model holds them in the
/// layout S for a block of n particles; null otherwise (the caller gathers them).
template <typename S>
const S* laidConstantLanes(const HairModel& model, int first_strand, int n) {
  const ModelLanes& lanes = model.lanes;
  constexpr bool kFloat = std::is_same<typename LaneTraits<S>::Elem, float>::value;
  if (lanes.width != kLaneWidth<S> || lanes.single != kFloat || first_strand % lanes.width != 0)
    return nullptr;
  const size_t block = static_cast<size_t>(first_strand / lanes.width);
  if (block >= lanes.block_offset.size() || lanes.block_offset[block] < 0 ||
      lanes.block_particles[block] != n)
    return nullptr;
  return reinterpret_cast<const S*>(lanes.chunks.data() + lanes.block_offset[block]);
}

}  // namespace detail
}  // namespace wet_curly_hair
