// rostest (services.test): ~set_saturation, ~set_parameters, ~get_parameters, ~reset; the
// parameter server mirror; parameters at start-up.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>

#include "ros_test_helpers.h"
#include "wet_curly_hair/GetParameters.h"
#include "wet_curly_hair/SetParameters.h"
#include "wet_curly_hair/SetSaturation.h"
#include "wet_curly_hair/SetWater.h"
#include "wet_curly_hair/Status.h"
#include "wet_curly_hair/WaterChange.h"
#include "wet_curly_hair/io/hair_file.h"
#include "wet_curly_hair/io/scene.h"

using wch_test::Latest;
using wet_curly_hair::GetParameters;
using wet_curly_hair::SetParameters;
using wet_curly_hair::SetSaturation;
using wet_curly_hair::Strands;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

class NodeServices : public testing::Test {
 protected:
  NodeServices()
      : strands_(nh_, "/wet_curly_hair/strands"),
        get_(nh_.serviceClient<GetParameters>("/wet_curly_hair/get_parameters")),
        set_(nh_.serviceClient<SetParameters>("/wet_curly_hair/set_parameters")),
        sat_(nh_.serviceClient<SetSaturation>("/wet_curly_hair/set_saturation")),
        reset_(nh_.serviceClient<std_srvs::Trigger>("/wet_curly_hair/reset")) {}

  GetParameters::Response getAll() {
    GetParameters srv;
    EXPECT_TRUE(wch_test::call(get_, &srv));
    EXPECT_TRUE(srv.response.success) << srv.response.message;
    return srv.response;
  }
  double get(const std::string& name) {
    GetParameters srv;
    srv.request.names = {name};
    EXPECT_TRUE(wch_test::call(get_, &srv));
    EXPECT_TRUE(srv.response.success) << srv.response.message;
    return srv.response.values.empty() ? kNaN : srv.response.values[0];
  }
  SetParameters::Response set(const std::vector<std::string>& names,
                              const std::vector<double>& values,
                              const std::vector<std::string>& string_names = {},
                              const std::vector<std::string>& string_values = {}) {
    SetParameters srv;
    srv.request.names = names;
    srv.request.values = values;
    srv.request.string_names = string_names;
    srv.request.string_values = string_values;
    EXPECT_TRUE(wch_test::call(set_, &srv));
    return srv.response;
  }
  /// A strands message produced after this call (so after anything done before it).
  Strands nextStrands() {
    Strands m;
    EXPECT_TRUE(strands_.next(20.0, &m)) << "no strands message within 20 s";
    return m;
  }
  /// The first strands message received after this call for which `shows` holds: the node
  /// publishes frames computed before a service call for a frame or two after it (more under
  /// load). After 20 s without one, a failure and the newest message, for the checks to report.
  Strands strandsShowing(const std::function<bool(const Strands&)>& shows) {
    Strands m;
    if (strands_.waitFor(20.0, shows, &m)) return m;
    ADD_FAILURE() << "no strands message showing the change within 20 s";
    EXPECT_TRUE(strands_.next(20.0, &m));
    return m;
  }
  void expectSameParameters(const GetParameters::Response& a, const GetParameters::Response& b,
                            const std::string& context) {
    ASSERT_EQ(a.names, b.names) << context;
    EXPECT_EQ(a.string_values, b.string_values) << context << ": a parameter changed";
  }

  ros::NodeHandle nh_;
  Latest<Strands> strands_;
  ros::ServiceClient get_, set_, sat_, reset_;
};

TEST_F(NodeServices, GetListsEveryScenParameterAndRefusesUnknownNames) {
  wet_curly_hair::io::SceneConfig probe;
  const auto table = wet_curly_hair::io::parameterTable(&probe);
  const GetParameters::Response all = getAll();
  ASSERT_EQ(all.names.size(), table.size());
  EXPECT_EQ(all.values.size(), table.size());
  EXPECT_EQ(all.string_values.size(), table.size());
  EXPECT_EQ(all.types.size(), table.size());
  EXPECT_EQ(all.docs.size(), table.size());
  EXPECT_EQ(all.needs_reset.size(), table.size());
  // start-up parameters given as ROS namespaces reach the scene
  EXPECT_DOUBLE_EQ(get("groom.strands"), 20.0);
  EXPECT_DOUBLE_EQ(get("solver.bend.damping_n_s"), 2e-3);
  GetParameters srv;
  srv.request.names = {"solver.bend.stiffness_n_m2", "solver.no_such_thing"};
  ASSERT_TRUE(wch_test::call(get_, &srv));
  EXPECT_FALSE(srv.response.success);
  EXPECT_NE(srv.response.message.find("solver.no_such_thing"), std::string::npos)
      << srv.response.message;
}

TEST_F(NodeServices, SetThenGetReturnsTheValueAndMirrorsIt) {
  SetParameters::Response r =
      set({"solver.bend.stiffness_n_m2", "solver.stretch.strain_limit"}, {4.25e-4, 0.04});
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_FALSE(r.reset);
  EXPECT_DOUBLE_EQ(get("solver.bend.stiffness_n_m2"), 4.25e-4);
  EXPECT_DOUBLE_EQ(get("solver.stretch.strain_limit"), 0.04);
  double mirrored = 0.0;
  ASSERT_TRUE(nh_.getParam("/wet_curly_hair/solver/bend/stiffness_n_m2", mirrored));
  EXPECT_DOUBLE_EQ(mirrored, 4.25e-4);
  // strings go through string_names / string_values
  r = set({}, {}, {"solver.cohesion.mode"}, {"off"});
  ASSERT_TRUE(r.success) << r.message;
  std::string mode;
  ASSERT_TRUE(nh_.getParam("/wet_curly_hair/solver/cohesion/mode", mode));
  EXPECT_EQ(mode, "off");
  nextStrands();
  EXPECT_TRUE(nextStrands().wet_positions.empty()) << "cohesion off: wet_positions must be empty";
  r = set({}, {}, {"solver.cohesion.mode"}, {"ours"});
  ASSERT_TRUE(r.success) << r.message;
  nextStrands();
  EXPECT_FALSE(nextStrands().wet_positions.empty());
}

TEST_F(NodeServices, InvalidSetsAreRefusedWithAMessageAndChangeNothing) {
  struct Case {
    const char* what;
    std::vector<std::string> names;
    std::vector<double> values;
    std::vector<std::string> string_names, string_values;
    const char* must_mention;
  };
  const std::vector<Case> cases = {
      {"NaN", {"solver.bend.stiffness_n_m2"}, {kNaN}, {}, {}, "solver.bend.stiffness_n_m2"},
      {"out of range",
       {"solver.stretch.strain_limit"},
       {-1.0},
       {},
       {},
       "solver.stretch.strain_limit"},
      {"unknown name", {"solver.bend.stifness"}, {1.0}, {}, {}, "solver.bend.stifness"},
      {"wrong array length", {"solver.bend.stiffness_n_m2", "groom.seed"}, {1.0}, {}, {}, "length"},
      {"not an integer", {"groom.strands"}, {2.5}, {}, {}, "groom.strands"},
      {"bool not 0/1",
       {"solver.collision.head_enabled"},
       {2.0},
       {},
       {},
       "solver.collision.head_enabled"},
      {"one bad among good ones",
       {"solver.bend.stiffness_n_m2", "solver.core.damping_n_s"},
       {3.3e-4, kNaN},
       {},
       {},
       "solver.core.damping_n_s"},
      {"string value not allowed",
       {},
       {},
       {"solver.cohesion.mode"},
       {"sticky"},
       "solver.cohesion.mode"},
      {"string for a number",
       {},
       {},
       {"solver.bend.stiffness_n_m2"},
       {"12"},
       "solver.bend.stiffness_n_m2"},
      {"number for a string", {"solver.cohesion.mode"}, {1.0}, {}, {}, "solver.cohesion.mode"},
      {"string arrays differ",
       {},
       {},
       {"solver.cohesion.mode", "solver.curl.mode"},
       {"off"},
       "length"},
      {"nothing given", {}, {}, {}, {}, "no parameter"},
      {"explicit past its stability bound (1e-2 s against about 6e-4 s at 12 particles)",
       {"solver.integrator.substep_s"},
       {1e-2},
       {"solver.integrator.method"},
       {"explicit"},
       "explicit integrator's stability bound"},
  };
  const GetParameters::Response before = getAll();
  XmlRpc::XmlRpcValue mirror_before;
  ASSERT_TRUE(nh_.getParam("/wet_curly_hair/solver", mirror_before));
  for (const Case& c : cases) {
    const SetParameters::Response r = set(c.names, c.values, c.string_names, c.string_values);
    EXPECT_FALSE(r.success) << c.what;
    EXPECT_FALSE(r.reset) << c.what;
    EXPECT_NE(r.message.find(c.must_mention), std::string::npos)
        << c.what << ": message '" << r.message << "' does not mention " << c.must_mention;
    expectSameParameters(before, getAll(), c.what);
  }
  XmlRpc::XmlRpcValue mirror_after;
  ASSERT_TRUE(nh_.getParam("/wet_curly_hair/solver", mirror_after));
  EXPECT_EQ(mirror_before.toXml(), mirror_after.toXml()) << "the parameter mirror changed";
}

TEST_F(NodeServices, GroomChangesRebuildTheModelAndResetTheHair) {
  const SetParameters::Response r = set({"groom.strands"}, {10});
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_TRUE(r.reset);
  const Strands m = nextStrands();
  EXPECT_EQ(m.strand_offsets.size(), 11u);
  EXPECT_EQ(wch_test::strandsProblem(m), "");
  ASSERT_TRUE(set({"groom.strands"}, {20}).success);
  EXPECT_EQ(nextStrands().strand_offsets.size(), 21u);
}

// A groom file with strands that cannot be simulated loads; the status counts what was skipped.
TEST_F(NodeServices, AGroomFileWithBadStrandsLoadsAndTheStatusCountsTheSkipped) {
  wet_curly_hair::io::HairFileData d;
  d.strand_offsets = {0};
  auto add = [&d](const std::vector<wet_curly_hair::Vec3>& pts) {
    for (const auto& p : pts)
      for (int k = 0; k < 3; ++k) d.points.push_back(static_cast<float>(p[k]));
    d.strand_offsets.push_back(static_cast<uint32_t>(d.points.size() / 3));
  };
  for (int k = 0; k < 3; ++k) {  // 10 cm, 6 points, from the top of the head outwards
    std::vector<wet_curly_hair::Vec3> line;
    const double a = 2.0 * M_PI * k / 3.0;
    for (int i = 0; i < 6; ++i)
      line.emplace_back(0.02 * i * std::cos(a), 0.02 * i * std::sin(a), 0.111);
    add(line);
  }
  add({{0, 0, 0.111}, {0, 0, 0.2}});                                       // 2 points
  add({{0, 0, 0.111}, {0.01, 0, 0.111}, {kNaN, 0, 0.1}, {0.03, 0, 0.1}});  // NaN
  const std::string path =
      "/tmp/wch_test_node_services_groom_" + std::to_string(getpid()) + ".hair";
  std::string why;
  ASSERT_TRUE(wet_curly_hair::io::writeHairFile(path, d, &why)) << why;
  Latest<wet_curly_hair::Status> status(nh_, "/wet_curly_hair/status");
  const SetParameters::Response r = set({}, {}, {"groom_file.file"}, {path});
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_TRUE(r.reset);
  wet_curly_hair::Status s;
  EXPECT_TRUE(status.waitFor(
      20.0, [](const wet_curly_hair::Status& m) { return m.strands == 3; }, &s))
      << "no status with the file's 3 simulable strands within 20 s";
  EXPECT_EQ(s.strands_skipped, 2u);
  EXPECT_EQ(s.particles, 18);
  ASSERT_TRUE(set({}, {}, {"groom_file.file"}, {""}).success);  // back to the generated groom
  EXPECT_TRUE(status.waitFor(
      20.0, [](const wet_curly_hair::Status& m) { return m.strands == 20; }, &s));
  EXPECT_EQ(s.strands_skipped, 0u);
  std::remove(path.c_str());
}

SetSaturation makeSat(float root, float tip, bool add = false) {
  SetSaturation s;
  s.request.root_value = root;
  s.request.tip_value = tip;
  s.request.add = add;
  return s;
}

TEST_F(NodeServices, SaturationSelectionsApply) {
  ASSERT_TRUE(reset_.waitForExistence(ros::Duration(20.0)));
  // everywhere, root-to-tip ramp
  SetSaturation s = makeSat(0.0f, 1.0f);
  ASSERT_TRUE(wch_test::call(sat_, &s));
  ASSERT_TRUE(s.response.success) << s.response.message;
  auto ramp = [](const Strands& x, float root, float tip) {
    for (size_t k = 0; k + 1 < x.strand_offsets.size(); ++k)
      if (x.saturation[x.strand_offsets[k]] != root ||
          x.saturation[x.strand_offsets[k + 1] - 1] != tip)
        return false;
    return true;
  };
  Strands m = strandsShowing([&](const Strands& x) { return ramp(x, 0.0f, 1.0f); });
  const size_t n = m.saturation.size();
  EXPECT_EQ(s.response.particles_changed, n);
  const size_t strands = m.strand_offsets.size() - 1;
  for (size_t k = 0; k < strands; ++k) {
    EXPECT_FLOAT_EQ(m.saturation[m.strand_offsets[k]], 0.0f);          // root
    EXPECT_FLOAT_EQ(m.saturation[m.strand_offsets[k + 1] - 1], 1.0f);  // tip
  }
  // a list of strands, uniform
  s = makeSat(0.5f, 0.5f);
  s.request.strands = {1, 2};
  ASSERT_TRUE(wch_test::call(sat_, &s));
  ASSERT_TRUE(s.response.success) << s.response.message;
  m = strandsShowing([](const Strands& x) { return x.saturation[x.strand_offsets[1]] == 0.5f; });
  for (uint32_t i = m.strand_offsets[1]; i < m.strand_offsets[3]; ++i)
    EXPECT_FLOAT_EQ(m.saturation[i], 0.5f);
  EXPECT_FLOAT_EQ(m.saturation[m.strand_offsets[1] - 1], 1.0f);  // strand 0's tip untouched
  // add, clamped to [0, 1]
  s = makeSat(0.8f, 0.8f, true);
  s.request.strands = {1};
  ASSERT_TRUE(wch_test::call(sat_, &s));
  ASSERT_TRUE(s.response.success) << s.response.message;
  m = strandsShowing([](const Strands& x) { return x.saturation[x.strand_offsets[1]] == 1.0f; });
  for (uint32_t i = m.strand_offsets[1]; i < m.strand_offsets[2]; ++i)
    EXPECT_FLOAT_EQ(m.saturation[i], 1.0f);
  // a sphere in the head frame holding the whole head, and a box in the world frame around it
  s = makeSat(0.25f, 0.25f);
  s.request.region_type = SetSaturation::Request::REGION_SPHERE;
  s.request.region_frame = SetSaturation::Request::FRAME_HEAD;
  s.request.region_radius = 1.0;
  ASSERT_TRUE(wch_test::call(sat_, &s));
  ASSERT_TRUE(s.response.success) << s.response.message;
  EXPECT_EQ(s.response.particles_changed, n);
  s = makeSat(0.75f, 0.75f);
  s.request.region_type = SetSaturation::Request::REGION_BOX;
  s.request.region_frame = SetSaturation::Request::FRAME_WORLD;
  s.request.region_center.z = 1.5;  // the head is at (0, 0, 1.5)
  s.request.region_half_extents.x = s.request.region_half_extents.y = 1.0;
  s.request.region_half_extents.z = 0.02;  // a thin slab through the head's centre
  ASSERT_TRUE(wch_test::call(sat_, &s));
  ASSERT_TRUE(s.response.success) << s.response.message;
  EXPECT_GT(s.response.particles_changed, 0u);
  EXPECT_LT(s.response.particles_changed, n);
}

TEST_F(NodeServices, InvalidSaturationRequestsAreRefusedAndChangeNothing) {
  ASSERT_TRUE(sat_.waitForExistence(ros::Duration(20.0)));
  SetSaturation base = makeSat(0.3f, 0.6f);
  ASSERT_TRUE(wch_test::call(sat_, &base));
  ASSERT_TRUE(base.response.success) << base.response.message;
  const std::vector<float> before =
      strandsShowing([](const Strands& x) {
        return std::abs(x.saturation.front() - 0.3f) < 1e-6f &&
               std::abs(x.saturation[x.strand_offsets[1] - 1] - 0.6f) < 1e-6f;
      }).saturation;
  std::vector<std::pair<std::string, SetSaturation>> cases;
  cases.push_back({"NaN root", makeSat(std::numeric_limits<float>::quiet_NaN(), 0.5f)});
  cases.push_back({"root above 1", makeSat(1.5f, 0.5f)});
  cases.push_back({"negative set", makeSat(-0.1f, 0.5f)});
  cases.push_back({"add below -1", makeSat(-2.0f, 0.0f, true)});
  SetSaturation unknown_strand = makeSat(0.5f, 0.5f);
  unknown_strand.request.strands = {0, 9999};
  cases.push_back({"unknown strand id", unknown_strand});
  SetSaturation empty_sphere = makeSat(0.5f, 0.5f);
  empty_sphere.request.region_type = SetSaturation::Request::REGION_SPHERE;
  empty_sphere.request.region_radius = 0.0;
  cases.push_back({"sphere of radius 0", empty_sphere});
  SetSaturation flat_box = makeSat(0.5f, 0.5f);
  flat_box.request.region_type = SetSaturation::Request::REGION_BOX;
  flat_box.request.region_half_extents.x = flat_box.request.region_half_extents.y = 1.0;
  cases.push_back({"box of zero height", flat_box});
  SetSaturation nan_centre = makeSat(0.5f, 0.5f);
  nan_centre.request.region_type = SetSaturation::Request::REGION_SPHERE;
  nan_centre.request.region_radius = 0.1;
  nan_centre.request.region_center.x = kNaN;
  cases.push_back({"NaN centre", nan_centre});
  SetSaturation bad_type = makeSat(0.5f, 0.5f);
  bad_type.request.region_type = 7;
  cases.push_back({"unknown region type", bad_type});
  SetSaturation bad_frame = makeSat(0.5f, 0.5f);
  bad_frame.request.region_type = SetSaturation::Request::REGION_SPHERE;
  bad_frame.request.region_radius = 0.1;
  bad_frame.request.region_frame = 5;
  cases.push_back({"unknown region frame", bad_frame});
  SetSaturation far_away = makeSat(0.5f, 0.5f);
  far_away.request.region_type = SetSaturation::Request::REGION_SPHERE;
  far_away.request.region_radius = 0.1;
  far_away.request.region_center.x = 50.0;
  cases.push_back({"region holding no particle", far_away});
  for (auto& c : cases) {
    ASSERT_TRUE(wch_test::call(sat_, &c.second)) << c.first;
    EXPECT_FALSE(c.second.response.success) << c.first;
    EXPECT_EQ(c.second.response.particles_changed, 0u) << c.first;
    EXPECT_FALSE(c.second.response.message.empty()) << c.first;
    std::printf("[ refused  ] %s: %s\n", c.first.c_str(), c.second.response.message.c_str());
  }
  EXPECT_EQ(nextStrands().saturation, before) << "a refused request changed the saturation";
}

TEST_F(NodeServices, ResetPutsTheHairBackAndCountsIt) {
  SetSaturation s = makeSat(1.0f, 1.0f);
  ASSERT_TRUE(wch_test::call(sat_, &s));
  const Strands a = nextStrands();
  std_srvs::Trigger t;
  ASSERT_TRUE(wch_test::call(reset_, &t));
  EXPECT_TRUE(t.response.success);
  EXPECT_FALSE(t.response.message.empty());
  const Strands b = nextStrands();
  EXPECT_GT(b.reset_count, a.reset_count);
  EXPECT_LE(b.step, 3u);
  // saturation back to the scene's initial root-to-tip ramp
  const float root = static_cast<float>(get("saturation.root"));
  const float tip = static_cast<float>(get("saturation.tip"));
  for (size_t k = 0; k + 1 < b.strand_offsets.size(); ++k) {
    EXPECT_FLOAT_EQ(b.saturation[b.strand_offsets[k]], root);
    EXPECT_FLOAT_EQ(b.saturation[b.strand_offsets[k + 1] - 1], tip);
  }
}

// ~set_water starts and stops sources and dryers (a bad spec is refused with its list index and
// field, nothing changed); ~water_changes schedules the same; the status carries the water
// totals, which balance. Last in the file: the water stage then keeps running.
TEST_F(NodeServices, WaterSourcesStartAndStopAndEveryGramIsAccounted) {
  ros::ServiceClient water =
      nh_.serviceClient<wet_curly_hair::SetWater>("/wet_curly_hair/set_water");
  Latest<wet_curly_hair::Status> status(nh_, "/wet_curly_hair/status");
  wet_curly_hair::Status st;
  ASSERT_TRUE(status.next(20.0, &st));
  EXPECT_FALSE(st.water_active);  // off until asked for
  EXPECT_EQ(st.water_added_kg, 0.0);
  wet_curly_hair::SetWater bad;
  bad.request.sources = {"shower:x=0,y=0,z=2,r=0.5,rate_kg_s=0.01", "shower:r=0"};
  ASSERT_TRUE(wch_test::call(water, &bad));
  EXPECT_FALSE(bad.response.success);
  EXPECT_NE(bad.response.message.find("sources[1]: shower.r"), std::string::npos)
      << bad.response.message;
  EXPECT_EQ(bad.response.sources_active, 0u);
  wet_curly_hair::SetWater on;  // the head is at z = 1.5: a shower over it
  on.request.sources = {"shower:x=0,y=0,z=2.5,r=0.5,rate_kg_s=0.01"};
  on.request.dryers = {"box:x=0,y=0,z=1.5,hx=0.5,hy=0.5,hz=0.5,rate_per_s=0.1"};
  ASSERT_TRUE(wch_test::call(water, &on));
  ASSERT_TRUE(on.response.success) << on.response.message;
  EXPECT_EQ(on.response.sources_active, 1u);
  EXPECT_EQ(on.response.dryers_active, 1u);
  ASSERT_TRUE(status.waitFor(
      20.0, [](const wet_curly_hair::Status& m) { return m.water_evaporated_kg > 0.0; }, &st));
  EXPECT_TRUE(st.water_active);
  EXPECT_GT(st.water_added_kg, 0.0);
  EXPECT_GT(st.mean_saturation, 0.0);
  EXPECT_NEAR(st.water_added_kg - st.water_removed_kg,
              st.water_held_kg + st.water_dripped_kg + st.water_evaporated_kg,
              1e-12 * st.water_added_kg);
  wet_curly_hair::SetWater off;
  off.request.clear = true;
  ASSERT_TRUE(wch_test::call(water, &off));
  EXPECT_TRUE(off.response.success);
  EXPECT_EQ(off.response.sources_active, 0u);
  ros::Publisher changes =
      nh_.advertise<wet_curly_hair::WaterChange>("/wet_curly_hair/water_changes", 10, true);
  wet_curly_hair::WaterChange change;  // stamp 0: before the next frame
  change.dryers = {"box:x=0,y=0,z=1.5,hx=0.5,hy=0.5,hz=0.5"};
  changes.publish(change);
  EXPECT_TRUE(status.waitFor(20.0, [](const wet_curly_hair::Status& m) {
    return m.water_dryers == 1 && m.water_sources == 0;
  }));
}

/// Runs the node binary with extra arguments against the test's master; returns exit code and
/// output.
int runNode(const std::string& args, std::string* output) {
  const std::string cmd = std::string(WCH_NODE_BINARY) + " __name:=refused_node " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return -1;
  char buf[4096];
  while (fgets(buf, sizeof(buf), p)) *output += buf;
  const int status = pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(NodeStartup, InvalidParametersAreRefusedByName) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"_solver/stretch/axial_stiffness_n:=-5", "solver.stretch.axial_stiffness_n"},
      {"_solver/stretch/stiffness_n_per_m:=500", "solver.stretch.axial_stiffness_n"},
      {"_solver/bend/stifness_n_per_m:=3", "~solver/bend/stifness_n_per_m"},
      {"_groom/strands:=many", "~groom/strands"},
      {"_publish_rate:=0", "~publish_rate"},
      {"_head_frame:=world", "~head_frame"},
      {"_scene:=/nonexistent/scene.yaml", "~scene"},
      {"_obstacle_map/file:=/nonexistent/map.bt", "obstacle_map.file"},
  };
  for (const auto& c : cases) {
    ros::param::del("/refused_node");
    std::string out;
    const int code = runNode(c.first, &out);
    EXPECT_EQ(code, 1) << c.first << "\n" << out;
    EXPECT_NE(out.find(c.second), std::string::npos)
        << c.first << ": output does not name " << c.second << ":\n"
        << out;
    const size_t at = out.find("not starting");
    std::printf("[ refused  ] %s -> %s", c.first.c_str(),
                at == std::string::npos ? out.c_str() : out.substr(at).c_str());
  }
  ros::param::del("/refused_node");
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_services");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
