// Configuration of the solver, one struct per component.
// Every field has a default, an SI unit in its name or comment, and a valid range checked by
// validate(), which names the offending field with its dotted scene-YAML name.
#pragma once

#include <initializer_list>
#include <string>
#include <string_view>

#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

// The per-length defaults below are the per-edge constants the project was tuned with at the
// built-in groom's edges (25 cm strands at 32 particles: 8.06 mm), converted by the scalings of
// docs/physics.md §2.11.

/// Stretch spring, eq. (1), with Selle-style strain limiting (docs/physics.md §2.2, §3). Per
/// length (docs/physics.md §2.11): edge i gets k_s = EA / L_i and c_s = C_s / L_i, so a strand
/// refined n times is the same hair.
struct StretchConfig {
  double axial_stiffness_n = 4.0;  ///< EA, N per unit strain (k_s = 500 N/m at 8.06 mm edges).
  double damping_n_s = 9.0e-4;     ///< C_s, N s per unit strain rate (c_s = 0.11 N s/m there).
  double strain_limit = 0.05;      ///< largest edge strain (L - L0) / L0 after each substep.
  /// Velocity clamp inside the damping pass (Iben §2.2a): the axial relative velocity of an edge
  /// may change its length by at most this fraction of the rest length per substep.
  double strain_rate_limit_per_substep = 0.01;
  /// Velocity after a strain-limit projection: "displacement" adds displacement / dt (Selle
  /// 2008); "inelastic" removes the edge's stretching relative velocity (docs/physics.md §3);
  /// "auto" (default) takes inelastic, or displacement while hair contact is on
  /// (SolverConfig::inelasticStrainLimit). Without contact, inelastic: the chart's errors within
  /// 0.4 % of displacement's in every run stable with both and the same verdicts on the hard
  /// cases, but displacement leaves a fast-stretching edge still stretching and the next substep
  /// overshoots by more (the largest strain before limiting on the chart's nod-and-shake scene at
  /// midpoint 1 ms: 9.2 % against 10.8 %, past the chart's stability bound of twice the limit).
  /// With contact (at its own longest substep, 5e-4 s), displacement: inelastic hands the root
  /// side's speed along an edge that a push-out stretched to the tip side, and strands started on
  /// top of each other fail the energy check at 2e-4 s; the split's error is larger too.
  std::string limit_velocity = "auto";
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Bending spring, eq. (4), on frames parallel-transported along the alpha_b-smoothed curve. Per
/// length (docs/physics.md §2.11): a strand with mean edge L gets k_b = B / (L alpha_b^2) and
/// c_b = D_b / L. At coarse resolution buildModel lengthens alpha_b to kMinBendSmoothingEdges
/// edges and raises c_b to kMinBendDampingRatio of critical, where the follower-like force
/// would otherwise flutter (docs/physics.md §10.15), and counts the strands it changed.
struct BendConfig {
  double stiffness_n_m2 = 9.4e-4;  ///< B, N m^2 (k_b = 50 N/m at 8.06 mm edges).
  /// D_b, N s: c_b = D_b / L on the perpendicular relative velocity (0.14 N s/m at 8.06 mm
  /// edges, about critical for the default density there).
  double damping_n_s = 1.13e-3;
  /// alpha_b, the IIR smoothing length of eq. (2), m (six default edges).
  double smoothing_length_m = 0.048;
  /// Add the force's derivative through the frames (bend_gradient.h), so that the bending force
  /// is the gradient of its energy, sum 1/2 k_b |e_i - F_i t_i^loc|^2: the same rest targets and
  /// rest shape, no energy from the frames' motion (docs/physics.md §2.6 "Energy"). Off: Iben's
  /// force with the frames held (eq. 4 as written). Off by default: 4-6 times the step's cost, and
  /// the hair settles at the energy's minimum, which sags more than the built-in scene's look was
  /// tuned for (docs/physics.md §2.6).
  bool frame_gradient = false;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Core spring, eq. (5), on the alpha_c-smoothed curve: keeps curls from unwinding. The same
/// axial law as the stretch spring on the smoothed differences b_i: k_c = K_c / L, c_c = C_c / L.
struct CoreSpringConfig {
  double stiffness_n = 0.4;          ///< K_c, N per unit strain of b (k_c = 50 N/m at 8.06 mm).
  double damping_n_s = 2.8e-4;       ///< C_c, N s (c_c = 0.035 N s/m at 8.06 mm).
  double smoothing_length_m = 0.08;  ///< alpha_c, m (ten default edges).
  /// Apply the core force, computed on the smoothed differences b_i, to the edges through the
  /// filter's transpose (smoothDifferencesAdjoint): the gradient of sum 1/2 k_c (|b_i| -
  /// |b0_i|)^2, and a core damping that never adds energy (explicit method; the implicit block
  /// keeps its local share, coreLocalGain). Off: eq. (5) on edge i alone, as Iben writes it.
  bool filter_gradient = false;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Particle collision with the head (Bridson et al., docs/physics.md §6).
struct CollisionConfig {
  bool head_enabled = true;
  double offset_m = 0.001;  ///< delta: particles are kept this far outside the surface, m.
  double friction = 0.3;    ///< Coulomb coefficient mu, dimensionless.
  /// Extra collision/strain-limit rounds in a substep where a particle touched the head or an
  /// obstacle and the strain limit then moved a particle of that strand. The strain limit runs
  /// after the collisions and can pull a projected particle back inside (with one substep per
  /// frame, 4 mm into a top-knot, measured); each round projects again and limits again,
  /// Gauss-Seidel on the two constraint sets. 0 = one round.
  int constraint_rounds = 3;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Time integration with fixed substeps. "explicit": semi-implicit Euler with separate damping
/// passes (Iben §2.2). The implicit methods solve, per strand, one block-tridiagonal linear system
/// per substep for the velocity that moves the particles (stretch, bend, core and curl springs and
/// every damping term inside the solve, frames held at the start of the substep), a theta method:
/// "backward_euler" (theta 1: stable, damps), "midpoint" (theta 1/2: second order, no numerical
/// damping), "theta" (theta from `theta`).
/// Default midpoint at 1e-3 s: the cheapest setting of the speed-against-error chart that meets
/// 1 % RMS of the strand length over the whole run on every benchmark scene and stays stable on
/// each (docs/bench/defaults.txt, written by the bench; test_config holds these values to it).
/// The explicit method needs 1e-4 s for the same budget and costs about 4 times more.
struct IntegratorConfig {
  std::string method = "midpoint";
  double substep_s = 1.0e-3;  ///< largest substep, s; a frame is split into equal substeps.
  double theta = 0.6;         ///< for method "theta": 1/2 midpoint ... 1 backward Euler.
  /// Threads that advance strands in parallel (OpenMP). Results do not depend on it: strands
  /// couple only between steps, and every reduction is over integers or maxima in a fixed order.
  /// 0 (the default): every hardware thread of the machine, at most kMaxSolverThreads
  /// (resolvedThreads).
  int threads = 0;
  /// threads with 0 resolved to the machine's hardware threads (at least 1).
  int resolvedThreads() const;
  /// Advance strands in blocks, one per SIMD lane (a structure of arrays per block of strands;
  /// the same operations as one strand at a time), every integrator. false: one strand at a
  /// time, the reference path.
  bool strand_lanes = true;
  /// The lanes' arithmetic and strands per block: "double4", "double8" (equal to the one-strand
  /// path to round-off), "float8", "float16" (every operation of a substep in float, positions
  /// relative to the head; the state stays double between steps, so float is rounded in and out
  /// once per step), or "auto": float in one register of the machine the core was compiled for,
  /// float16 with AVX-512, float8 without. One key, so that any value set alone is valid.
  /// Default auto: float costs 0.50-0.70 of double at the same error to 3-4 digits, and a block
  /// wider than one register costs 3x per particle on an AVX2 machine (float16 against float8,
  /// double8 against double4; docs/performance.md "Float or double").
  std::string lane_layout = "auto";
  /// lane_layout with "auto" resolved for this build (no allocation: the block loop asks).
  std::string_view resolvedLaneLayout() const {
    if (lane_layout != "auto") return lane_layout;
#ifdef __AVX512F__
    return "float16";
#else
    return "float8";
#endif
  }
  bool laneFloat() const {
    const std::string_view l = resolvedLaneLayout();
    return l == "float8" || l == "float16";
  }
  int laneWidth() const {
    const std::string_view l = resolvedLaneLayout();
    return l == "float16" ? 16 : l == "double4" ? 4 : 8;
  }
  /// A head that moves faster than this within a step (translation speed, m/s; or turns more than
  /// teleport_angle_rad) has jumped, not moved: the hair is carried rigidly by the jump before
  /// the step and keeps its velocities relative to the head (a tracking glitch or a teleport must
  /// not fling the hair). 0 disables.
  double teleport_speed_m_s = 20.0;
  double teleport_angle_rad = 1.5;
  /// Explicit damping sub-iterations per substep (tau = dt / n). A minimum: the solver uses more
  /// when the substep needs them for the explicit damping to be stable, tau <= 0.9 m / (2 C) with
  /// C the largest damping constant (c_s + c_b + c_c) at a particle of mass m (docs/physics.md
  /// §10.1); see dampingPassCount().
  int damping_passes = 2;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Curl exaggeration toward a helix by saturation, eqs. (6)-(9) of Kim 2023 (A6-A10).
struct CurlConfig {
  bool enabled = true;  ///< acts only on wet particles (saturation > 0).
  /// "spring": the restoring target-edge variant of A10, k_w sigma (M h_edge - e) (default, chosen
  /// by measurement, docs/physics.md §1.2); "literal": eq. (9) as a couple w_h sigma M h_edge.
  std::string mode = "spring";
  /// W, N: w_h (spring: k_w) = W / L for a strand of mean edge L (docs/physics.md §2.11; 25 N/m
  /// at 8.06 mm edges); the force scales with saturation.
  double weight_n = 0.2;
  double helix_radius_m = 0.006;  ///< r of eq. (6): the wet curl's radius, m.
  double helix_pitch_m = 0.018;   ///< rise per turn of the wet curl (2 pi p of eq. 6), m.
  /// M follows the strand's root-to-tip axis with this time constant (s; 0: at once, literal).
  /// docs/physics.md §10.6: M taken at once from the moving axis is a follower load that
  /// self-excites.
  double rotation_time_constant_s = 0.1;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Cohesion of wet strands. "ours": the stable display-position cohesion of eq. (10) (A11-A14),
/// computed after each step and never fed back; "lin" and "kim": force-based reconstructions of
/// Lin 2015 and Kim et al. 2017 (docs/physics.md §4, §5: their exact laws are not public);
/// "off": none.
struct CohesionConfig {
  std::string mode = "ours";
  double tightness = 0.85;  ///< lambda of eq. (10) (A12 blend), dimensionless.
  double radius_m =
      0.04;  ///< kernel support h, m (chosen with include_self, docs/physics.md §1.3).
  /// Include the particle itself in the Shepard weights of eq. (10) (A13). Chosen by measurement
  /// (docs/physics.md §1.3): without it p^w jumps when a neighbour enters the kernel support.
  bool include_self = true;
  /// lin: attraction spring between two pieces of strand, N/m per m of each (a particle pair
  /// gets K l_i l_j with l the length a particle stands for, docs/physics.md §2.11). The default
  /// (0.004 N/m per pair at 8.06 mm edges) clumps the cohesion scene about as much as "ours"
  /// does (docs/physics.md §1.3), so that the comparison is at equal clumping.
  double lin_stiffness_n_per_m3 = 60.0;
  /// kim: Akinci's gamma (force = gamma m_i m_j C(r) + gamma m_i (n_i - n_j), SI), calibrated
  /// the same way.
  double kim_surface_tension = 0.3;
  /// How eq. (10) is evaluated (mode "ours"): "exact" sums over every neighbour within h;
  /// "grid" splats the particles onto a lattice of node spacing h / grid_cells_per_radius
  /// (trilinear) and evaluates the kernel at the nodes, at a cost per particle that does not
  /// grow with the number of neighbours (docs/physics.md §7.3: error and cost). Default grid at
  /// 3 nodes per radius: the cheapest evaluation the bench's cohesion section finds within 1 %
  /// of exact's clump distance and 1 % of the strand length (RMS of p^w) at 100 to 1,000
  /// strands (docs/bench/defaults.txt, held by test_config); exact stays for reference.
  std::string evaluation = "grid";
  int grid_cells_per_radius = 3;  ///< "grid": lattice nodes per kernel radius h, [2, 16].
  /// "grid": the gathers read single-precision copies of the node sums and, like the own-strand
  /// share, evaluate the kernel in float (twice the SIMD lanes); particles whose other-strand
  /// weight is below 1e-2 of their own strand's, where float round-off would dominate the
  /// own-strand cancellation, have both sums redone in double. Chosen by measurement
  /// (docs/physics.md §7.3).
  bool grid_single_precision = true;
  /// "grid": the volumes of eq. (10)'s Shepard weights taken at the lattice's nodes, V = m /
  /// rho(x_n) for a particle's share of node n, instead of at each particle, V = m / rho(p): one
  /// splat of every particle instead of two and no density per particle (the guides' only with
  /// gather_at "guides"). Cheaper, with a larger error against exact (docs/physics.md §7.3);
  /// opt-in.
  bool grid_node_volumes = false;
  /// "grid": where eq. (10)'s sums over all strands are evaluated. "particles": each wet
  /// particle gathers the nodes within h (about 113 at 3 nodes per radius). "nodes": the splatted
  /// sums are convolved once per node with the node kernel and interpolated from a particle's
  /// cell, as the densities are; the own strand is then subtracted as exact pairs where the other
  /// strands outweigh it, else through the same lattice functional (docs/physics.md §7.3). Two
  /// interpolations: at the same lattice their error is larger, at one node per radius more
  /// smaller. "auto", at 3 nodes per radius: the node sums where the hair at rest is dense
  /// enough for their convolution to cost less than the gathers (cohesionLattice), else the
  /// gathers; at other lattices the gathers. Particle volumes only: with grid_node_volumes the
  /// gathers run.
  std::string grid_wet_sums = "auto";
  /// Where eq. (10)'s sums are evaluated when the groom has followers (followers.h): "all"
  /// output particles, or the "guides" only, each follower then taking its guides' display
  /// offsets interpolated as its position is (docs/followers.md: about half the cost, but not a
  /// follower's own offset). Every particle's volume still enters the sums either way.
  std::string gather_at = "all";
  /// Mode "ours": the display offsets p^w - p are evaluated at most this often, s, and held
  /// (applied to the current positions, of wet particles) between evaluations; 0: every step.
  /// Never fed back, so only the display lags (docs/physics.md §7.3: error and cost).
  double refresh_period_s = 0.0;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Adhesion of wet hair to obstacles, eqs. (11)-(12) with Akinci's kernel (A15, A16).
struct AdhesionConfig {
  bool enabled = true;
  /// Peak adhesion acceleration sigma nu A_max at sigma = 1, m/s^2 (nu = 1300 of the paper only
  /// means something in the authors' units; A16). Set this instead of nu.
  double peak_acceleration_m_s2 = 30.0;
  double radius_m = 0.01;           ///< kernel h: attracts for h/2 < distance <= h, m.
  bool literal_polynomial = false;  ///< the paper's polynomial without Akinci's 1/4 power (A15).
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Saturation-dependent stiffness, eq. (13) (A17), in a substep-independent form:
/// v <- (xi zeta_i)^(h / reference_step_s) v, zeta_i = sigma gamma0 + (1 - sigma) gamma1.
struct StiffnessConfig {
  double global_factor = 0.999995;  ///< xi per reference step.
  double wet_factor = 0.9999;       ///< gamma0 per reference step (fully wet).
  double dry_factor = 1.0;          ///< gamma1 per reference step (dry).
  double reference_step_s = 1e-4;   ///< the step the factors are given for, s.
  /// Damp the velocity relative to the head's rigid motion (true) or the absolute velocity
  /// (false, literal): absolute damping makes hair lag a moving head (docs/physics.md §10.2).
  bool relative_to_head = true;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Collision with external obstacles (analytic shapes and the OctoMap field).
struct ObstacleCollisionConfig {
  bool enabled = true;
  double offset_m = 0.005;  ///< delta; also the adhesion rest distance, about h/2 (A16), m.
  double friction = 0.3;
  /// Particles farther than this from every obstacle skip collision and adhesion, m.
  double margin_m = 0.03;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Hair-hair contact, per length (docs/hair_contact.md; hair_contact.h). A sphere stands for the
/// length of strand l_i around it (the pruned particles' shares go to the sphere before them), so a
/// sphere pair gets the stiffness K l_i l_j and damping D l_i l_j: two pieces of hair crossing feel
/// the same force at 32 or 256 particles per strand.
struct HairContactConfig {
  bool enabled = false;
  /// Sphere radius r, m: two spheres of different strands touch closer than 2 r. A simulated
  /// strand stands for a wisp, so r is the wisp's radius, not a hair's; it also has to close
  /// the gaps between spheres along a strand (2 r above the edge length at the resolution used,
  /// or strands slip between spheres: docs/hair_contact.md).
  double radius_m = 0.004;
  /// Iben's pruning sparsity s: walking from the root, the next sphere is the first particle at
  /// least s 2 r from the last one in the rest pose (1: the spheres just touch). (0, 1].
  double sparsity = 0.75;
  /// K, N/m per m of each strand: a sphere pair pushes apart with K l_i l_j (2 r - d).
  double stiffness_n_per_m3 = 5.0e6;
  /// D, N s/m per m of each strand: damping of the normal relative velocity, D l_i l_j.
  double damping_n_s_per_m3 = 2000.0;
  /// Coulomb friction coefficient between strands (the sliding force is at most mu times the
  /// normal force, and never more than stops the pair's sliding within the substep).
  double friction = 0.2;
  /// Stiffness ramp on first contact (full damping from the first substep: Iben), s.
  double ramp_time_s = 0.005;
  /// Stiffness taper after release: a pair that touches again within it resumes where it was, s.
  double taper_time_s = 0.005;
  /// Verlet skin, m: the sphere pairs within 2 r + skin are listed and the list is rebuilt only
  /// when a sphere has moved more than skin / 2 since it was built.
  double skin_m = 0.004;
  /// Longest substep while contact is on, s: the solver splits a frame into substeps no longer
  /// than this or the integrator's substep_s, whichever is shorter (substepCount). The contact
  /// forces are split from the strands' solves (evaluated at the substep's start, the partner
  /// lagged), stable while h^2 k / m stays small: at 1e-3 s two strands started inside each
  /// other at twice the default stiffness ring (energy 1.37x the start, midpoint; the bound the
  /// contact was measured and tested at is 5e-4 s, docs/hair_contact.md).
  double max_substep_s = 5.0e-4;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Everything the step needs besides the model and the inputs.
struct SolverConfig {
  StretchConfig stretch;
  BendConfig bend;
  CoreSpringConfig core;
  CollisionConfig collision;
  IntegratorConfig integrator;
  CurlConfig curl;
  CohesionConfig cohesion;
  AdhesionConfig adhesion;
  StiffnessConfig stiffness;
  ObstacleCollisionConfig obstacle;
  HairContactConfig hair_contact;
  Vec3 gravity_m_s2 = Vec3(0.0, 0.0, -9.81);  ///< world frame, m/s^2.
  /// Sag-free start (docs/physics.md §8, docs/physics.md §8): buildModel solves the stretch rest
  /// lengths and bending targets so that the groom is an equilibrium under gravity_m_s2 on the
  /// head at its start pose (identity orientation, as every scene starts; makeSagFree takes
  /// another head-frame gravity). Needs bend.stiffness_n_m2 > 0 when gravity is not zero.
  bool sag_free = false;
  /// Whether the strain limit removes the stretching velocity (stretch.limit_velocity
  /// "inelastic", or "auto" without hair contact) rather than adding displacement / dt.
  bool inelasticStrainLimit() const {
    return stretch.limit_velocity == "inelastic" ||
           (stretch.limit_velocity == "auto" && !hair_contact.enabled);
  }
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Bending flutter bounds (docs/physics.md §10.15), measured on a hanging curly strand and tested
/// on both sides by test/core/test_solver.cpp (BendingFlutter*), see docs/physics.md §2.6. The
/// follower-like bending force self-excites at any step size when alpha_b is too short for its
/// damping: at critical bend damping it flutters at 2 edge lengths and is calm at 3; at a quarter
/// of critical it flutters at 4 and is calm at 5. buildModel keeps every strand inside both
/// bounds by lengthening alpha_b and raising c_b where the resolution is too coarse for them.
constexpr double kMinBendSmoothingEdges = 4.0;
/// Smallest bend damping ratio c_b / (2 sqrt(k_b m)), with m = rho L the particle mass.
constexpr double kMinBendDampingRatio = 0.5;
/// The explicit integrator's substep is at most this fraction of 2 / omega_max, the stability
/// limit of symplectic Euler on the stiffest particle (docs/physics.md §10.1): the solver splits
/// a frame into more substeps when the resolution needs it. At the built-in scene's 32
/// particles this is 2.3e-4 s on its shortest strands (10 % under 25 cm), above the default
/// substep, which it leaves alone.
constexpr double kExplicitStabilityFraction = 0.6;
/// Largest solver thread count (per-thread scratch is allocated for this many at most).
constexpr int kMaxSolverThreads = 64;

namespace config_check {
/// Helpers used by the validators: each sets *why to "<name>: <reason>" and returns false.
bool finiteInRange(const std::string& name, double value, double lo, double hi, std::string* why);
bool positive(const std::string& name, double value, std::string* why);
bool nonNegative(const std::string& name, double value, std::string* why);
bool finiteVec(const std::string& name, const Vec3& v, std::string* why);
bool oneOf(const std::string& name, const std::string& value,
           std::initializer_list<const char*> allowed, std::string* why);
}  // namespace config_check

}  // namespace wet_curly_hair
