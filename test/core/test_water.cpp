// The water stage (water.h) against analytic answers: wicking as the diffusion equation, gravity
// flow moving the water's centre at the flow speed and running it to the tips, evaporation as an
// exponential, exchange between touching strands, and the ledger balancing to round-off under
// random sources, motions and commands.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "wet_curly_hair/core/saturation.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/water.h"

using namespace wet_curly_hair;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Straight strands of n particles with edges `edge`, strand k's root at roots[k], laid along
/// `direction` (no head collider matters: the water stage reads positions only).
HairModel lineModel(const Vec3List& roots, int n, double edge, const Vec3& direction) {
  Groom g;
  for (const Vec3& r : roots) {
    for (int i = 0; i < n; ++i) g.points.push_back(r + edge * i * direction.normalized());
    g.strand_offsets.push_back(static_cast<uint32_t>(g.points.size()));
    g.root_normals.push_back(direction.normalized());
  }
  SolverConfig c;
  c.collision.head_enabled = false;
  HairModel m;
  buildModelUnchecked(g, GroomConfig().linear_density_kg_per_m, HeadShape(), c, &m);
  return m;
}

/// Transport off, so a test sees only what it turns on.
WaterConfig still() {
  WaterConfig w;
  w.enabled = true;
  w.wicking_m2_s = 0.0;
  w.gravity_flow_m_s = 0.0;
  w.evaporation_per_s = 0.0;
  w.exchange_per_s = 0.0;
  return w;
}

/// Round-off bound on the water a strand's solve can create or lose per step, relative to the
/// water: each of the n rows is solved to about one ulp of its largest term, the diagonal
/// capacity + dt (flux coefficients), at most (1 + 4 D dt / L^2) times the capacity.
double solveRoundoff(int n, double d, double dt, double edge) {
  return n * 2.2e-16 * (1.0 + 4.0 * d * dt / (edge * edge));
}

double balance(const HairState& s) {
  const WaterLedger& l = s.water_ledger;
  return l.added_kg - l.removed_kg - heldWater(s) - l.dripped_kg - l.evaporated_kg;
}

}  // namespace

// ds/dt = D d2s/dx2 on [0, Lt] with no flux at the ends: s = 1 + a cos(pi x / Lt) keeps its shape
// and its amplitude decays as exp(-D (pi / Lt)^2 t). Errors of the scheme: the second difference
// (relative (k L)^2 / 12 = 8e-5 at 100 edges) and backward Euler (relative lambda^2 dt t / 2 =
// 1.2e-4 here): bound 1e-3 of the amplitude. The water is conserved to round-off.
TEST(Water, WickingDecaysACosineModeAsTheDiffusionEquation) {
  const int n = 101;
  const double lt = 0.25, edge = lt / (n - 1), c = 0.012, d = 1e-4, dt = 1.0 / 60.0;
  std::vector<double> cap(n), held(n), edges(n - 1, edge), down(n - 1, 0.0), scratch(2 * n);
  for (int i = 0; i < n; ++i) {
    cap[i] = c * edge * (i == 0 || i == n - 1 ? 0.5 : 1.0);
    held[i] = cap[i] * (0.5 + 0.4 * std::cos(kPi * i / (n - 1)));
  }
  double mass0 = 0.0;
  for (double h : held) mass0 += h;
  const int frames = 3600;  // 60 s: exp(-0.95)
  for (int f = 0; f < frames; ++f)
    transportStrand(n, cap.data(), edges.data(), down.data(), c, d, 0.0, dt, held.data(),
                    scratch.data());
  const double k = kPi / lt;
  const double amp = 0.4 * std::exp(-d * k * k * frames * dt);
  double mass = 0.0;
  for (int i = 0; i < n; ++i) {
    mass += held[i];
    const double expected = 0.5 + amp * std::cos(kPi * i / (n - 1));
    EXPECT_NEAR(held[i] / cap[i], expected, 1e-3 * amp) << "particle " << i;
  }
  EXPECT_NEAR(mass, mass0, frames * solveRoundoff(n, d, dt, edge) * mass0);
}

// Backward Euler is stable at any step: a frame 50 times the explicit bound L^2 / 2D still gives
// non-negative water that is conserved, and a spike spreads monotonically toward uniform.
TEST(Water, WickingIsStableAndPositiveBeyondTheExplicitBound) {
  const int n = 32;
  const double edge = 0.008, c = 0.012, d = 1e-3;
  const double dt = 50.0 * edge * edge / (2.0 * d);
  std::vector<double> cap(n, c * edge), held(n, 0.0), edges(n - 1, edge), down(n - 1, 0.0),
      scratch(2 * n);
  held[5] = 3.0 * cap[5];
  // 60 steps: the slowest mode (lambda = D (pi / 0.248 m)^2) shrinks by (1 + lambda dt)^-60 = 1e-6.
  for (int f = 0; f < 60; ++f) {
    transportStrand(n, cap.data(), edges.data(), down.data(), c, d, 0.0, dt, held.data(),
                    scratch.data());
    double mass = 0.0;
    for (int i = 0; i < n; ++i) {
      EXPECT_GE(held[i], 0.0);
      mass += held[i];
    }
    EXPECT_NEAR(mass, 3.0 * cap[5], (f + 1) * solveRoundoff(n, d, dt, edge) * 3.0 * cap[5]);
  }
  for (int i = 0; i < n; ++i) EXPECT_NEAR(held[i] / cap[i], 3.0 / n, 0.01 * 3.0 / n);
}

// On a strand hanging along gravity the flux down edge i is v c u_i, which moves the first moment
// sum x_i m_i at exactly v times the water on interior particles; wicking adds D c (u_0 - u_tip),
// zero while root and tip are dry. So the water's centre descends at v while it is away from
// the ends (backward Euler keeps this exactly: the moment is linear in the new values).
TEST(Water, GravityFlowMovesTheWaterCentreAtTheFlowSpeed) {
  const int n = 201;
  const double edge = 0.002, c = 0.012, v = 0.01, d = 1e-6, dt = 1.0 / 60.0;
  std::vector<double> cap(n), held(n, 0.0), edges(n - 1, edge), down(n - 1, 1.0), scratch(2 * n);
  for (int i = 0; i < n; ++i) cap[i] = c * edge * (i == 0 || i == n - 1 ? 0.5 : 1.0);
  for (int i = 20; i < 40; ++i) held[i] = 0.8 * cap[i];
  auto centre = [&] {
    double m = 0.0, moment = 0.0;
    for (int i = 0; i < n; ++i) {
      m += held[i];
      moment += held[i] * edge * i;
    }
    return moment / m;
  };
  const double start = centre();
  const int frames = 900;  // 15 s: 0.15 m down a 0.4 m strand, the front 0.17 m from the tip
  for (int f = 0; f < frames; ++f)
    transportStrand(n, cap.data(), edges.data(), down.data(), c, d, v, dt, held.data(),
                    scratch.data());
  // The tip is still dry (upwind's numerical diffusion sends a thin front ahead): the claim holds
  // to v t times the tip's share of the water.
  double mass = 0.0;
  for (double h : held) mass += h;
  ASSERT_LT(held[n - 1], 1e-9 * mass);
  EXPECT_NEAR(centre() - start, v * frames * dt, 1e-9 * v * frames * dt);
}

// Through stepWater: a uniformly wet strand hanging down runs its water to the tip, which fills
// to its capacity and drips the rest (wicking small: D / v = 0.1 mm, under one edge).
TEST(Water, GravityFlowReachesTheTipsAndDrips) {
  const HairModel m = lineModel({Vec3(0, 0, 1)}, 32, 0.008, Vec3(0, 0, -1));
  HairState s = makeState(m, Pose(), Twist());
  WaterConfig w = still();
  w.gravity_flow_m_s = 0.01;
  w.wicking_m2_s = 1e-6;
  s.saturation.assign(s.saturation.size(), 0.5);
  reconcileWater(m, w, &s);
  const double start = heldWater(s);
  double t = 0.0;
  for (int f = 0; f < 60 * 90; ++f, t += 1.0 / 60.0)  // 90 s: 3.6 strand lengths at 1 cm/s
    stepWater(m, w, WaterSources(), Vec3(0, 0, -9.81), t, 1.0 / 60.0, &s, nullptr);
  const int tip = m.particleCount() - 1;
  EXPECT_NEAR(s.saturation[tip], 1.0, 1e-9);
  EXPECT_LT(s.saturation[tip - 3], 0.01);
  EXPECT_NEAR(s.water_ledger.dripped_kg, start - particleCapacity(m, w, tip), 0.01 * start);
  EXPECT_GT(s.water_ledger.drips, 0u);
  EXPECT_NEAR(balance(s), 0.0, 1e-15);
}

// Evaporation: exactly exp(-k t) at every frame; inside a dryer's box exp(-(k + k_d) t); a dryer
// on for half a frame adds half its rate for that frame.
TEST(Water, EvaporationDecaysExponentiallyAndFasterInADryer) {
  const HairModel m = lineModel({Vec3(0, 0, 0), Vec3(1, 0, 0)}, 8, 0.01, Vec3(0, 0, -1));
  HairState s = makeState(m, Pose(), Twist());
  WaterConfig w = still();
  w.evaporation_per_s = 0.02;
  WaterSources src;
  WaterDryer dryer;  // around the second strand only
  dryer.center_m = Vec3(1, 0, -0.035);
  dryer.half_extents_m = Vec3(0.1, 0.1, 0.1);
  dryer.rate_per_s = 0.1;
  dryer.start_s = 0.0;
  dryer.stop_s = 10.0 + 0.5 / 60.0;
  src.dryers.push_back(dryer);
  s.saturation.assign(s.saturation.size(), 0.9);
  reconcileWater(m, w, &s);
  const std::vector<double> start = s.water_kg;
  const double dt = 1.0 / 60.0;
  for (int f = 0; f < 601; ++f) {
    stepWater(m, w, src, Vec3(0, 0, -9.81), f * dt, dt, &s, nullptr);
    const double t = (f + 1) * dt;
    const double dried = f < 600 ? 0.1 * t : 0.1 * (600 * dt + 0.5 * dt);
    for (int i = 0; i < m.particleCount(); ++i) {
      const double expected =
          start[i] * std::exp(-0.02 * t - (i >= m.strandBegin(1) ? dried : 0.0));
      ASSERT_NEAR(s.water_kg[i], expected, 1e-12 * start[i]) << "frame " << f << " particle " << i;
    }
  }
  EXPECT_NEAR(balance(s), 0.0, 1e-15);
}

// Two parallel strands 2 mm apart with 8 mm edges: each 5 mm cell holds one particle of each, whose
// saturation difference then decays exactly as exp(-k t) (equal capacities), the sum kept. Run
// every frame (interval 0) or every third (interval 0.05 s at 60 frames/s, over the elapsed
// time): the same decay at the frames where it ran.
TEST(Water, TouchingStrandsShareWater) {
  for (const double interval : {0.0, 0.05}) {
    const HairModel m = lineModel({Vec3(0, 0, 0), Vec3(0, 0.002, 0)}, 10, 0.008, Vec3(1, 0, 0));
    HairState s = makeState(m, Pose(), Twist());
    WaterConfig w = still();
    w.exchange_per_s = 2.0;
    w.exchange_cell_m = 0.005;
    w.exchange_interval_s = interval;
    SaturationCommand wet;
    wet.strands = {0};
    applySaturation(m, wet, Pose(), &s);
    reconcileWater(m, w, &s);
    const double dt = 1.0 / 60.0;
    WaterStepStats stats;
    for (int f = 0; f < 30; ++f)
      stepWater(m, w, WaterSources(), Vec3::Zero(), f * dt, dt, &s, &stats);
    EXPECT_EQ(stats.exchange_particles, interval > 0.0 ? 200u : 600u);
    for (int i = 0; i < 10; ++i) {
      EXPECT_NEAR(s.saturation[i] - s.saturation[10 + i], std::exp(-2.0 * 30 * dt), 1e-12);
      EXPECT_NEAR(s.saturation[i] + s.saturation[10 + i], 1.0, 1e-12);
    }
  }
}

// A shower puts rate x time into the hair in its column, shared by length; water that finds no
// hair is not counted; a bath fills what is below its level to capacity.
TEST(Water, ShowerAndBathAddWhatTheySay) {
  const HairModel m = lineModel({Vec3(0, 0, 0), Vec3(1, 0, 0)}, 8, 0.01, Vec3(0, 0, -1));
  HairState s = makeState(m, Pose(), Twist());
  WaterConfig w = still();
  w.capacity_kg_per_m = 1.0;  // no drip: the shower's water stays
  WaterSources src;
  ASSERT_TRUE(
      WaterSource::parse("shower:x=0,y=0,z=0.5,r=0.05,rate_kg_s=0.002,start_s=0.1,stop_s=0.2",
                         &src.sources.emplace_back(), nullptr));
  ASSERT_TRUE(WaterSource::parse("shower:x=5,y=0,z=0.5,r=0.05,rate_kg_s=1",
                                 &src.sources.emplace_back(),
                                 nullptr));  // over no hair
  const double dt = 1.0 / 60.0;
  for (int f = 0; f < 20; ++f) stepWater(m, w, src, Vec3(0, 0, -9.81), f * dt, dt, &s, nullptr);
  EXPECT_NEAR(s.water_ledger.added_kg, 0.002 * 0.1, 1e-15);
  for (int i = 0; i < 8; ++i)
    EXPECT_NEAR(s.water_kg[i], 0.0002 * m.length_share_m[i] / 0.07, 1e-15) << i;
  for (int i = 8; i < 16; ++i) EXPECT_EQ(s.water_kg[i], 0.0);
  WaterSources bath;
  ASSERT_TRUE(WaterSource::parse("bath:z=-0.035", &bath.sources.emplace_back(), nullptr));
  stepWater(m, w, bath, Vec3(0, 0, -9.81), 1.0, dt, &s, nullptr);
  for (int i = 0; i < 16; ++i) EXPECT_EQ(s.saturation[i] == 1.0, s.position[i].z() < -0.035) << i;
  EXPECT_NEAR(balance(s), 0.0, 1e-15);
}

// The ledger balances to round-off under random showers, baths, dryers, set/add commands and
// random motions (the particles jump about: the stage reads positions only), with every transport
// on, exchange included.
TEST(Water, EveryKilogramIsAccountedFor) {
  GroomConfig gc;
  gc.strands = 60;
  gc.particles = 16;
  HairModel m;
  std::string why;
  ASSERT_TRUE(buildModel(generateGroom(gc, EllipsoidShape()), gc.linear_density_kg_per_m,
                         HeadShape(), SolverConfig(), &m, &why))
      << why;
  HairState s = makeState(m, Pose(), Twist());
  WaterConfig w;
  w.enabled = true;
  w.evaporation_per_s = 0.05;
  w.exchange_cell_m = 0.01;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double dt = 1.0 / 30.0;
  uint64_t pairs = 0;
  for (int f = 0; f < 300; ++f) {
    WaterSources src;
    WaterSource shower;
    shower.center_m = Vec3(0.05 * u(rng), 0.05 * u(rng), 0.3);
    shower.radius_m = 0.05 + 0.04 * u(rng);
    shower.rate_kg_s = 0.01 * (1.0 + u(rng));
    shower.start_s = f * dt + dt * 0.5 * (1.0 + u(rng));
    src.sources.push_back(shower);
    if (f % 17 == 0) {
      WaterSource bath;
      bath.kind = WaterSource::Kind::kBath;
      bath.level_m = 0.1 * u(rng);
      src.sources.push_back(bath);
    }
    WaterDryer dryer;
    dryer.center_m = Vec3(0.1 * u(rng), 0.1 * u(rng), 0.1 * u(rng));
    dryer.rate_per_s = 0.5;
    src.dryers.push_back(dryer);
    for (Vec3& p : s.position) p += 0.01 * Vec3(u(rng), u(rng), u(rng));
    if (f % 23 == 0) {
      SaturationCommand c;
      c.add = f % 2 == 0;
      c.root_value = 0.5 * u(rng);
      c.tip_value = c.add ? 0.5 * u(rng) : 0.5 * (1.0 + u(rng));
      if (!c.add) c.root_value = std::abs(c.root_value);
      applySaturation(m, c, Pose(), &s);
      reconcileWater(m, w, &s);
    }
    WaterStepStats stats;
    stepWater(m, w, src, Vec3(0, 0, -9.81), f * dt, dt, &s, &stats);
    pairs += stats.exchange_particles;
    const double scale = s.water_ledger.added_kg;
    ASSERT_NEAR(balance(s), 0.0, 1e-13 * scale) << "frame " << f;
    for (size_t i = 0; i < s.water_kg.size(); ++i) {
      ASSERT_GE(s.water_kg[i], 0.0);
      ASSERT_EQ(s.saturation[i], std::clamp(s.water_kg[i] / particleCapacity(m, w, i), 0.0, 1.0));
    }
  }
  EXPECT_GT(pairs, 0u);
  EXPECT_GT(s.water_ledger.dripped_kg, 0.0);
  EXPECT_GT(s.water_ledger.evaporated_kg, 0.0);
  EXPECT_GT(s.water_ledger.removed_kg, 0.0);
}

// A command that sets the saturation books the change: adding water counts as added, drying as
// removed, and a particle already at its value is left alone (its water above capacity too).
TEST(Water, ReconcileBooksCommands) {
  const HairModel m = lineModel({Vec3(0, 0, 0)}, 5, 0.01, Vec3(0, 0, -1));
  HairState s = makeState(m, Pose(), Twist());
  WaterConfig w = still();
  s.saturation.assign(5, 1.0);
  EXPECT_EQ(reconcileWater(m, w, &s), 5);
  const double full = heldWater(s);
  EXPECT_NEAR(s.water_ledger.added_kg, w.capacity_kg_per_m * 0.04, 1e-16);
  s.water_kg[2] *= 1.5;  // above capacity: saturation 1 still agrees
  EXPECT_EQ(reconcileWater(m, w, &s), 0);
  s.saturation[3] = 0.25;
  EXPECT_EQ(reconcileWater(m, w, &s), 1);
  EXPECT_NEAR(s.water_ledger.removed_kg, 0.75 * particleCapacity(m, w, 3), 1e-16);
  EXPECT_NEAR(heldWater(s), full + 0.5 * particleCapacity(m, w, 2) - s.water_ledger.removed_kg,
              1e-16);
}

TEST(Water, BadConfigAndSpecsAreRefusedWithTheFieldNamed) {
  struct Case {
    void (*edit)(WaterConfig*);
    const char* field;
  };
  const Case cases[] = {
      {[](WaterConfig* w) { w->capacity_kg_per_m = 0.0; }, "water.capacity_kg_per_m"},
      {[](WaterConfig* w) { w->wicking_m2_s = -1.0; }, "water.wicking_m2_s"},
      {[](WaterConfig* w) { w->gravity_flow_m_s = NAN; }, "water.gravity_flow_m_s"},
      {[](WaterConfig* w) { w->evaporation_per_s = -0.1; }, "water.evaporation_per_s"},
      {[](WaterConfig* w) { w->exchange_per_s = INFINITY; }, "water.exchange_per_s"},
      {[](WaterConfig* w) { w->exchange_cell_m = 0.0; }, "water.exchange_cell_m"},
      {[](WaterConfig* w) { w->exchange_interval_s = -1.0; }, "water.exchange_interval_s"},
  };
  EXPECT_TRUE(WaterConfig().validate("water.", nullptr));
  for (const Case& c : cases) {
    WaterConfig w;
    c.edit(&w);
    std::string why;
    EXPECT_FALSE(w.validate("water.", &why)) << c.field;
    EXPECT_EQ(why.rfind(std::string(c.field) + ":", 0), 0u) << why;
  }
  const std::pair<const char*, const char*> specs[] = {
      {"shower:x=0,y=0,z=1,r=0,rate_kg_s=0.01", "shower.r:"},
      {"shower:x=0,y=0,z=1,r=0.1,rate_kg_s=-1", "shower.rate_kg_s:"},
      {"shower:x=0,y=0,z=1,r=0.1,start_s=2,stop_s=1", "shower.stop_s:"},
      {"shower:x=0,y=0,z=1,r=0.1,flow=2", "shower.flow:"},
      {"shower:x=zero", "shower.x:"},
      {"bath:start_s=0", "bath.z:"},
      {"bath:z=0,r=1", "bath.r:"},
      {"hose:x=0", "'hose'"},
  };
  for (const auto& [spec, field] : specs) {
    WaterSource out;
    std::string why;
    EXPECT_FALSE(WaterSource::parse(spec, &out, &why)) << spec;
    EXPECT_NE(why.find(field), std::string::npos) << spec << " -> " << why;
  }
  const std::pair<const char*, const char*> dryers[] = {
      {"box:x=0,y=0,z=0,hx=0", "box.hx:"}, {"box:rate_per_s=-1", "box.rate_per_s:"},
      {"box:start_s=-1", "box.start_s:"},  {"box:r=1", "box.r:"},
      {"sphere:x=0", "'sphere'"},
  };
  for (const auto& [spec, field] : dryers) {
    WaterDryer out;
    std::string why;
    EXPECT_FALSE(WaterDryer::parse(spec, &out, &why)) << spec;
    EXPECT_NE(why.find(field), std::string::npos) << spec << " -> " << why;
  }
  // What spec() writes, parse reads back.
  WaterSource a;
  ASSERT_TRUE(WaterSource::parse("shower:x=0.1,y=-2,z=1,r=0.3,rate_kg_s=0.004,start_s=1,stop_s=4",
                                 &a, nullptr));
  WaterSource b;
  ASSERT_TRUE(WaterSource::parse(a.spec(), &b, nullptr));
  EXPECT_EQ(a.spec(), b.spec());
  WaterDryer d, e;
  ASSERT_TRUE(WaterDryer::parse("box:x=0,y=0,z=0.2,hx=0.2,hy=0.2,hz=0.1,start_s=5", &d, nullptr));
  ASSERT_TRUE(WaterDryer::parse(d.spec(), &e, nullptr));
  EXPECT_EQ(d.spec(), e.spec());
  EXPECT_TRUE(std::isinf(e.stop_s));
}

// The exchange against a direct reference: particles grouped by the cell floor(x / cell), and in
// each cell holding more than one strand every saturation moves toward the cell's capacity-
// weighted mean by 1 - exp(-k dt). On a groom shaken into random contacts (hash-table collisions
// must not merge cells).
TEST(Water, ExchangeMixesEachSharedCellTowardItsMean) {
  GroomConfig gc;
  gc.strands = 80;
  gc.particles = 12;
  HairModel m;
  std::string why;
  ASSERT_TRUE(buildModel(generateGroom(gc, EllipsoidShape()), gc.linear_density_kg_per_m,
                         HeadShape(), SolverConfig(), &m, &why))
      << why;
  HairState s = makeState(m, Pose(), Twist());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (Vec3& p : s.position) p = 0.05 * Vec3(u(rng), u(rng), u(rng));
  for (double& x : s.saturation) x = 0.5 * (1.0 + u(rng));
  WaterConfig w = still();
  w.exchange_per_s = 3.0;
  w.exchange_cell_m = 0.02;
  reconcileWater(m, w, &s);
  const double dt = 0.05, r = 1.0 - std::exp(-3.0 * dt);
  std::map<std::array<long, 3>, std::vector<int>> cells;
  for (int i = 0; i < m.particleCount(); ++i) {
    std::array<long, 3> c;
    for (int a = 0; a < 3; ++a) c[a] = static_cast<long>(std::floor(s.position[i][a] / 0.02));
    cells[c].push_back(i);
  }
  std::vector<double> expected = s.water_kg;
  uint64_t mixed = 0;
  for (const auto& [cell, members] : cells) {
    double water = 0.0, capacity = 0.0;
    std::set<uint32_t> strands;
    for (int i : members) {
      water += s.water_kg[i];
      capacity += particleCapacity(m, w, i);
      strands.insert(s.grid.strand_of[i]);
    }
    if (strands.size() < 2) continue;
    for (int i : members) {
      expected[i] += r * (particleCapacity(m, w, i) * water / capacity - s.water_kg[i]);
      ++mixed;
    }
  }
  WaterStepStats stats;
  stepWater(m, w, WaterSources(), Vec3::Zero(), 0.0, dt, &s, &stats);
  ASSERT_GT(mixed, 100u);
  EXPECT_EQ(stats.exchange_particles, mixed);
  for (int i = 0; i < m.particleCount(); ++i)
    ASSERT_NEAR(s.water_kg[i], expected[i], 1e-12 * particleCapacity(m, w, i)) << i;
}

// Wet hair is heavier: a straight chain hanging from its root, uniformly at saturation u, stretches
// as the weight below each edge says with rho replaced by rho + c u (test_solver's
// HangingStraightChainStretchesAsItsWeightSays, same bound: 1 %); the water's share is half the
// stretch here, so leaving it out fails. No water gives back the dry masses bit for bit.
TEST(Water, HeldWaterAddsToTheMassesAndTheHangingStretch) {
  Groom g;
  const int n = 32;
  const double edge = 0.008;
  for (int i = 0; i < n; ++i) g.points.push_back(Vec3(0, 0, -0.2 - edge * i));
  g.strand_offsets = {0, static_cast<uint32_t>(n)};
  g.root_normals = {Vec3(0, 0, -1)};
  SolverConfig c;
  c.core.stiffness_n = 0.0;
  c.core.damping_n_s = 0.0;
  c.collision.head_enabled = false;
  c.curl.enabled = false;
  c.adhesion.enabled = false;
  c.cohesion.mode = "off";
  c.stiffness.wet_factor = c.stiffness.dry_factor;  // eq. 13: wet damps as dry
  HairModel m;
  std::string why;
  const double rho = GroomConfig().linear_density_kg_per_m;
  ASSERT_TRUE(buildModel(g, rho, HeadShape(), c, &m, &why)) << why;
  const HairModel dry = m;
  HairState s = makeState(m, Pose(), Twist());
  WaterConfig w = still();
  w.capacity_kg_per_m = rho;
  const double u = 0.5;
  s.saturation.assign(n, u);
  reconcileWater(m, w, &s);
  applyWaterMass(s, &m);
  // The bounds stay the dry ones, also when a parameter change recomputes them.
  ASSERT_TRUE(updateSpringConstants(c, &m, &why)) << why;
  EXPECT_EQ(m.explicit_substep_bound_s, dry.explicit_substep_bound_s);
  EXPECT_EQ(m.max_damping_per_mass, dry.max_damping_per_mass);
  const double frame = 1.0 / 60.0;
  for (int f = 0; f < 360; ++f) {
    StepInputs in;
    StepStats stats;
    step(m, c, in, frame, &s, &stats);
  }
  const double alpha = c.bend.smoothing_length_m;
  const double k =
      c.stretch.axial_stiffness_n / edge + c.bend.stiffness_n_m2 / (edge * alpha * alpha);
  for (int i = 0; i + 1 < n; ++i) {
    const double expected = (rho + w.capacity_kg_per_m * u) * 9.81 * edge * (n - 1.5 - i) / k;
    const double got = (s.position[i + 1] - s.position[i]).norm() - edge;
    EXPECT_NEAR(got, expected, 0.01 * expected) << "edge " << i;
  }
  std::fill(s.water_kg.begin(), s.water_kg.end(), 0.0);
  applyWaterMass(s, &m);
  EXPECT_EQ(m.mass_kg, dry.mass_kg);
  EXPECT_EQ(m.inv_mass, dry.inv_mass);
}
