// Grooms: the authored rest shape of the hair, in the head frame (metres, REP-103: x forward,
// y left, z up). Generated on a scalp patch of an ellipsoid head, or imported from a .hair file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Strands as one structure of arrays: strand s owns points [strand_offsets[s],
/// strand_offsets[s+1]), its root first. Strands may have different particle counts.
struct Groom {
  std::vector<uint32_t> strand_offsets{0};  ///< strands + 1 entries.
  Vec3List points;                          ///< head frame, m.
  Vec3List root_normals;  ///< per strand: outward scalp normal at the root (unit).

  int strandCount() const { return static_cast<int>(strand_offsets.size()) - 1; }
  int particleCount() const { return static_cast<int>(points.size()); }
  int strandSize(int s) const {
    return static_cast<int>(strand_offsets[s + 1] - strand_offsets[s]);
  }
  /// Checks offsets, sizes (>= 2 particles per strand), finiteness and non-degenerate edges.
  bool validate(std::string* why) const;
};

/// The head as an ellipsoid centred at the head-frame origin (plus optional capsules, see
/// head_collider.h). The groom generator places roots on its surface.
struct EllipsoidShape {
  Vec3 center_m = Vec3(0.0, 0.0, 0.0);
  Vec3 radii_m = Vec3(0.095, 0.078, 0.11);  ///< semi-axes along head x, y, z, m.
};

/// Largest groom.follow_ratio (one guide per this many strands).
constexpr int kMaxFollowRatio = 1000000;

/// Parameters of the generated groom (scene YAML section `groom`).
struct GroomConfig {
  int strands = 200;            ///< number of strands.
  int particles = 32;           ///< particles per strand, root included.
  double length_m = 0.25;       ///< arc length of each strand, m.
  double curl_radius_m = 0.01;  ///< helix radius, m; 0 gives straight hair.
  double curl_pitch_m = 0.03;   ///< helix rise per turn, m (must be > 0 for curly hair).
  double jitter = 0.1;          ///< relative random variation of radius, pitch, length.
  int seed = 1;                 ///< random seed for root placement, phase and jitter.
  /// rho, kg/m: particle i carries rho (L_{i-1} + L_i) / 2 (lumped; 1e-4 kg per interior particle
  /// at the default 8.06 mm edges).
  double linear_density_kg_per_m = 0.0124;
  double scalp_half_angle_deg = 70;         ///< roots lie within this angle of the scalp axis.
  Vec3 scalp_axis = Vec3(-0.25, 0.0, 1.0);  ///< centre direction of the scalp patch (head frame).
  /// K: one strand in K is simulated (a guide), the others follow their nearest guides
  /// (followers.h); 1 simulates every strand. Applies to a groom read from a .hair file too.
  int follow_ratio = 1;
  /// How the guides are chosen with follow_ratio > 1: "sampled", farthest-point sampling on the
  /// roots (selectGuides), or "first", the groom's first ceil(N / K) strands: guides marked in a
  /// file by their place, as this package's .hair frames write them (guides first). Applies to a
  /// .hair groom too.
  std::string guides = "sampled";
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Generates a groom on the ellipsoid: roots spread over the scalp patch (Fibonacci spiral with
/// jitter), each strand a helix about its root normal with radius ramped in over the first
/// quarter turn (so the hair leaves the scalp along the normal), polyline with equal edge
/// lengths. Deterministic for a given config.
Groom generateGroom(const GroomConfig& config, const EllipsoidShape& head);

/// The point of the ellipsoid's surface nearest x, inside or outside (Eberly, "Distance from a
/// point to an ellipse, an ellipsoid, or a hyperellipsoid"): componentwise p = c + r^2 (x - c) /
/// (r^2 + t), t the root of F(t) = sum_i (r_i (x - c)_i / (r_i^2 + t))^2 - 1, which decreases
/// over t > -r_min^2, found by bisection (t > 0 outside, t < 0 inside). Where that root does not
/// exist (a point inside with no component along the shortest axis, or the centre) the point is
/// taken along the ray from the centre instead.
Vec3 nearestEllipsoidPoint(const EllipsoidShape& e, const Vec3& x);

/// What placeRootsOnScalp did.
struct ScalpPlacement {
  int strands_moved = 0;        ///< strands whose root moved by more than 1 nm.
  double largest_move_m = 0.0;  ///< the longest move of a root, m.
  int particles_inside = 0;     ///< non-root particles inside the ellipsoid after the moves.
};

/// Moves every strand rigidly (each of its points by one vector) so that its root lies on the
/// head's surface point nearest it (nearestEllipsoidPoint), as the generator's roots do, and sets
/// its root normal to the surface normal there. For a groom authored on another head: roots
/// inside the head hold the strand's first edge against the head's collision, and roots above it
/// float. Particles left inside after the move are counted, not moved (the first step's collision
/// pushes them out).
ScalpPlacement placeRootsOnScalp(const EllipsoidShape& head, Groom* groom);

/// The roots deeper inside the ellipsoid than a tolerance: how many, and the deepest, m.
struct RootsInside {
  int count = 0;
  double deepest_m = 0.0;
};

/// The roots of `groom` more than tolerance_m inside the head's ellipsoid (depth: the distance
/// to nearestEllipsoidPoint). A kinematic root inside the head holds its strand's first edge
/// against the head's collision on every substep.
RootsInside rootsInside(const EllipsoidShape& head, const Groom& groom, double tolerance_m);

/// Mean edge length for a helix of radius r and rise per turn `pitch` sampled at equal chords of
/// length `edge`: solves l^2 = 4 r^2 sin^2(dt/2) + (pitch/2pi)^2 dt^2 for the angle step dt by
/// bisection (docs/physics.md A9). Returns dt in (0, pi]; requires edge > 0.
double helixAngleStepForChord(double radius_m, double pitch_m, double edge_m);

}  // namespace wet_curly_hair
