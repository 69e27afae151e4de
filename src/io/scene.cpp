#include "wet_curly_hair/io/scene.h"

#include <yaml-cpp/yaml.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

namespace wet_curly_hair {
namespace io {

bool RunConfig::validate(const std::string& p, std::string* why) const {
  using namespace config_check;
  return finiteInRange(p + "seconds", seconds, 0.0, 1e7, why) &&
         finiteInRange(p + "frame_s", frame_s, 1e-5, 1.0, why) &&
         finiteInRange(p + "strand_radius_m", strand_radius_m, 0.0, 0.1, why) &&
         finiteInRange(p + "clump_search_m", clump_search_m, 1e-4, 1.0, why);
}

bool SceneConfig::validate(std::string* why) const {
  using namespace config_check;
  if (!groom.validate("groom.", why) || !head.validate("head.", why) ||
      !solver.validate("solver.", why) || !motion.validate("motion.", why) ||
      !run.validate("run.", why) ||
      !finiteInRange("saturation.root", saturation.root, 0.0, 1.0, why) ||
      !finiteInRange("saturation.tip", saturation.tip, 0.0, 1.0, why))
    return false;
  if (!finiteVec("obstacle_map.offset_m", obstacle_map.offset_m, why) ||
      !finiteInRange("obstacle_map.resolution_m", obstacle_map.resolution_m, 1e-4, 1.0, why) ||
      !finiteInRange("obstacle_map.margin_m", obstacle_map.margin_m, 0.0, 10.0, why))
    return false;
  for (size_t k = 0; k < obstacles.size(); ++k)
    if (!obstacles[k].validate("obstacles[" + std::to_string(k) + "].", why)) return false;
  if (!water.validate("water.", why)) return false;
  for (size_t k = 0; k < water_sources.sources.size(); ++k)
    if (!water_sources.sources[k].validate("water.sources[" + std::to_string(k) + "].", why))
      return false;
  for (size_t k = 0; k < water_sources.dryers.size(); ++k)
    if (!water_sources.dryers[k].validate("water.dryers[" + std::to_string(k) + "].", why))
      return false;
  if (!groom_file.file.empty()) {
    if (!positive("groom_file.scale", groom_file.scale, why) ||
        !finiteVec("groom_file.offset_m", groom_file.offset_m, why))
      return false;
    static const char* kAxes[] = {"x", "y", "z", "-x", "-y", "-z"};
    bool axis_ok = false;
    for (const char* a : kAxes) axis_ok = axis_ok || groom_file.up_axis == a;
    if (!axis_ok) {
      if (why)
        *why = "groom_file.up_axis: '" + groom_file.up_axis + "' is not one of x, y, z, -x, -y, -z";
      return false;
    }
    if (groom_file.resample_particles != 0 &&
        (groom_file.resample_particles < 2 || groom_file.resample_particles > 4096)) {
      if (why) *why = "groom_file.resample_particles: must be 0 (keep) or in [2, 4096]";
      return false;
    }
    // Below 0.1 mm a 1 m strand would get over 10^4 particles: a typo, not a groom.
    const double edge = groom_file.resample_edge_m;
    if (!std::isfinite(edge) || (edge != 0.0 && (edge < 1e-4 || edge > 1.0))) {
      if (why) {
        *why = "groom_file.resample_edge_m: " + std::to_string(edge) +
               " must be 0 (off) or in [1e-4, 1] m";
      }
      return false;
    }
    const double min_edge = groom_file.min_edge_m;
    if (!std::isfinite(min_edge) || (min_edge != 0.0 && (min_edge < 1e-5 || min_edge > 0.1))) {
      if (why) {
        *why = "groom_file.min_edge_m: " + std::to_string(min_edge) +
               " must be 0 (off) or in [1e-5, 0.1] m";
      }
      return false;
    }
    if (edge != 0.0 && groom_file.resample_particles != 0) {
      if (why) {
        *why = "groom_file.resample_edge_m: set together with groom_file.resample_particles (" +
               std::to_string(groom_file.resample_particles) + "): choose one, the other 0";
      }
      return false;
    }
  }
  return true;
}

namespace {

void addVec(std::vector<ParamRef>* t, const std::string& name, Vec3* v, const std::string& doc,
            bool rebuild) {
  const char* axes[] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k)
    t->push_back({name + "." + axes[k], ParamRef::Type::kDouble, &(*v)[k], doc, rebuild});
}

/// Appends a row to a parameter table, its type from the field's: rows(name, &field, doc,
/// needs_rebuild).
struct Rows {
  std::vector<ParamRef>* t;
  void operator()(const std::string& n, double* f, const std::string& doc, bool rebuild) const {
    t->push_back({n, ParamRef::Type::kDouble, f, doc, rebuild});
  }
  void operator()(const std::string& n, int* f, const std::string& doc, bool rebuild) const {
    t->push_back({n, ParamRef::Type::kInt, f, doc, rebuild});
  }
  void operator()(const std::string& n, bool* f, const std::string& doc, bool rebuild) const {
    t->push_back({n, ParamRef::Type::kBool, f, doc, rebuild});
  }
  void operator()(const std::string& n, std::string* f, const std::string& doc,
                  bool rebuild) const {
    t->push_back({n, ParamRef::Type::kString, f, doc, rebuild});
  }
};

}  // namespace

namespace {

/// The solver.hair_contact rows of parameterTable (hair-hair contact, hair_contact.h).
void addHairContactParameters(HairContactConfig* hc_config, std::vector<ParamRef>* table) {
  std::vector<ParamRef>& t = *table;
  const Rows d{&t}, b{&t};
  HairContactConfig& hc = *hc_config;
  b("solver.hair_contact.enabled", &hc.enabled, "hair-hair penalty contact (Iben §2.8)", false);
  d("solver.hair_contact.radius_m", &hc.radius_m, "collision sphere radius r (contact at 2 r), m",
    false);
  d("solver.hair_contact.sparsity", &hc.sparsity, "Iben's pruning s: spheres >= s 2 r apart",
    false);
  d("solver.hair_contact.stiffness_n_per_m3", &hc.stiffness_n_per_m3,
    "K: a sphere pair gets K l_i l_j, N/m per m of each strand", false);
  d("solver.hair_contact.damping_n_s_per_m3", &hc.damping_n_s_per_m3,
    "D: a sphere pair gets D l_i l_j, N s/m per m of each strand", false);
  d("solver.hair_contact.friction", &hc.friction, "Coulomb friction between strands", false);
  d("solver.hair_contact.ramp_time_s", &hc.ramp_time_s, "stiffness ramp on first contact, s",
    false);
  d("solver.hair_contact.taper_time_s", &hc.taper_time_s, "stiffness taper after release, s",
    false);
  d("solver.hair_contact.skin_m", &hc.skin_m, "Verlet list skin, m", false);
  d("solver.hair_contact.max_substep_s", &hc.max_substep_s,
    "longest substep while contact is on (the integrator's may be shorter), s", false);
}

/// The groom and groom_file rows of parameterTable.
void addGroomParameters(SceneConfig* s, std::vector<ParamRef>* table) {
  std::vector<ParamRef>& t = *table;
  const Rows d{&t}, i{&t}, str{&t}, b{&t};
  GroomConfig& g = s->groom;
  i("groom.strands", &g.strands, "number of generated strands", true);
  i("groom.particles", &g.particles, "particles per strand, root included", true);
  d("groom.length_m", &g.length_m, "strand arc length, m", true);
  d("groom.curl_radius_m", &g.curl_radius_m, "helix radius, m (0: straight)", true);
  d("groom.curl_pitch_m", &g.curl_pitch_m, "helix rise per turn, m", true);
  d("groom.jitter", &g.jitter, "relative per-strand variation of radius, pitch, length", true);
  i("groom.seed", &g.seed, "random seed", true);
  d("groom.linear_density_kg_per_m", &g.linear_density_kg_per_m,
    "rho, mass per length of strand, kg/m", true);
  d("groom.scalp_half_angle_deg", &g.scalp_half_angle_deg, "scalp patch half angle, deg", true);
  addVec(&t, "groom.scalp_axis", &g.scalp_axis, "scalp patch centre direction (head frame)", true);
  i("groom.follow_ratio", &g.follow_ratio,
    "K: one strand in K is simulated (guide), the others follow their nearest guides (1: all)",
    true);
  str("groom.guides", &g.guides,
      "with K > 1: sampled (farthest-point on the roots) or first (the groom's first N/K strands)",
      true);
  GroomFileConfig& gf = s->groom_file;
  str("groom_file.file", &gf.file, ".hair file to load instead of generating (empty: generate)",
      true);
  d("groom_file.scale", &gf.scale, "metres per file unit", true);
  str("groom_file.up_axis", &gf.up_axis, "the file's up axis: x, y, z, -x, -y, -z", true);
  addVec(&t, "groom_file.offset_m", &gf.offset_m, "offset after scaling, head frame, m", true);
  i("groom_file.resample_particles", &gf.resample_particles, "0 keeps the file's points", true);
  d("groom_file.resample_edge_m", &gf.resample_edge_m,
    "edge length to resample every strand to, m (0: off; particles follow each strand's length)",
    true);
  d("groom_file.min_edge_m", &gf.min_edge_m,
    "shortest edge kept: finer strands are resampled, strands under two edges skipped, m (0: off)",
    true);
  b("groom_file.roots_on_scalp", &gf.roots_on_scalp,
    "move each strand rigidly so that its root lies on the head's ellipsoid", true);
}

/// The water rows of parameterTable (docs/water.md).
void addWaterParameters(SceneConfig* s, std::vector<ParamRef>* table) {
  std::vector<ParamRef>& t = *table;
  const Rows d{&t}, b{&t};
  WaterConfig& w = s->water;
  b("water.enabled", &w.enabled,
    "run the water stage without sources too (on whenever water.sources or water.dryers is set)",
    false);
  d("water.capacity_kg_per_m", &w.capacity_kg_per_m, "water a metre of strand holds, kg/m", false);
  d("water.wicking_m2_s", &w.wicking_m2_s, "wicking diffusivity along a strand, m^2/s", false);
  d("water.gravity_flow_m_s", &w.gravity_flow_m_s,
    "speed water runs down a strand hanging along gravity, m/s", false);
  d("water.evaporation_per_s", &w.evaporation_per_s, "evaporation rate outside dryers, 1/s", false);
  d("water.exchange_per_s", &w.exchange_per_s,
    "rate at which strands sharing a cell share water, 1/s", false);
  d("water.exchange_cell_m", &w.exchange_cell_m, "cell size of the exchange between strands, m",
    false);
  d("water.exchange_interval_s", &w.exchange_interval_s,
    "the exchange runs once this much time has passed, over that time, s (0: every frame)", false);
  b("water.adds_mass", &w.adds_mass, "the held water adds to the particle masses", false);
}

}  // namespace

std::vector<ParamRef> parameterTable(SceneConfig* s) {
  std::vector<ParamRef> t;
  const Rows d{&t}, i{&t}, b{&t}, str{&t};
  addGroomParameters(s, &t);
  addVec(&t, "head.center_m", &s->head.ellipsoid.center_m, "ellipsoid centre, head frame, m", true);
  addVec(&t, "head.radii_m", &s->head.ellipsoid.radii_m, "ellipsoid semi-axes, m", true);
  SolverConfig& c = s->solver;
  d("solver.stretch.axial_stiffness_n", &c.stretch.axial_stiffness_n,
    "EA, N per unit strain (eq. 1: k_s = EA / L per edge)", false);
  d("solver.stretch.damping_n_s", &c.stretch.damping_n_s,
    "C_s, N s per unit strain rate (eq. 1: c_s = C_s / L)", false);
  d("solver.stretch.strain_limit", &c.stretch.strain_limit, "largest edge strain", false);
  d("solver.stretch.strain_rate_limit_per_substep", &c.stretch.strain_rate_limit_per_substep,
    "velocity clamp: largest strain change per substep", false);
  str("solver.stretch.limit_velocity", &c.stretch.limit_velocity,
      "after a strain-limit projection: displacement (Selle), inelastic, or auto (inelastic; "
      "displacement with hair contact)",
      false);
  d("solver.bend.stiffness_n_m2", &c.bend.stiffness_n_m2,
    "B, bending stiffness, N m^2 (eq. 4: k_b = B / (L alpha_b^2))", false);
  d("solver.bend.damping_n_s", &c.bend.damping_n_s, "D_b, N s (eq. 4: c_b = D_b / L)", false);
  d("solver.bend.smoothing_length_m", &c.bend.smoothing_length_m,
    "alpha_b, bend frame smoothing length, m (eq. 2)", true);
  b("solver.bend.frame_gradient", &c.bend.frame_gradient,
    "bending force through the frames too: the gradient of its energy (docs/physics.md §2.6)",
    false);
  d("solver.core.stiffness_n", &c.core.stiffness_n, "K_c, N per unit strain (eq. 5: k_c = K_c / L)",
    false);
  d("solver.core.damping_n_s", &c.core.damping_n_s, "C_c, N s (eq. 5: c_c = C_c / L)", false);
  d("solver.core.smoothing_length_m", &c.core.smoothing_length_m,
    "alpha_c, core smoothing length, m (eq. 2)", true);
  b("solver.core.filter_gradient", &c.core.filter_gradient,
    "core force through the filter's transpose: the gradient of its energy (physics.md §2.7)",
    false);
  b("solver.collision.head_enabled", &c.collision.head_enabled, "collide with the head", false);
  d("solver.collision.offset_m", &c.collision.offset_m, "collision offset delta, m", false);
  d("solver.collision.friction", &c.collision.friction, "Coulomb friction mu", false);
  i("solver.collision.constraint_rounds", &c.collision.constraint_rounds,
    "extra collision + strain-limit rounds in a substep with contact", false);
  str("solver.integrator.method", &c.integrator.method,
      "explicit, backward_euler, midpoint or theta (docs/performance.md)", false);
  d("solver.integrator.substep_s", &c.integrator.substep_s, "largest substep, s", false);
  d("solver.integrator.theta", &c.integrator.theta, "theta of method theta, [0.5, 1]", false);
  b("solver.integrator.strand_lanes", &c.integrator.strand_lanes,
    "strands in SIMD blocks (false: one at a time)", false);
  str("solver.integrator.lane_layout", &c.integrator.lane_layout,
      "arithmetic and strands per SIMD block: auto (float, one register), double4, double8, "
      "float8 or float16",
      false);
  i("solver.integrator.threads", &c.integrator.threads,
    "solver threads, 0: every hardware thread (results identical)", false);
  d("solver.integrator.teleport_speed_m_s", &c.integrator.teleport_speed_m_s,
    "head faster than this within a step: a jump that carries the hair rigidly, m/s (0: off)",
    false);
  d("solver.integrator.teleport_angle_rad", &c.integrator.teleport_angle_rad,
    "head turning more than this within a step: a jump, rad (0: off)", false);
  i("solver.integrator.damping_passes", &c.integrator.damping_passes, "damping passes", false);
  addVec(&t, "solver.gravity_m_s2", &c.gravity_m_s2, "gravity, world frame, m/s^2", false);
  b("solver.sag_free", &c.sag_free,
    "solve rest lengths and bend targets so the groom hangs still (docs/physics.md §8)", true);
  b("solver.curl.enabled", &c.curl.enabled, "curl exaggeration on wet particles (eqs. 6-9)", false);
  str("solver.curl.mode", &c.curl.mode, "spring (A10 restoring) or literal (eq. 9 couple)", false);
  d("solver.curl.weight_n", &c.curl.weight_n, "W, N (eqs. 6-9: w_h = W / L)", false);
  d("solver.curl.helix_radius_m", &c.curl.helix_radius_m, "wet helix radius r, m (eq. 6)", true);
  d("solver.curl.helix_pitch_m", &c.curl.helix_pitch_m, "wet helix rise per turn, m", true);
  d("solver.curl.rotation_time_constant_s", &c.curl.rotation_time_constant_s,
    "M follows the strand axis with this time constant, s (0: at once)", false);
  str("solver.cohesion.mode", &c.cohesion.mode, "ours (eq. 10), lin, kim or off", false);
  d("solver.cohesion.tightness", &c.cohesion.tightness, "lambda of eq. 10", false);
  d("solver.cohesion.radius_m", &c.cohesion.radius_m, "kernel support h, m", false);
  b("solver.cohesion.include_self", &c.cohesion.include_self,
    "the particle itself joins the Shepard weights of eq. 10 (A13)", false);
  d("solver.cohesion.lin_stiffness_n_per_m3", &c.cohesion.lin_stiffness_n_per_m3,
    "lin baseline: attraction per length of each strand, N/m per m^2", false);
  d("solver.cohesion.kim_surface_tension", &c.cohesion.kim_surface_tension,
    "kim baseline: Akinci cohesion coefficient", false);
  str("solver.cohesion.evaluation", &c.cohesion.evaluation,
      "exact or grid (lattice approximation, docs/physics.md §7.3)", true);
  i("solver.cohesion.grid_cells_per_radius", &c.cohesion.grid_cells_per_radius,
    "grid evaluation: lattice nodes per kernel radius", true);
  b("solver.cohesion.grid_single_precision", &c.cohesion.grid_single_precision,
    "grid evaluation: gathers in float, double where the cancellation needs it", false);
  b("solver.cohesion.grid_node_volumes", &c.cohesion.grid_node_volumes,
    "grid evaluation: the volumes m / rho at the lattice nodes (one splat, not two)", false);
  str("solver.cohesion.grid_wet_sums", &c.cohesion.grid_wet_sums,
      "grid evaluation: eq. 10's sums gathered per particle, convolved at the nodes, or auto",
      true);
  str("solver.cohesion.gather_at", &c.cohesion.gather_at,
      "with followers: eq. 10's sums at all particles, or at the guides (followers interpolate)",
      false);
  d("solver.cohesion.refresh_period_s", &c.cohesion.refresh_period_s,
    "display offsets evaluated at most this often and held between, s; 0: every step", false);
  b("solver.adhesion.enabled", &c.adhesion.enabled, "adhesion of wet hair to obstacles", false);
  d("solver.adhesion.peak_acceleration_m_s2", &c.adhesion.peak_acceleration_m_s2,
    "peak adhesion acceleration at saturation 1, m/s^2", false);
  d("solver.adhesion.radius_m", &c.adhesion.radius_m, "Akinci kernel h, m", false);
  b("solver.adhesion.literal_polynomial", &c.adhesion.literal_polynomial,
    "eq. 12 without the 1/4 power (A15)", false);
  d("solver.stiffness.global_factor", &c.stiffness.global_factor, "xi per reference step", false);
  d("solver.stiffness.wet_factor", &c.stiffness.wet_factor, "gamma0 per reference step", false);
  d("solver.stiffness.dry_factor", &c.stiffness.dry_factor, "gamma1 per reference step", false);
  d("solver.stiffness.reference_step_s", &c.stiffness.reference_step_s, "reference step, s", false);
  b("solver.stiffness.relative_to_head", &c.stiffness.relative_to_head,
    "damp velocity relative to the head's motion", false);
  b("solver.obstacle.enabled", &c.obstacle.enabled, "collide with obstacles", false);
  d("solver.obstacle.offset_m", &c.obstacle.offset_m, "obstacle collision offset, m", false);
  d("solver.obstacle.friction", &c.obstacle.friction, "obstacle Coulomb friction", false);
  d("solver.obstacle.margin_m", &c.obstacle.margin_m, "obstacle reach margin, m", false);
  addHairContactParameters(&c.hair_contact, &t);
  HeadMotionConfig& m = s->motion;
  str("motion.type", &m.type, "still, spin, nod, shake, teleport, linear", false);
  d("motion.rate_hz", &m.rate_hz, "spin rate, rev/s", false);
  d("motion.freq_hz", &m.freq_hz, "nod/shake frequency, Hz", false);
  d("motion.amplitude_rad", &m.amplitude_rad, "nod/shake amplitude, rad", false);
  d("motion.distance_m", &m.distance_m, "teleport distance, m", false);
  d("motion.speed_m_s", &m.speed_m_s, "linear speed, m/s", false);
  d("motion.start_s", &m.start_s, "motion start (teleport instant), s", false);
  d("motion.stop_s", &m.stop_s, "motion stops dead at this time, s", false);
  addVec(&t, "motion.axis", &m.axis, "spin axis / translation direction", false);
  d("run.seconds", &s->run.seconds, "simulated time, s", false);
  d("run.frame_s", &s->run.frame_s, "output frame, s", false);
  d("run.strand_radius_m", &s->run.strand_radius_m, "strand radius for the tangle count, m", false);
  d("run.clump_search_m", &s->run.clump_search_m, "clump distance search radius, m", false);
  str("obstacle_map.file", &s->obstacle_map.file, "OctoMap .bt/.ot obstacle file (empty: none)",
      false);
  addVec(&t, "obstacle_map.offset_m", &s->obstacle_map.offset_m, "map origin in the world, m",
         false);
  d("obstacle_map.resolution_m", &s->obstacle_map.resolution_m, "signed distance field voxel, m",
    false);
  d("obstacle_map.margin_m", &s->obstacle_map.margin_m, "reach box margin, m", false);
  b("obstacle_map.unknown_is_occupied", &s->obstacle_map.unknown_is_occupied,
    "treat unknown space as occupied", false);
  d("saturation.root", &s->saturation.root, "initial saturation at the roots, [0, 1]", false);
  d("saturation.tip", &s->saturation.tip, "initial saturation at the tips, [0, 1]", false);
  addWaterParameters(s, &t);
  return t;
}

double ParamRef::getAsDouble() const {
  switch (type) {
    case Type::kDouble:
      return *static_cast<double*>(field);
    case Type::kInt:
      return *static_cast<int*>(field);
    case Type::kBool:
      return *static_cast<bool*>(field) ? 1.0 : 0.0;
    case Type::kString:
      return std::nan("");
  }
  return std::nan("");
}

namespace {

/// Shortest text that reads back as exactly the same double.
std::string shortest(double v) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return std::string(buffer, result.ptr);
}

/// `s` as a YAML double-quoted scalar that reads back as exactly `s`: quote, backslash and the
/// ASCII control characters are escaped (other bytes are copied: what yaml-cpp parsed is UTF-8).
std::string yamlQuoted(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += ch;
    } else if (c < 0x20 || c == 0x7f) {
      static const char* hex = "0123456789abcdef";
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

}  // namespace

std::string ParamRef::valueString() const {
  std::ostringstream s;
  switch (type) {
    case Type::kDouble:
      s << shortest(*static_cast<double*>(field));
      break;
    case Type::kInt:
      s << *static_cast<int*>(field);
      break;
    case Type::kBool:
      s << (*static_cast<bool*>(field) ? "true" : "false");
      break;
    case Type::kString:
      s << *static_cast<std::string*>(field);
      break;
  }
  return s.str();
}

bool ParamRef::setFromDouble(double v, std::string* why) const {
  if (!std::isfinite(v)) {
    if (why) *why = name + ": value is not finite";
    return false;
  }
  switch (type) {
    case Type::kDouble:
      *static_cast<double*>(field) = v;
      return true;
    case Type::kInt:
      if (v != std::floor(v) || std::abs(v) > 2e9) {
        if (why) *why = name + ": " + std::to_string(v) + " is not an integer";
        return false;
      }
      *static_cast<int*>(field) = static_cast<int>(v);
      return true;
    case Type::kBool:
      if (v != 0.0 && v != 1.0) {
        if (why) *why = name + ": a boolean takes 0 or 1, not " + std::to_string(v);
        return false;
      }
      *static_cast<bool*>(field) = v == 1.0;
      return true;
    case Type::kString:
      if (why) *why = name + ": is a string parameter and cannot be set from a number";
      return false;
  }
  return false;
}

std::string unknownParameterMessage(const std::string& name) {
  struct Renamed {
    const char *old_name, *new_name, *unit;
  };
  static const Renamed kRenamed[] = {
      {"groom.particle_mass_kg", "groom.linear_density_kg_per_m", "kg/m"},
      {"solver.stretch.stiffness_n_per_m", "solver.stretch.axial_stiffness_n", "N per unit strain"},
      {"solver.stretch.damping_ns_per_m", "solver.stretch.damping_n_s", "N s"},
      {"solver.bend.stiffness_n_per_m", "solver.bend.stiffness_n_m2", "N m^2"},
      {"solver.bend.damping_ns_per_m", "solver.bend.damping_n_s", "N s"},
      {"solver.bend.smoothing_edges", "solver.bend.smoothing_length_m", "m"},
      {"solver.core.stiffness_n_per_m", "solver.core.stiffness_n", "N per unit strain"},
      {"solver.core.damping_ns_per_m", "solver.core.damping_n_s", "N s"},
      {"solver.core.smoothing_edges", "solver.core.smoothing_length_m", "m"},
      {"solver.curl.weight_n_per_m", "solver.curl.weight_n", "N"},
      {"solver.cohesion.lin_stiffness_n_per_m", "solver.cohesion.lin_stiffness_n_per_m3",
       "N/m per m^2"},
  };
  for (const Renamed& r : kRenamed)
    if (name == r.old_name)
      return name + ": no longer a parameter: parameters are per length of strand, so that the " +
             "same hair at any particle count is the same hair; use " + r.new_name + " (" + r.unit +
             "; docs/physics.md §2.11 converts)";
  return name + ": unknown parameter";
}

bool applyParameters(const std::vector<std::string>& names, const std::vector<double>& values,
                     SceneConfig* scene, bool* needs_rebuild, std::string* why) {
  if (names.size() != values.size()) {
    if (why)
      *why = "names and values differ in length (" + std::to_string(names.size()) + " vs " +
             std::to_string(values.size()) + ")";
    return false;
  }
  SceneConfig copy = *scene;
  const std::vector<ParamRef> table = parameterTable(&copy);
  bool rebuild = false;
  bool sag_input = false;
  for (size_t k = 0; k < names.size(); ++k) {
    const ParamRef* ref = nullptr;
    for (const ParamRef& r : table)
      if (r.name == names[k]) ref = &r;
    if (!ref) {
      if (why) *why = unknownParameterMessage(names[k]);
      return false;
    }
    if (!ref->setFromDouble(values[k], why)) return false;
    rebuild = rebuild || ref->needs_rebuild;
    // The sag-free rest parameters are solved from these too (sag_free.cpp).
    sag_input = sag_input || ref->name.rfind("solver.gravity_m_s2.", 0) == 0 ||
                ref->name == "solver.stretch.axial_stiffness_n" ||
                ref->name == "solver.stretch.strain_limit" ||
                ref->name == "solver.bend.stiffness_n_m2";
  }
  rebuild = rebuild || (sag_input && copy.solver.sag_free);
  if (!copy.validate(why)) return false;
  *scene = copy;
  if (needs_rebuild) *needs_rebuild = rebuild;
  return true;
}

namespace {

struct YamlWalker {
  std::map<std::string, const ParamRef*> table;
  SceneConfig* scene;
  std::string* why;

  bool fail(const std::string& message) {
    if (why) *why = message;
    return false;
  }

  bool setScalar(const std::string& key, const YAML::Node& node) {
    auto it = table.find(key);
    if (it == table.end()) {
      const std::string message = unknownParameterMessage(key);
      return fail(message == key + ": unknown parameter" ? key + ": unknown key" : message);
    }
    const ParamRef& ref = *it->second;
    const std::string text = node.Scalar();
    try {
      switch (ref.type) {
        case ParamRef::Type::kString:
          *static_cast<std::string*>(ref.field) = text;
          return true;
        case ParamRef::Type::kBool:
          *static_cast<bool*>(ref.field) = node.as<bool>();
          return true;
        case ParamRef::Type::kInt: {
          const double v = node.as<double>();
          return ref.setFromDouble(v, why);
        }
        case ParamRef::Type::kDouble: {
          const double v = node.as<double>();
          if (!std::isfinite(v)) return fail(key + ": '" + text + "' is not a finite number");
          *static_cast<double*>(ref.field) = v;
          return true;
        }
      }
    } catch (const YAML::Exception&) {
      return fail(key + ": '" + text + "' is not a valid value for this key");
    }
    return false;
  }

  bool capsules(const std::string& key, const YAML::Node& node) {
    if (!node.IsSequence()) return fail(key + ": must be a list of capsules");
    std::vector<CapsuleShape> list;
    for (size_t k = 0; k < node.size(); ++k) {
      const std::string p = key + "[" + std::to_string(k) + "]";
      const YAML::Node& c = node[k];
      if (!c.IsMap()) return fail(p + ": must be a map with name, a_m, b_m, radius_m");
      CapsuleShape cap;
      for (const auto& kv : c) {
        if (!kv.first.IsScalar()) return fail(p + ": a key is not a string");
        const std::string sub = kv.first.Scalar();
        try {
          if (sub == "name") {
            cap.name = kv.second.as<std::string>();
          } else if (sub == "radius_m") {
            cap.radius_m = kv.second.as<double>();
          } else if (sub == "a_m" || sub == "b_m") {
            Vec3& v = sub == "a_m" ? cap.a_m : cap.b_m;
            if (!kv.second.IsSequence() || kv.second.size() != 3)
              return fail(p + "." + sub + ": must be a list of 3 numbers");
            for (int a = 0; a < 3; ++a) v[a] = kv.second[a].as<double>();
          } else {
            return fail(p + "." + sub + ": unknown key");
          }
        } catch (const YAML::Exception&) {
          return fail(p + "." + sub + ": not a valid value");
        }
      }
      list.push_back(cap);
    }
    scene->head.capsules = list;
    return true;
  }

  bool obstacleList(const std::string& key, const YAML::Node& node) {
    if (!node.IsSequence()) return fail(key + ": must be a list of obstacle specs");
    std::vector<AnalyticObstacle> list;
    for (size_t k = 0; k < node.size(); ++k) {
      const std::string p = key + "[" + std::to_string(k) + "]";
      if (!node[k].IsScalar())
        return fail(p + ": must be a spec string like sphere:x=0,y=0,z=0,r=0.1");
      AnalyticObstacle o;
      std::string inner;
      if (!AnalyticObstacle::parse(node[k].Scalar(), &o, &inner)) return fail(p + ": " + inner);
      list.push_back(o);
    }
    scene->obstacles = list;
    return true;
  }

  /// water.sources / water.dryers: lists of spec strings (WaterSource / WaterDryer::parse).
  template <typename T>
  bool specList(const std::string& key, const YAML::Node& node, std::vector<T>* out) {
    if (!node.IsSequence()) return fail(key + ": must be a list of spec strings");
    std::vector<T> list;
    for (size_t k = 0; k < node.size(); ++k) {
      const std::string p = key + "[" + std::to_string(k) + "]";
      if (!node[k].IsScalar()) return fail(p + ": must be a spec string");
      T item;
      std::string inner;
      if (!T::parse(node[k].Scalar(), &item, &inner)) return fail(p + ": " + inner);
      list.push_back(item);
    }
    *out = list;
    return true;
  }

  bool walk(const std::string& prefix, const YAML::Node& node) {
    if (node.IsNull()) return prefix.empty() ? true : fail(prefix + ": has no value");
    if (prefix == "head.capsules") return capsules(prefix, node);
    if (prefix == "obstacles") return obstacleList(prefix, node);
    if (prefix == "water.sources") return specList(prefix, node, &scene->water_sources.sources);
    if (prefix == "water.dryers") return specList(prefix, node, &scene->water_sources.dryers);
    if (node.IsMap()) {
      for (const auto& kv : node) {
        std::string sub;
        try {
          sub = kv.first.as<std::string>();
        } catch (const YAML::Exception&) {
          return fail(prefix + ": a key is not a string");
        }
        if (!walk(prefix.empty() ? sub : prefix + "." + sub, kv.second)) return false;
      }
      return true;
    }
    if (node.IsSequence()) {
      // A 3-vector may be written [x, y, z].
      if (table.count(prefix + ".x") && node.size() == 3) {
        const char* axes[] = {"x", "y", "z"};
        for (int k = 0; k < 3; ++k) {
          if (!node[k].IsScalar()) return fail(prefix + ": must be a list of 3 numbers");
          if (!setScalar(prefix + "." + axes[k], node[k])) return false;
        }
        return true;
      }
      return fail(prefix + ": unexpected list" +
                  (table.count(prefix + ".x") ? " (a vector takes exactly 3 numbers)" : ""));
    }
    if (prefix.empty()) return fail("scene: the document must be a map");
    return setScalar(prefix, node);
  }
};

}  // namespace

bool parseSceneYaml(const std::string& text, SceneConfig* scene, std::string* why) {
  SceneConfig copy = *scene;
  std::vector<ParamRef> table = parameterTable(&copy);
  YamlWalker walker;
  for (const ParamRef& r : table) walker.table[r.name] = &r;
  walker.scene = &copy;
  walker.why = why;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    if (why) *why = std::string("scene: YAML syntax error: ") + e.what();
    return false;
  }
  if (!root.IsNull() && !root.IsMap()) {
    if (why) *why = "scene: the document must be a map of sections";
    return false;
  }
  try {
    if (!walker.walk("", root)) return false;
  } catch (const YAML::Exception& e) {
    // Every conversion above catches its own; this is a safety net (the scene stays unchanged).
    if (why) *why = std::string("scene: ") + e.what();
    return false;
  }
  if (!copy.validate(why)) return false;
  *scene = copy;
  return true;
}

bool loadSceneFile(const std::string& path, SceneConfig* scene, std::string* why) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (why) *why = path + ": cannot open the scene file";
    return false;
  }
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string inner;
  if (!parseSceneYaml(buffer.str(), scene, &inner)) {
    if (why) *why = path + ": " + inner;
    return false;
  }
  return true;
}

std::string sceneToYaml(const SceneConfig& scene_in) {
  SceneConfig scene = scene_in;
  const std::vector<ParamRef> table = parameterTable(&scene);
  std::ostringstream out;
  out << "# wet_curly_hair scene: every key, with its unit (dotted names = set_parameters names)\n";
  std::vector<std::string> open;
  for (const ParamRef& r : table) {
    std::vector<std::string> parts;
    std::stringstream ss(r.name);
    std::string part;
    while (std::getline(ss, part, '.')) parts.push_back(part);
    size_t common = 0;
    while (common < open.size() && common + 1 < parts.size() && open[common] == parts[common])
      ++common;
    open.resize(common);
    for (size_t k = common; k + 1 < parts.size(); ++k) {
      out << std::string(2 * k, ' ') << parts[k] << ":\n";
      open.push_back(parts[k]);
    }
    std::string value = r.valueString();
    if (r.type == ParamRef::Type::kString) value = yamlQuoted(value);
    out << std::string(2 * (parts.size() - 1), ' ') << parts.back() << ": " << value << "  # "
        << r.doc << "\n";
    if (r.name == "head.radii_m.z" && !scene.head.capsules.empty()) {
      out << "  capsules:  # neck, ears: points within radius_m of segment a_m-b_m (head frame, "
             "m)\n";
      for (const CapsuleShape& c : scene.head.capsules) {
        out << "    - {name: " << yamlQuoted(c.name) << ", a_m: [" << shortest(c.a_m.x()) << ", "
            << shortest(c.a_m.y()) << ", " << shortest(c.a_m.z()) << "], b_m: ["
            << shortest(c.b_m.x()) << ", " << shortest(c.b_m.y()) << ", " << shortest(c.b_m.z())
            << "], radius_m: " << shortest(c.radius_m) << "}\n";
      }
      open.resize(1);
    }
  }
  // The water section is the table's last: its lists follow its keys.
  if (!scene.water_sources.sources.empty()) {
    out << "  sources:  # shower:x,y,z,r,rate_kg_s,start_s,stop_s or bath:z,start_s,stop_s\n";
    for (const WaterSource& w : scene.water_sources.sources)
      out << "    - \"" << w.spec() << "\"\n";
  }
  if (!scene.water_sources.dryers.empty()) {
    out << "  dryers:  # box:x,y,z,hx,hy,hz,rate_per_s,start_s,stop_s (world frame, m, 1/s)\n";
    for (const WaterDryer& d : scene.water_sources.dryers) out << "    - \"" << d.spec() << "\"\n";
  }
  if (!scene.obstacles.empty()) {
    out << "obstacles:  # world frame, m\n";
    for (const AnalyticObstacle& o : scene.obstacles) out << "  - \"" << obstacleSpec(o) << "\"\n";
  }
  return out.str();
}

std::string dottedToYaml(const std::string& name, const std::string& value) {
  std::string out, closing;
  std::stringstream parts(name);
  std::string part;
  std::vector<std::string> keys;
  while (std::getline(parts, part, '.')) keys.push_back(part);
  for (size_t k = 0; k < keys.size(); ++k) {
    out += "{" + keys[k] + ": ";
    closing += "}";
  }
  // Quote nothing: the value is YAML text; a bare empty value would be null, so keep "".
  return out + (value.empty() ? "\"\"" : value) + closing;
}

std::string obstacleSpec(const AnalyticObstacle& o) {
  std::string s;
  const Vec3& c = o.center_m;
  switch (o.shape) {
    case AnalyticObstacle::Shape::kSphere:
      s = "sphere:x=" + shortest(c.x()) + ",y=" + shortest(c.y()) + ",z=" + shortest(c.z()) +
          ",r=" + shortest(o.radius_m);
      break;
    case AnalyticObstacle::Shape::kBox:
      s = "box:x=" + shortest(c.x()) + ",y=" + shortest(c.y()) + ",z=" + shortest(c.z()) +
          ",hx=" + shortest(o.half_extents_m.x()) + ",hy=" + shortest(o.half_extents_m.y()) +
          ",hz=" + shortest(o.half_extents_m.z());
      break;
    case AnalyticObstacle::Shape::kPlane:
      s = "plane:x=" + shortest(c.x()) + ",y=" + shortest(c.y()) + ",z=" + shortest(c.z()) +
          ",nx=" + shortest(o.normal.x()) + ",ny=" + shortest(o.normal.y()) +
          ",nz=" + shortest(o.normal.z());
      break;
  }
  return s;
}

SceneConfig builtinScene() {
  SceneConfig s;
  s.groom.strands = 200;
  s.groom.particles = 32;
  s.groom.scalp_axis = Vec3(-0.45, 0.0, 1.0);  // the patch leaves the face free
  s.groom.scalp_half_angle_deg = 65.0;
  // Soft curls that drape on the head (the solver defaults hold curls up like a bush): k_b = 10
  // N/m, c_b = 0.063 N s/m (critical, inside the flutter bound) and k_c = 10 N/m at the default
  // 8.06 mm edges.
  s.solver.bend.stiffness_n_m2 = 1.9e-4;
  s.solver.bend.damping_n_s = 5.1e-4;
  s.solver.core.stiffness_n = 0.08;
  s.saturation.root = 0.0;
  s.saturation.tip = 0.8;  // wet toward the tips
  s.head.capsules.push_back({"neck", Vec3(-0.01, 0.0, -0.06), Vec3(-0.02, 0.0, -0.25), 0.055});
  s.motion.type = "nod";
  s.motion.freq_hz = 0.5;
  s.motion.amplitude_rad = 0.3;
  s.run.seconds = 4.0;
  return s;
}

}  // namespace io
}  // namespace wet_curly_hair
