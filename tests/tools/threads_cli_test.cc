// tether optimize --threads: validated (exit 2 with a message), and the written graph is the
// same byte for byte with one thread or several.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "testing/cli.h"

namespace {

using tether::testing::CliRun;
using tether::testing::Tether;

namespace fs = std::filesystem;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class ThreadsCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tether_threads_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

TEST_F(ThreadsCliTest, BadThreadCountsAreUsageErrors) {
  ASSERT_EQ(Tether("simulate manhattan --poses 50 --seed 2 -o " + P("m.g2o")).code, 0);
  for (const char* bad : {"0", "-3", "257"}) {
    const CliRun r = Tether("optimize " + P("m.g2o") + " -o " + P("out.g2o") + " --threads " + bad);
    EXPECT_EQ(r.code, 2) << bad << ": " << r.output;
    EXPECT_NE(r.output.find("' is outside its range [1, 256]"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(P("out.g2o")));
  }
  const CliRun word = Tether("optimize " + P("m.g2o") + " --threads two");
  EXPECT_EQ(word.code, 2) << word.output;
}

TEST_F(ThreadsCliTest, TwoThreadsWriteTheSameFileAsOne) {
  ASSERT_EQ(Tether("simulate sphere --poses 300 --seed 4 -o " + P("s.g2o")).code, 0);
  const CliRun one = Tether("optimize " + P("s.g2o") + " -q -o " + P("one.g2o") + " --threads 1");
  ASSERT_EQ(one.code, 0) << one.output;
  const CliRun two = Tether("optimize " + P("s.g2o") + " -q -o " + P("two.g2o") + " --threads 2");
  ASSERT_EQ(two.code, 0) << two.output;
  const std::string a = Slurp(P("one.g2o")), b = Slurp(P("two.g2o"));
  EXPECT_GT(a.size(), 1000u);
  EXPECT_EQ(a, b);
}

}  // namespace
