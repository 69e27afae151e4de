// Strands in SIMD lanes (issue 6, part 4). The recurrences of a strand run root to tip (IIR
// smoothing, frame transport, the block-Thomas solve, the strain limit), so they cannot be
// vectorised along the strand; across strands they are the same operations on independent data.
// A block of strands is gathered into a structure of arrays once per step, stays in cache through
// all its substeps (strands couple only through per-step outputs) and is scattered back at the
// end. The blocks are fixed by strand index, so the result does not depend on the thread count.
//
// The block kernel (solver_lanes_block.inc) is compiled once per lane layout: double x 4 (one
// AVX register), double x 8 and float x 16 (one AVX-512 register, two AVX ones without it) and
// float x 8. Which one runs is IntegratorConfig::lane_layout; the benchmark's
// lane section measures them against each other (README, "Float or double").
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#ifdef __AVX__
#include <immintrin.h>
#endif

#include "solver_internal.h"
#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/head_collider.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/springs.h"
#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {
namespace detail {

#define WCH_LANE_REAL double
#define WCH_LANE_FLOAT 0
#define WCH_LANE_WIDTH 4
namespace lanes_double4 {
#include "solver_lanes_block.inc"
}  // namespace lanes_double4
#undef WCH_LANE_WIDTH
#define WCH_LANE_WIDTH 8
namespace lanes_double8 {
#include "solver_lanes_block.inc"
}  // namespace lanes_double8
#undef WCH_LANE_REAL
#undef WCH_LANE_FLOAT
#undef WCH_LANE_WIDTH

#define WCH_LANE_REAL float
#define WCH_LANE_FLOAT 1
#define WCH_LANE_WIDTH 8
namespace lanes_float8 {
#include "solver_lanes_block.inc"
}  // namespace lanes_float8
#undef WCH_LANE_WIDTH
#define WCH_LANE_WIDTH 16
namespace lanes_float16 {
#include "solver_lanes_block.inc"
}  // namespace lanes_float16
#undef WCH_LANE_REAL
#undef WCH_LANE_FLOAT
#undef WCH_LANE_WIDTH

double stepStrandBlock(const HairModel& model, const SolverConfig& config, const StepInputs& inputs,
                       int first_strand, int active, const StrandFlags* flags, int nsub, double h,
                       HairState* state, StrandScratch* scratch, StepStats* stats) {
  // A partial block that fits half the width takes the half-width layout of the same precision:
  // the same operations lane by lane, so the same result, on half the padding.
  const bool single = config.integrator.laneFloat();
  const int width = config.integrator.laneWidth();
  const bool half = active <= width / 2;
  if (single && width == 16 && !half)
    return lanes_float16::stepStrandBlock(model, config, inputs, first_strand, active, flags, nsub,
                                          h, state, scratch, stats);
  if (single)
    return lanes_float8::stepStrandBlock(model, config, inputs, first_strand, active, flags, nsub,
                                         h, state, scratch, stats);
  if (width == 8 && !half)
    return lanes_double8::stepStrandBlock(model, config, inputs, first_strand, active, flags, nsub,
                                          h, state, scratch, stats);
  return lanes_double4::stepStrandBlock(model, config, inputs, first_strand, active, flags, nsub, h,
                                        state, scratch, stats);
}

}  // namespace detail
}  // namespace wet_curly_hair
