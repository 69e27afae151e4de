// Configuration of the solver, one struct per component (design.md, style.md §3).
// Every field has a default, an SI unit in its name or comment, and a valid range checked by
// validate(), which names the offending field with its dotted scene-YAML name.
#pragma once

#include <string>

#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Stretch spring, eq. (1), with Selle-style strain limiting (method.md §2.2, §3).
struct StretchConfig {
  double stiffness_n_per_m = 500.0;  ///< k_s, N/m.
  double damping_ns_per_m = 0.11;    ///< c_s, N·s/m (about 0.25 of critical for 1e-4 kg).
  double strain_limit = 0.05;        ///< largest edge strain (L - L0) / L0 after each substep.
  /// Velocity clamp inside the damping pass (Iben §2.2a): the axial relative velocity of an edge
  /// may change its length by at most this fraction of the rest length per substep.
  double strain_rate_limit_per_substep = 0.01;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Bending spring, eq. (4), on frames parallel-transported along the alpha_b-smoothed curve.
struct BendConfig {
  double stiffness_n_per_m = 50.0;  ///< k_b, N/m.
  /// c_b, N·s/m (perpendicular relative velocity): about critical, 2 sqrt(k_b m), for 1e-4 kg.
  /// Below half of critical the bending spring flutters (kMinBendDampingRatio, checked by
  /// buildModel, which knows the masses).
  double damping_ns_per_m = 0.14;
  /// alpha_b, the IIR smoothing length of eq. (2), in mean rest edge lengths (dimensionless).
  /// Below kMinBendSmoothingEdges the follower-like bending force self-excites (method.md §10.15).
  double smoothing_edges = 6.0;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Core spring, eq. (5), on the alpha_c-smoothed curve: keeps curls from unwinding.
struct CoreSpringConfig {
  double stiffness_n_per_m = 50.0;  ///< k_c, N/m.
  double damping_ns_per_m = 0.035;  ///< c_c, N·s/m.
  double smoothing_edges = 10.0;    ///< alpha_c in mean rest edge lengths.
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Particle collision with the head (Bridson et al., method.md §6).
struct CollisionConfig {
  bool head_enabled = true;
  double offset_m = 0.001;  ///< delta: particles are kept this far outside the surface, m.
  double friction = 0.3;    ///< Coulomb coefficient mu, dimensionless.
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Time integration: semi-implicit Euler with fixed substeps and separate damping passes.
struct IntegratorConfig {
  double substep_s = 2.0e-4;  ///< largest substep, s; a frame is split into equal substeps.
  /// Explicit damping sub-iterations per substep (tau = dt / n). A minimum: the solver uses more
  /// when the substep needs them for the explicit damping to be stable, tau <= 0.9 m / (2 C) with
  /// C = c_s + c_b + c_c (method.md §10.1); see dampingPassCount().
  int damping_passes = 2;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Everything the step needs besides the model and the inputs.
struct SolverConfig {
  StretchConfig stretch;
  BendConfig bend;
  CoreSpringConfig core;
  CollisionConfig collision;
  IntegratorConfig integrator;
  Vec3 gravity_m_s2 = Vec3(0.0, 0.0, -9.81);  ///< world frame, m/s^2.
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Bending flutter bounds (method.md §10.15), measured on a hanging curly strand and tested on
/// both sides by test/core/test_solver.cpp (BendingFlutter*), see README "Bending flutter".
/// The follower-like bending force self-excites at any step size when alpha_b is too short for
/// its damping: at critical bend damping it flutters at 2 edge lengths and is calm at 3; at a
/// quarter of critical it flutters at 4 and is calm at 5.
constexpr double kMinBendSmoothingEdges = 4.0;
/// Smallest bend damping ratio c_b / (2 sqrt(k_b m)), with m the particle mass.
constexpr double kMinBendDampingRatio = 0.5;

namespace config_check {
/// Helpers used by the validators: each sets *why to "<name>: <reason>" and returns false.
bool finiteInRange(const std::string& name, double value, double lo, double hi, std::string* why);
bool positive(const std::string& name, double value, std::string* why);
bool nonNegative(const std::string& name, double value, std::string* why);
bool finiteVec(const std::string& name, const Vec3& v, std::string* why);
}  // namespace config_check

}  // namespace wet_curly_hair
