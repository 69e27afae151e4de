// The solver's defaults are what the last benchmark run chose (docs/bench/defaults.txt, written by
// bench/bench_summary.py from the speed-against-error chart): names and values, not timings.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>

#include "wet_curly_hair/core/config.h"

namespace wet_curly_hair {
namespace {

/// "key value" lines of the bench's choice; '#' lines are comments.
std::map<std::string, std::string> benchChoice() {
  std::ifstream in(std::string(WCH_SOURCE_DIR) + "/docs/bench/defaults.txt");
  EXPECT_TRUE(in.good()) << "docs/bench/defaults.txt: run scripts/bench";
  std::map<std::string, std::string> choice;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string key, value;
    fields >> key >> value;
    choice[key] = value;
  }
  return choice;
}

}  // namespace

TEST(Config, IntegratorDefaultsAreTheBenchmarksChoice) {
  const std::map<std::string, std::string> choice = benchChoice();
  ASSERT_EQ(choice.count("solver.integrator.method"), 1u);
  ASSERT_EQ(choice.count("solver.integrator.substep_s"), 1u);
  const IntegratorConfig defaults;
  EXPECT_EQ(defaults.method, choice.at("solver.integrator.method"));
  EXPECT_DOUBLE_EQ(defaults.substep_s, std::stod(choice.at("solver.integrator.substep_s")));
}

TEST(Config, CohesionEvaluationDefaultIsTheBenchmarksChoice) {
  const std::map<std::string, std::string> choice = benchChoice();
  ASSERT_EQ(choice.count("solver.cohesion.evaluation"), 1u);
  EXPECT_EQ(CohesionConfig().evaluation, choice.at("solver.cohesion.evaluation"));
  // The lattice density, when the bench chose the lattice (a file from before the density was a
  // candidate has none: the lattice then ran at 4 nodes per radius only).
  if (choice.at("solver.cohesion.evaluation") == "grid") {
    const int cells = choice.count("solver.cohesion.grid_cells_per_radius")
                          ? std::stoi(choice.at("solver.cohesion.grid_cells_per_radius"))
                          : 4;
    EXPECT_EQ(CohesionConfig().grid_cells_per_radius, cells);
    // Where the lattice's sums run (a file from before the node sums were a candidate: the
    // particles).
    const std::string wet_sums = choice.count("solver.cohesion.grid_wet_sums")
                                     ? choice.at("solver.cohesion.grid_wet_sums")
                                     : "particles";
    EXPECT_EQ(CohesionConfig().grid_wet_sums, wet_sums);
  }
}

TEST(Config, ThreadsDefaultToEveryHardwareThread) {
  IntegratorConfig c;
  EXPECT_EQ(c.threads, 0);
  const int machine = static_cast<int>(std::thread::hardware_concurrency());
  EXPECT_EQ(c.resolvedThreads(), std::max(1, std::min(machine, kMaxSolverThreads)));
  c.threads = 3;
  EXPECT_EQ(c.resolvedThreads(), 3);
  std::string why;
  EXPECT_TRUE(c.validate("solver.integrator.", &why)) << why;
  for (int bad : {-1, kMaxSolverThreads + 1}) {
    c.threads = bad;
    EXPECT_FALSE(c.validate("solver.integrator.", &why));
    EXPECT_NE(why.find("solver.integrator.threads"), std::string::npos) << why;
  }
}

}  // namespace wet_curly_hair
