// tether mcl-demo: the tables' rows for a tiny configuration, the file they are written to, and
// usage errors.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "testing/cli.h"
#include "testing/lidar_files.h"

namespace tether {
namespace {

using testing::CliRun;
using testing::Tether;

class MclDemoTest : public testing::LidarFilesTest {};

TEST_F(MclDemoTest, PrintsAndWritesTheTables) {
  const CliRun r = Tether(
      "mcl-demo --seeds 1 --particles 200,300 --methods mcl,amcl,acmcl --kidnap-step 20 "
      "--max-steps 30 --threads 2 -o " +
      P("t.md"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("kidnapped robot: 1 seeds from 1, kidnap before step 20"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| world, method | 200 | 300 |"), std::string::npos) << r.output;
  for (const char* row : {"| maze, MCL | - (1/1 not converged) | - (1/1 not converged) |", "| maze, Augmented MCL |",
                          "| maze, ACMCL |", "| office, MCL |", "| office, ACMCL |"}) {
    EXPECT_NE(r.output.find(row), std::string::npos) << row << "\n" << r.output;
  }
  // The thesis's rows need its particle counts.
  EXPECT_EQ(r.output.find("thesis (Table 5.1)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| method | maze: position | maze: pose | maze: re-drawn | office: position"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("| ACMCL |"), std::string::npos);
  EXPECT_NE(r.output.find("wrote " + P("t.md")), std::string::npos);
  std::ifstream in(P("t.md"));
  std::stringstream s;
  s << in.rdbuf();
  EXPECT_NE(s.str().find("| maze, MCL | - (1/1 not converged)"), std::string::npos) << s.str();
}

TEST_F(MclDemoTest, TheThesisRowsBesideItsCounts) {
  const CliRun r = Tether("mcl-demo -q --seeds 1 --worlds maze --particles 500 --max-steps 10 --threads 2");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("| thesis (Table 5.1), maze, Augmented MCL | 379 |"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| thesis (Table 5.1), maze, ACMCL | 50 |"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| 0.80% | 0.81% |"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| 4.70% | 8.50% |"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("office"), std::string::npos);
}

TEST_F(MclDemoTest, UsageErrors) {
  CliRun r = Tether("mcl-demo --worlds moon");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("--worlds: 'moon' is not one of"), std::string::npos) << r.output;
  r = Tether("mcl-demo --methods amcl,pf");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("'pf'"), std::string::npos) << r.output;
  r = Tether("mcl-demo --seeds 0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("seeds"), std::string::npos) << r.output;
  r = Tether("mcl-demo --particles 500,500");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("repeats"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace tether
