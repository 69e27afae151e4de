// The strand-block stepper (strand_block.h) in double: one strand at a time (the reference
// path) and blocks of 4 and 8 strands.
#include "strand_block.h"

namespace wet_curly_hair {
namespace detail {

double stepStrandBlockDouble(int width, const HairModel& model, const SolverConfig& config,
                             const SolverPlan& plan, const StepInputs& inputs, int first_strand,
                             int active, const StrandFlags* flags, int k_begin, int k_end, int nsub,
                             double h, HairState* state, StrandScratch* scratch, StepStats* stats) {
  switch (width) {
    case 8:
      return stepStrandBlock<LaneDouble8>(model, config, plan, inputs, first_strand, active, flags,
                                          k_begin, k_end, nsub, h, state, scratch, stats);
    case 4:
      return stepStrandBlock<LaneDouble4>(model, config, plan, inputs, first_strand, active, flags,
                                          k_begin, k_end, nsub, h, state, scratch, stats);
    default:
      return stepStrandBlock<double>(model, config, plan, inputs, first_strand, active, flags,
                                     k_begin, k_end, nsub, h, state, scratch, stats);
  }
}

}  // namespace detail
}  // namespace wet_curly_hair
