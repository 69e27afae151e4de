// The strand-block stepper (strand_block.h) in float: blocks of 8 and 16 strands (every
// operation of a substep in float; the state stays double between steps).
#include "strand_block.h"

namespace wet_curly_hair {
namespace detail {

double stepStrandBlockFloat(int width, const HairModel& model, const SolverConfig& config,
                            const SolverPlan& plan, const StepInputs& inputs, int first_strand,
                            int active, const StrandFlags* flags, int k_begin, int k_end, int nsub,
                            double h, HairState* state, StrandScratch* scratch, StepStats* stats) {
  if (width == 16)
    return stepStrandBlock<LaneFloat16>(model, config, plan, inputs, first_strand, active, flags,
                                        k_begin, k_end, nsub, h, state, scratch, stats);
  return stepStrandBlock<LaneFloat8>(model, config, plan, inputs, first_strand, active, flags,
                                     k_begin, k_end, nsub, h, state, scratch, stats);
}

}  // namespace detail
}  // namespace wet_curly_hair
