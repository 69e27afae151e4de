// Sag-free start (docs/physics.md §8, after Hsu et al. 2023): solve the REST parameters of the
// springs, not the positions, so that the groomed pose is an equilibrium under gravity on the still
// head.
#pragma once

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// What makeSagFree changed (all over the whole model).
struct SagFreeStats {
  int edges = 0;                  ///< edges adjusted.
  double max_preload_strain = 0;  ///< largest |e| / |e0| - 1 of the new rest lengths at the groom.
  double max_bend_shift_m = 0;    ///< largest |t'_i - t_i| (bend target shift), m.
  /// Edges whose axial load would have needed more than the preload cap (half the strain limit)
  /// in the stretch spring; the excess went to the bending target instead (still exact).
  int capped_edges = 0;
};

/// Largest preload strain the stretch springs take, as a fraction of solver.stretch.strain_limit:
/// beyond it the strain limiter would pull the groom in at the first substep.
constexpr double kSagFreeMaxPreloadOfStrainLimit = 0.5;

/// Changes model->rest_edge_m and model->bend_local_target so that the elastic forces of the
/// solver (stretch, bend on frames transported along the alpha_b-smoothed groom, core) balance
/// `gravity_head_m_s2` (gravity in the HEAD frame at the start pose) on every non-root particle
/// of the rest pose `model->rest_position_head`. Head contacts are ignored: the whole weight is
/// carried by the strand (a particle resting on the scalp then presses on it with zero force).
/// Needs config.bend.stiffness_n_m2 > 0 when gravity is not zero (SolverConfig::validate
/// checks it for solver.sag_free). Call it on a freshly built model, once.
void makeSagFree(const SolverConfig& config, const Vec3& gravity_head_m_s2, HairModel* model,
                 SagFreeStats* stats = nullptr);

}  // namespace wet_curly_hair
