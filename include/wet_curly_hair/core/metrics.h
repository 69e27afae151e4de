// Measurements of the hair's shape used to reproduce the paper's comparisons (docs/paper.md):
// clump tightness, tangles, curl radius and pitch of the tips.
#pragma once

#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/state.h"

namespace wet_curly_hair {

/// Mean distance (m) from each wet particle's position in `points` to the nearest point of
/// another strand, searched within search_radius_m (farther counts as search_radius_m). Uses
/// state->grid as scratch. Returns 0 when no particle is wet.
double clumpDistance(const HairModel& model, const Vec3List& points,
                     const std::vector<double>& saturation, double search_radius_m,
                     NeighborGrid* grid);

/// Number of segment pairs of different strands closer than 2 * strand_radius_m (touching
/// strands), from `points`. Uses the grid as scratch.
int tangleCount(const HairModel& model, const Vec3List& points, double strand_radius_m,
                NeighborGrid* grid);

/// Curl radius and rise per turn (m) of a polyline from its discrete curvature kappa and torsion
/// tau: a helix has r = kappa / (kappa^2 + tau^2), pitch = 2 pi tau / (kappa^2 + tau^2).
struct CurlShape {
  double radius_m = 0.0;
  double pitch_m = 0.0;
};
/// Mean over strands of the curl shape of their tip third (mean curvature and torsion over it).
CurlShape tipCurlShape(const HairModel& model, const Vec3List& points);

/// Distance between segments [a0, a1] and [b0, b1] (m).
double segmentDistance(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1);

}  // namespace wet_curly_hair
