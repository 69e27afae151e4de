// layModelLanes: the model's per-particle constants laid once in the strand-block stepper's lanes
// (ModelLanes, model.h), block by block as advanceStrands forms the blocks.
#include "model_lanes.h"

#include "solver_internal.h"

namespace wet_curly_hair {
namespace {

/// Every block of kLaneWidth<S> simulated strands that advanceStrands runs at that width: its
/// place in one allocation, then its lanes, written as the step's gather would write them.
/// `masses_only`: the blocks as they are laid, their masses written again.
template <typename S>
void layBlocks(HairModel* model, bool masses_only) {
  constexpr int kWidth = kLaneWidth<S>;
  ModelLanes& lanes = model->lanes;
  if (!masses_only) {
    const int blocks = (model->simulatedStrandCount() + kWidth - 1) / kWidth;
    lanes.block_offset.assign(blocks, -1);
    lanes.block_particles.assign(blocks, 0);
    int64_t chunks = 0;
    for (int b = 0; b < blocks; ++b) {
      const int active = detail::blockStrands(*model, b * kWidth, kWidth);
      if (active < 2 || detail::blockRunWidth(kWidth, active, lanes.single) != kWidth) continue;
      const int n = model->strandSize(b * kWidth);
      lanes.block_offset[b] = chunks;
      lanes.block_particles[b] = n;
      chunks += static_cast<int64_t>(
          (detail::constantLaneValues(n) * sizeof(S) + sizeof(ModelLanes::Chunk) - 1) /
          sizeof(ModelLanes::Chunk));
    }
    lanes.chunks.assign(static_cast<size_t>(chunks), ModelLanes::Chunk{});
  }
  for (size_t b = 0; b < lanes.block_offset.size(); ++b) {
    if (lanes.block_offset[b] < 0) continue;
    const int first = static_cast<int>(b) * kWidth;
    const int active = detail::blockStrands(*model, first, kWidth);
    int begin[kWidth];
    for (int l = 0; l < kWidth; ++l)  // padding lanes repeat the last strand, as initBlock's
      begin[l] = model->strandBegin(first + std::min(l, active - 1));
    detail::writeConstantLanes(*model, begin, lanes.block_particles[b],
                               reinterpret_cast<S*>(lanes.chunks.data() + lanes.block_offset[b]),
                               masses_only);
  }
}

/// layBlocks in the layout model->lanes names; none known: nothing laid.
void relay(HairModel* model, bool masses_only) {
  const ModelLanes& lanes = model->lanes;
  if (lanes.single && lanes.width == 16) return layBlocks<LaneFloat16>(model, masses_only);
  if (lanes.single && lanes.width == 8) return layBlocks<LaneFloat8>(model, masses_only);
  if (!lanes.single && lanes.width == 8) return layBlocks<LaneDouble8>(model, masses_only);
  if (!lanes.single && lanes.width == 4) return layBlocks<LaneDouble4>(model, masses_only);
  model->lanes = ModelLanes{};  // every block gathered
}

}  // namespace

void relayModelLanes(HairModel* model) { relay(model, false); }

void relayModelMassLanes(HairModel* model) { relay(model, true); }

void layModelLanes(const IntegratorConfig& integrator, HairModel* model) {
  model->lanes = ModelLanes{};
  if (!integrator.strand_lanes) return;
  model->lanes.width = integrator.laneWidth();
  model->lanes.single = integrator.laneFloat();
  relayModelLanes(model);
}

}  // namespace wet_curly_hair
