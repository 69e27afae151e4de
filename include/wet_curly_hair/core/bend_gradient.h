// The bending force of eq. (4) made the gradient of its energy (issue: energy-consistent
// bending). Iben's force k_b (t_i - e_i) holds the frames F_i fixed, but the frames, and with them
// the targets t_i = F_i t_i^loc, follow the alpha_b-smoothed curve of the current positions: the
// force is not the gradient of E = sum 1/2 k_b |e_i - F_i t_i^loc|^2 (Solver,
// BendForceIsNotAnEnergyGradient), and under a violent drive it pumps energy (docs/hard_cases.md,
// the 4 Hz shake). This adds the missing part, -dE/dp through the frames, by reverse-mode
// differentiation of the chain positions -> smoothed differences d (eq. 2, linear) -> unit
// tangents -> minimal rotations (rodrigues) -> frames -> targets. With it the bending force is
// -dE/dp exactly, for the same energy, the same rest targets and so the same rest shape.
#pragma once

#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Adds to force[0 .. n-1] the frame part of -dE/dp for one strand: `p` its n positions, `beta`
/// its alpha_b filter constant, `root_frame` the frame of edge 0 (world), `local_target` the n - 1
/// rest targets in their frames, `k_b` the bending constant. The frames-held part, k_b (t_i - e_i)
/// on each edge, is the caller's (bendForce). Where a smoothed difference is shorter than
/// kDirectionEpsilon the transport keeps the previous frame (transportFrame) and nothing flows
/// through it. Scratch: `frames` and `d` hold n - 1 entries, `adjoint` n - 1.
void addBendFrameGradientForce(const Vec3* p, int n, double beta, const Mat3& root_frame,
                               const Vec3* local_target, double k_b, Mat3* frames, Vec3* d,
                               Vec3* adjoint, Vec3* force);

/// The bending energy E = sum 1/2 k_b |e_i - F_i t_i^loc|^2 of one strand, frames from the
/// current positions exactly as the solver builds them (for the tests and the diagnostics).
double bendEnergyOfStrand(const Vec3* p, int n, double beta, const Mat3& root_frame,
                          const Vec3* local_target, double k_b);

}  // namespace wet_curly_hair
