#include "wet_curly_hair/core/config.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <thread>

namespace wet_curly_hair {
namespace config_check {

bool finiteInRange(const std::string& name, double value, double lo, double hi, std::string* why) {
  if (!std::isfinite(value) || value < lo || value > hi) {
    if (why) {
      std::ostringstream s;
      s << name << ": " << value << " is outside the valid range [" << lo << ", " << hi << "]";
      *why = s.str();
    }
    return false;
  }
  return true;
}

bool positive(const std::string& name, double value, std::string* why) {
  if (!std::isfinite(value) || value <= 0.0) {
    if (why) {
      std::ostringstream s;
      s << name << ": " << value << " must be a finite number greater than 0";
      *why = s.str();
    }
    return false;
  }
  return true;
}

bool nonNegative(const std::string& name, double value, std::string* why) {
  if (!std::isfinite(value) || value < 0.0) {
    if (why) {
      std::ostringstream s;
      s << name << ": " << value << " must be a finite number not below 0";
      *why = s.str();
    }
    return false;
  }
  return true;
}

bool finiteVec(const std::string& name, const Vec3& v, std::string* why) {
  if (!v.allFinite()) {
    if (why) *why = name + ": every component must be finite";
    return false;
  }
  return true;
}

bool oneOf(const std::string& name, const std::string& value,
           std::initializer_list<const char*> allowed, std::string* why) {
  std::string list;
  for (const char* a : allowed) {
    if (value == a) return true;
    list += (list.empty() ? "" : ", ") + std::string(a);
  }
  if (why) *why = name + ": '" + value + "' is not one of " + list;
  return false;
}

}  // namespace config_check

using namespace config_check;

bool StretchConfig::validate(const std::string& p, std::string* why) const {
  return finiteInRange(p + "axial_stiffness_n", axial_stiffness_n, 1e-9, 1e9, why) &&
         oneOf(p + "limit_velocity", limit_velocity, {"auto", "displacement", "inelastic"}, why) &&
         finiteInRange(p + "damping_n_s", damping_n_s, 0.0, 1e6, why) &&
         finiteInRange(p + "strain_limit", strain_limit, 1e-4, 1.0, why) &&
         finiteInRange(p + "strain_rate_limit_per_substep", strain_rate_limit_per_substep, 1e-5,
                       1.0, why);
}

// The flutter bounds on alpha_b and c_b depend on the resolution: buildModel applies them per
// strand (docs/physics.md §10.15), so any non-negative value is valid here.
bool BendConfig::validate(const std::string& p, std::string* why) const {
  return finiteInRange(p + "stiffness_n_m2", stiffness_n_m2, 0.0, 1e6, why) &&
         finiteInRange(p + "damping_n_s", damping_n_s, 0.0, 1e6, why) &&
         finiteInRange(p + "smoothing_length_m", smoothing_length_m, 0.0, 10.0, why);
}

bool CoreSpringConfig::validate(const std::string& p, std::string* why) const {
  return finiteInRange(p + "stiffness_n", stiffness_n, 0.0, 1e9, why) &&
         finiteInRange(p + "damping_n_s", damping_n_s, 0.0, 1e6, why) &&
         finiteInRange(p + "smoothing_length_m", smoothing_length_m, 0.0, 10.0, why);
}

bool CollisionConfig::validate(const std::string& p, std::string* why) const {
  if (constraint_rounds < 0 || constraint_rounds > 100) {
    if (why)
      *why = p + "constraint_rounds: " + std::to_string(constraint_rounds) + " is outside [0, 100]";
    return false;
  }
  return finiteInRange(p + "offset_m", offset_m, 0.0, 0.05, why) &&
         finiteInRange(p + "friction", friction, 0.0, 10.0, why);
}

int IntegratorConfig::resolvedThreads() const {
  if (threads > 0) return std::min(threads, kMaxSolverThreads);
  const int machine = static_cast<int>(std::thread::hardware_concurrency());
  return std::max(1, std::min(machine, kMaxSolverThreads));
}

bool IntegratorConfig::validate(const std::string& p, std::string* why) const {
  if (!oneOf(p + "method", method, {"explicit", "backward_euler", "midpoint", "theta"}, why) ||
      !finiteInRange(p + "substep_s", substep_s, 1e-7, 0.1, why) ||
      !finiteInRange(p + "theta", theta, 0.5, 1.0, why) ||
      !finiteInRange(p + "teleport_speed_m_s", teleport_speed_m_s, 0.0, 1e6, why) ||
      !finiteInRange(p + "teleport_angle_rad", teleport_angle_rad, 0.0, 10.0, why) ||
      !oneOf(p + "lane_layout", lane_layout, {"auto", "double4", "double8", "float8", "float16"},
             why))
    return false;
  if (threads < 0 || threads > kMaxSolverThreads) {
    if (why)
      *why = p + "threads: " + std::to_string(threads) + " is outside [0, " +
             std::to_string(kMaxSolverThreads) + "] (0: every hardware thread)";
    return false;
  }
  if (damping_passes < 1 || damping_passes > 64) {
    if (why) *why = p + "damping_passes: " + std::to_string(damping_passes) + " is outside [1, 64]";
    return false;
  }
  return true;
}

bool CurlConfig::validate(const std::string& p, std::string* why) const {
  return oneOf(p + "mode", mode, {"spring", "literal"}, why) &&
         finiteInRange(p + "weight_n", weight_n, 0.0, 1e5, why) &&
         finiteInRange(p + "helix_radius_m", helix_radius_m, 0.0, 1.0, why) &&
         finiteInRange(p + "helix_pitch_m", helix_pitch_m, 0.0, 10.0, why) &&
         finiteInRange(p + "rotation_time_constant_s", rotation_time_constant_s, 0.0, 100.0, why) &&
         (helix_radius_m == 0.0 || helix_pitch_m > 0.0 ||
          (why && (*why = p + "helix_pitch_m: must be > 0 when helix_radius_m > 0", false)));
}

bool CohesionConfig::validate(const std::string& p, std::string* why) const {
  return oneOf(p + "mode", mode, {"ours", "lin", "kim", "off"}, why) &&
         finiteInRange(p + "tightness", tightness, 0.0, 1.0, why) &&
         finiteInRange(p + "radius_m", radius_m, 1e-4, 1.0, why) &&
         finiteInRange(p + "lin_stiffness_n_per_m3", lin_stiffness_n_per_m3, 0.0, 1e9, why) &&
         finiteInRange(p + "kim_surface_tension", kim_surface_tension, 0.0, 1e3, why) &&
         oneOf(p + "evaluation", evaluation, {"exact", "grid"}, why) &&
         finiteInRange(p + "grid_cells_per_radius", grid_cells_per_radius, 2, 16, why) &&
         oneOf(p + "gather_at", gather_at, {"all", "guides"}, why) &&
         oneOf(p + "grid_wet_sums", grid_wet_sums, {"auto", "particles", "nodes"}, why) &&
         finiteInRange(p + "refresh_period_s", refresh_period_s, 0.0, 1.0, why);
}

bool AdhesionConfig::validate(const std::string& p, std::string* why) const {
  return finiteInRange(p + "peak_acceleration_m_s2", peak_acceleration_m_s2, 0.0, 1e4, why) &&
         finiteInRange(p + "radius_m", radius_m, 1e-4, 1.0, why);
}

bool StiffnessConfig::validate(const std::string& p, std::string* why) const {
  return finiteInRange(p + "global_factor", global_factor, 0.5, 1.0, why) &&
         finiteInRange(p + "wet_factor", wet_factor, 0.5, 1.0, why) &&
         finiteInRange(p + "dry_factor", dry_factor, 0.5, 1.0, why) &&
         finiteInRange(p + "reference_step_s", reference_step_s, 1e-7, 1.0, why);
}

bool ObstacleCollisionConfig::validate(const std::string& p, std::string* why) const {
  return finiteInRange(p + "offset_m", offset_m, 0.0, 0.1, why) &&
         finiteInRange(p + "friction", friction, 0.0, 10.0, why) &&
         finiteInRange(p + "margin_m", margin_m, 0.0, 1.0, why);
}

bool HairContactConfig::validate(const std::string& p, std::string* why) const {
  return finiteInRange(p + "radius_m", radius_m, 1e-5, 0.1, why) &&
         finiteInRange(p + "sparsity", sparsity, 1e-3, 1.0, why) &&
         finiteInRange(p + "stiffness_n_per_m3", stiffness_n_per_m3, 0.0, 1e12, why) &&
         finiteInRange(p + "damping_n_s_per_m3", damping_n_s_per_m3, 0.0, 1e9, why) &&
         finiteInRange(p + "friction", friction, 0.0, 10.0, why) &&
         finiteInRange(p + "ramp_time_s", ramp_time_s, 0.0, 10.0, why) &&
         finiteInRange(p + "taper_time_s", taper_time_s, 0.0, 10.0, why) &&
         finiteInRange(p + "skin_m", skin_m, 1e-6, 0.1, why) &&
         finiteInRange(p + "max_substep_s", max_substep_s, 1e-6, 1.0, why);
}

bool SolverConfig::validate(const std::string& p, std::string* why) const {
  const bool parts_ok =
      stretch.validate(p + "stretch.", why) && bend.validate(p + "bend.", why) &&
      core.validate(p + "core.", why) && collision.validate(p + "collision.", why) &&
      integrator.validate(p + "integrator.", why) && curl.validate(p + "curl.", why) &&
      cohesion.validate(p + "cohesion.", why) && adhesion.validate(p + "adhesion.", why) &&
      stiffness.validate(p + "stiffness.", why) && obstacle.validate(p + "obstacle.", why) &&
      hair_contact.validate(p + "hair_contact.", why) &&
      finiteVec(p + "gravity_m_s2", gravity_m_s2, why) &&
      finiteInRange(p + "gravity_m_s2", gravity_m_s2.norm(), 0.0, 1000.0, why);
  if (!parts_ok) return false;
  // sag_free: the bending spring is the only one that carries weight across an edge
  // (sag_free.cpp).
  if (sag_free && gravity_m_s2.squaredNorm() > 0.0 && !(bend.stiffness_n_m2 > 0.0)) {
    if (why)
      *why = p + "sag_free: needs " + p +
             "bend.stiffness_n_m2 > 0 under gravity (the bending "
             "spring carries the weight across the edges)";
    return false;
  }
  return true;
}

}  // namespace wet_curly_hair
