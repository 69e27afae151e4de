#include "wet_curly_hair/core/water.h"

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <map>
#include <sstream>

#include "wet_curly_hair/core/config.h"

namespace wet_curly_hair {

using namespace config_check;

bool WaterConfig::validate(const std::string& p, std::string* why) const {
  return finiteInRange(p + "capacity_kg_per_m", capacity_kg_per_m, 1e-9, 10.0, why) &&
         finiteInRange(p + "wicking_m2_s", wicking_m2_s, 0.0, 1.0, why) &&
         finiteInRange(p + "gravity_flow_m_s", gravity_flow_m_s, 0.0, 10.0, why) &&
         finiteInRange(p + "evaporation_per_s", evaporation_per_s, 0.0, 1e3, why) &&
         finiteInRange(p + "exchange_per_s", exchange_per_s, 0.0, 1e3, why) &&
         finiteInRange(p + "exchange_cell_m", exchange_cell_m, 1e-4, 0.1, why) &&
         finiteInRange(p + "exchange_interval_s", exchange_interval_s, 0.0, 10.0, why);
}

namespace {

bool timeWindow(const std::string& p, double start, double stop, std::string* why) {
  if (!finiteInRange(p + "start_s", start, 0.0, 1e9, why)) return false;
  if (std::isnan(stop) || stop <= start) {
    if (why) *why = p + "stop_s: " + std::to_string(stop) + " must be after start_s";
    return false;
  }
  return true;
}

/// Shortest text that reads back as exactly the same double.
std::string shortest(double v) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return std::string(buffer, result.ptr);
}

/// "kind:k=v,k=v" into the kind and a map; names the bad field as "<kind>.<key>".
bool parseSpec(const std::string& spec, const std::vector<std::string>& kinds,
               const std::vector<std::string>& keys, std::string* kind,
               std::map<std::string, double>* values, std::string* why) {
  const size_t colon = spec.find(':');
  *kind = spec.substr(0, colon);
  if (std::find(kinds.begin(), kinds.end(), *kind) == kinds.end()) {
    std::string list;
    for (const std::string& k : kinds) list += (list.empty() ? "" : " or ") + k;
    if (why) *why = "'" + *kind + "' is not " + list;
    return false;
  }
  if (colon == std::string::npos) return true;
  std::stringstream items(spec.substr(colon + 1));
  std::string item;
  while (std::getline(items, item, ',')) {
    const size_t eq = item.find('=');
    const std::string key = item.substr(0, eq);
    if (std::find(keys.begin(), keys.end(), key) == keys.end()) {
      if (why) *why = *kind + "." + key + ": unknown key";
      return false;
    }
    const std::string text = eq == std::string::npos ? "" : item.substr(eq + 1);
    char* end = nullptr;
    const double value = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0' || !std::isfinite(value)) {
      if (why) *why = *kind + "." + key + ": '" + text + "' is not a finite number";
      return false;
    }
    (*values)[key] = value;
  }
  return true;
}

}  // namespace

bool WaterSource::validate(const std::string& p, std::string* why) const {
  if (kind == Kind::kShower) {
    if (!finiteVec(p + "center_m", center_m, why) || !positive(p + "r", radius_m, why) ||
        !finiteInRange(p + "rate_kg_s", rate_kg_s, 0.0, 1e3, why))
      return false;
  } else if (!finiteInRange(p + "z", level_m, -1e6, 1e6, why)) {
    return false;
  }
  return timeWindow(p, start_s, stop_s, why);
}

bool WaterSource::parse(const std::string& spec, WaterSource* out, std::string* why) {
  std::string kind;
  std::map<std::string, double> v;
  if (!parseSpec(spec, {"shower", "bath"}, {"x", "y", "z", "r", "rate_kg_s", "start_s", "stop_s"},
                 &kind, &v, why))
    return false;
  WaterSource s;
  s.kind = kind == "shower" ? Kind::kShower : Kind::kBath;
  if (s.kind == Kind::kBath) {
    for (const char* k : {"x", "y", "r", "rate_kg_s"}) {
      if (v.count(k)) {
        if (why) *why = "bath." + std::string(k) + ": a bath takes only z, start_s, stop_s";
        return false;
      }
    }
    if (!v.count("z")) {
      if (why) *why = "bath.z: the water level is required";
      return false;
    }
  }
  auto get = [&](const char* k, double fallback) { return v.count(k) ? v[k] : fallback; };
  s.center_m = Vec3(get("x", 0.0), get("y", 0.0), get("z", 0.0));
  s.level_m = get("z", 0.0);
  s.radius_m = get("r", s.radius_m);
  s.rate_kg_s = get("rate_kg_s", s.rate_kg_s);
  s.start_s = get("start_s", 0.0);
  s.stop_s = get("stop_s", s.stop_s);
  if (!s.validate(kind + ".", why)) return false;
  *out = s;
  return true;
}

std::string WaterSource::spec() const {
  std::string s;
  if (kind == Kind::kShower) {
    s = "shower:x=" + shortest(center_m.x()) + ",y=" + shortest(center_m.y()) +
        ",z=" + shortest(center_m.z()) + ",r=" + shortest(radius_m) +
        ",rate_kg_s=" + shortest(rate_kg_s);
  } else {
    s = "bath:z=" + shortest(level_m);
  }
  s += ",start_s=" + shortest(start_s);
  if (std::isfinite(stop_s)) s += ",stop_s=" + shortest(stop_s);
  return s;
}

bool WaterDryer::validate(const std::string& p, std::string* why) const {
  return finiteVec(p + "center_m", center_m, why) && positive(p + "hx", half_extents_m.x(), why) &&
         positive(p + "hy", half_extents_m.y(), why) &&
         positive(p + "hz", half_extents_m.z(), why) &&
         finiteInRange(p + "rate_per_s", rate_per_s, 0.0, 1e3, why) &&
         timeWindow(p, start_s, stop_s, why);
}

bool WaterDryer::parse(const std::string& spec, WaterDryer* out, std::string* why) {
  std::string kind;
  std::map<std::string, double> v;
  if (!parseSpec(spec, {"box"},
                 {"x", "y", "z", "hx", "hy", "hz", "rate_per_s", "start_s", "stop_s"}, &kind, &v,
                 why))
    return false;
  WaterDryer d;
  auto get = [&](const char* k, double fallback) { return v.count(k) ? v[k] : fallback; };
  d.center_m = Vec3(get("x", 0.0), get("y", 0.0), get("z", 0.0));
  d.half_extents_m = Vec3(get("hx", 0.1), get("hy", 0.1), get("hz", 0.1));
  d.rate_per_s = get("rate_per_s", d.rate_per_s);
  d.start_s = get("start_s", 0.0);
  d.stop_s = get("stop_s", d.stop_s);
  if (!d.validate("box.", why)) return false;
  *out = d;
  return true;
}

std::string WaterDryer::spec() const {
  std::string s = "box:x=" + shortest(center_m.x()) + ",y=" + shortest(center_m.y()) +
                  ",z=" + shortest(center_m.z()) + ",hx=" + shortest(half_extents_m.x()) +
                  ",hy=" + shortest(half_extents_m.y()) + ",hz=" + shortest(half_extents_m.z()) +
                  ",rate_per_s=" + shortest(rate_per_s) + ",start_s=" + shortest(start_s);
  if (std::isfinite(stop_s)) s += ",stop_s=" + shortest(stop_s);
  return s;
}

void transportStrand(int n, const double* capacity, const double* edge_m, const double* downhill,
                     double capacity_per_m, double wicking_m2_s, double flow_m_s, double dt,
                     double* held, double* scratch) {
  if (n < 2) return;
  double* cp = scratch;      // Thomas: the eliminated upper diagonal
  double* dp = scratch + n;  // and right-hand side
  // Edge i couples particles i and i+1. Diffusion conductance g = D c / L; upwind gravity flow
  // moves p u_i down the edge when it points along gravity, q u_{i+1} when against it.
  auto g = [&](int i) { return wicking_m2_s * capacity_per_m / edge_m[i]; };
  auto p = [&](int i) { return flow_m_s * capacity_per_m * std::max(downhill[i], 0.0); };
  auto q = [&](int i) { return flow_m_s * capacity_per_m * std::max(-downhill[i], 0.0); };
  for (int i = 0; i < n; ++i) {
    double diag = capacity[i];
    double lower = 0.0, upper = 0.0;
    if (i + 1 < n) {
      diag += dt * (g(i) + p(i));
      upper = -dt * (g(i) + q(i));
    }
    if (i > 0) {
      diag += dt * (g(i - 1) + q(i - 1));
      lower = -dt * (g(i - 1) + p(i - 1));
    }
    const double m = i > 0 ? diag - lower * cp[i - 1] : diag;
    cp[i] = upper / m;
    dp[i] = (held[i] - (i > 0 ? lower * dp[i - 1] : 0.0)) / m;
  }
  double u = dp[n - 1];
  held[n - 1] = capacity[n - 1] * u;
  for (int i = n - 2; i >= 0; --i) {
    u = dp[i] - cp[i] * u;
    held[i] = capacity[i] * u;
  }
}

namespace {

/// Showers and baths over [t0, t0 + dt): water into state->water_kg.
void addSources(const HairModel& model, const WaterConfig& config, const WaterSources& sources,
                double t0, double dt, HairState* state, WaterStepStats* stats) {
  const int n = model.particleCount();
  for (const WaterSource& src : sources.sources) {
    const double on = overlapSeconds(src.start_s, src.stop_s, t0, t0 + dt);
    if (on <= 0.0) continue;
    if (src.kind == WaterSource::Kind::kBath) {
      for (int i = 0; i < n; ++i) {
        if (state->position[i].z() >= src.level_m) continue;
        const double deficit = particleCapacity(model, config, i) - state->water_kg[i];
        if (deficit <= 0.0) continue;
        state->water_kg[i] += deficit;
        stats->added_kg += deficit;
      }
      continue;
    }
    auto inColumn = [&](const Vec3& x) {
      const double dx = x.x() - src.center_m.x(), dy = x.y() - src.center_m.y();
      return x.z() <= src.center_m.z() && dx * dx + dy * dy <= src.radius_m * src.radius_m;
    };
    double length = 0.0;
    for (int i = 0; i < n; ++i)
      if (inColumn(state->position[i])) length += model.length_share_m[i];
    if (length <= 0.0) continue;  // the water finds no hair
    const double total = src.rate_kg_s * on;
    for (int i = 0; i < n; ++i) {
      if (!inColumn(state->position[i])) continue;
      state->water_kg[i] += total * model.length_share_m[i] / length;
      ++stats->shower_particles;
    }
    stats->added_kg += total;
  }
}

constexpr uint64_t kEmptySlot = ~uint64_t{0};

/// A cell's coordinates packed into one key (21 bits each: cells of 5 mm span 10 km).
uint64_t cellKey(const Vec3& x, double cell_m) {
  const uint64_t m = (uint64_t{1} << 21) - 1;
  uint64_t key = 0;
  for (int a = 0; a < 3; ++a)
    key |= (static_cast<uint64_t>(static_cast<long>(std::floor(x[a] / cell_m))) & m) << (21 * a);
  return key;
}

/// The slot of `key` in the open-addressing table (linear probing), claimed when new.
uint32_t claimSlot(uint64_t key, uint32_t strand, WaterScratch* w) {
  const size_t mask = w->slots.size() - 1;  // a power of two
  size_t h = (key * 0x9E3779B97F4A7C15ull) >> 20 & mask;
  while (w->slots[h].key != key && w->slots[h].key != kEmptySlot) h = (h + 1) & mask;
  if (w->slots[h].key == kEmptySlot) {
    WaterScratch::Slot& slot = w->slots[h];
    slot.key = key;
    slot.capacity = slot.water = 0.0;
    slot.strand = strand;
    slot.mixed = 0;
    w->used_slots.push_back(static_cast<uint32_t>(h));
  }
  return static_cast<uint32_t>(h);
}

/// Strands in contact share water: particles in one cell of the exchange lattice (cells of
/// exchange_cell_m, in the world frame) relax toward the cell's saturation, u_i += r (U - u_i)
/// with U = (water in the cell) / (capacity in the cell) and r = 1 - exp(-rate dt), in cells
/// that hold particles of more than one strand. Exactly conservative (the capacity-weighted
/// changes of a cell sum to zero) and a convex combination (r < 1: no particle goes negative).
/// O(n): one pass to sum the cells (an open-addressing hash table), one to relax.
void exchangeWater(const HairModel& model, const WaterConfig& config, double dt, HairState* state,
                   WaterStepStats* stats) {
  if (config.exchange_per_s <= 0.0) return;
  WaterScratch& w = state->water_scratch;
  const int n = model.particleCount();
  const std::vector<uint32_t>& strand = state->grid.strand_of;
  for (int i = 0; i < n; ++i) {
    const uint32_t h =
        claimSlot(cellKey(state->position[i], config.exchange_cell_m), strand[i], &w);
    w.cell_of[i] = h;
    WaterScratch::Slot& slot = w.slots[h];
    slot.capacity += particleCapacity(model, config, i);
    slot.water += state->water_kg[i];
    slot.mixed |= slot.strand != strand[i];
  }
  const double r = -std::expm1(-config.exchange_per_s * dt);
  for (int i = 0; i < n; ++i) {
    const uint32_t h = w.cell_of[i];
    const WaterScratch::Slot& slot = w.slots[h];
    if (!slot.mixed) continue;
    const double capacity = particleCapacity(model, config, i);
    state->water_kg[i] += r * (capacity * (slot.water / slot.capacity) - state->water_kg[i]);
    ++stats->exchange_particles;
  }
  for (uint32_t h : w.used_slots) w.slots[h].key = kEmptySlot;
  w.used_slots.clear();
}

/// Wicking and gravity flow along every strand (transportStrand on its rest edges).
void transportAll(const HairModel& model, const WaterConfig& config, const Vec3& gravity, double dt,
                  HairState* state) {
  const double g = gravity.norm();
  const Vec3 down = g > 0.0 ? Vec3(gravity / g) : Vec3::Zero();
  const double flow = config.gravity_flow_m_s * g / 9.81;
  WaterScratch& w = state->water_scratch;
  for (int s = 0; s < model.strandCount(); ++s) {
    const int begin = model.strandBegin(s), n = model.strandSize(s);
    double* capacity = w.strand.data();
    for (int i = 0; i < n; ++i) capacity[i] = particleCapacity(model, config, begin + i);
    for (int i = 0; i + 1 < n; ++i) {
      w.edge_m[i] = model.rest_edge_m[begin + i];
      const Vec3 e = state->position[begin + i + 1] - state->position[begin + i];
      const double len = e.norm();
      w.downhill[i] = len > 0.0 ? down.dot(e) / len : 0.0;
    }
    transportStrand(n, capacity, w.edge_m.data(), w.downhill.data(), config.capacity_kg_per_m,
                    config.wicking_m2_s, flow, dt, state->water_kg.data() + begin,
                    w.strand.data() + n);
  }
}

}  // namespace

void stepWater(const HairModel& model, const WaterConfig& config, const WaterSources& sources,
               const Vec3& gravity_m_s2, double t0, double dt, HairState* state,
               WaterStepStats* stats) {
  if (!(dt > 0.0)) return;
  WaterStepStats local;
  addSources(model, config, sources, t0, dt, state, &local);
  // The exchange over the time since it last ran, once that reaches its interval (a first step,
  // or time that went back, starts it afresh at t0).
  WaterScratch& ws = state->water_scratch;
  if (!(ws.exchange_until_s <= t0)) ws.exchange_until_s = t0;
  const double elapsed = t0 + dt - ws.exchange_until_s;
  if (config.exchange_per_s > 0.0 && elapsed >= config.exchange_interval_s * (1.0 - 1e-9)) {
    exchangeWater(model, config, elapsed, state, &local);
    ws.exchange_until_s = t0 + dt;
  }
  transportAll(model, config, gravity_m_s2, dt, state);
  WaterScratch& w = state->water_scratch;
  w.drip_points.clear();
  const int n = model.particleCount();
  // The evaporated fraction 1 - exp(-rate dt) (evaporate()), recomputed only when the rate
  // changes: most particles share the rate outside dryers or one dryer's.
  double last_rate = -1.0, fraction = 0.0;
  for (int i = 0; i < n; ++i) {
    const double capacity = particleCapacity(model, config, i);
    const double dripped = drip(capacity, &state->water_kg[i]);
    if (dripped > 0.0) {
      local.dripped_kg += dripped;
      ++local.drips;
      w.drip_points.push_back(state->position[i]);
    }
    // The dryers' rates, weighted by the part of the step each is on.
    double rate = config.evaporation_per_s;
    for (const WaterDryer& d : sources.dryers) {
      const double on = overlapSeconds(d.start_s, d.stop_s, t0, t0 + dt);
      if (on > 0.0 &&
          ((state->position[i] - d.center_m).cwiseAbs() - d.half_extents_m).maxCoeff() <= 0.0)
        rate += d.rate_per_s * on / dt;
    }
    if (rate != last_rate) {
      last_rate = rate;
      fraction = -std::expm1(-rate * dt);
    }
    const double gone = state->water_kg[i] * fraction;
    state->water_kg[i] -= gone;
    local.evaporated_kg += gone;
    state->saturation[i] = std::clamp(state->water_kg[i] / capacity, 0.0, 1.0);
  }
  WaterLedger& l = state->water_ledger;
  l.added_kg += local.added_kg;
  l.dripped_kg += local.dripped_kg;
  l.evaporated_kg += local.evaporated_kg;
  l.drips += local.drips;
  if (stats) {
    stats->added_kg += local.added_kg;
    stats->dripped_kg += local.dripped_kg;
    stats->evaporated_kg += local.evaporated_kg;
    stats->drips += local.drips;
    stats->exchange_particles += local.exchange_particles;
    stats->shower_particles += local.shower_particles;
  }
}

int reconcileWater(const HairModel& model, const WaterConfig& config, HairState* state) {
  int changed = 0;
  for (int i = 0; i < model.particleCount(); ++i) {
    const double capacity = particleCapacity(model, config, i);
    double& held = state->water_kg[i];
    if (state->saturation[i] == std::clamp(held / capacity, 0.0, 1.0)) continue;
    const double target = state->saturation[i] * capacity;
    if (target > held)
      state->water_ledger.added_kg += target - held;
    else
      state->water_ledger.removed_kg += held - target;
    held = target;
    ++changed;
  }
  return changed;
}

void applyWaterMass(const HairState& state, HairModel* model) {
  const double rho = model->linear_density_kg_per_m;
  for (int s = 0; s < model->strandCount(); ++s) {
    const int begin = model->strandBegin(s), n = model->strandSize(s);
    for (int i = begin; i < begin + n; ++i) {
      model->mass_kg[i] = rho * model->length_share_m[i] + state.water_kg[i];
      model->inv_mass[i] = i == begin ? 0.0 : 1.0 / model->mass_kg[i];
    }
  }
  relayModelMassLanes(model);
}

double heldWater(const HairState& state) {
  double sum = 0.0;
  for (double m : state.water_kg) sum += m;
  return sum;
}

double meanSaturation(const HairState& state) {
  if (state.saturation.empty()) return 0.0;
  double sum = 0.0;
  for (double s : state.saturation) sum += s;
  return sum / static_cast<double>(state.saturation.size());
}

}  // namespace wet_curly_hair
