// tether optimize --threads: validated (exit 2 with a message), and the written graph is the
// same byte for byte with one thread or several.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace {

namespace fs = std::filesystem;

struct Output {
  int code;
  std::string text;  // stdout and stderr together
};

Output RunTether(const std::string& args) {
  const std::string cmd = std::string(TETHER_CLI) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) out.append(buf, n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

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
  ASSERT_EQ(RunTether("simulate manhattan --poses 50 --seed 2 -o " + P("m.g2o")).code, 0);
  for (const char* bad : {"0", "-3", "257"}) {
    const Output r = RunTether("optimize " + P("m.g2o") + " -o " + P("out.g2o") + " --threads " + bad);
    EXPECT_EQ(r.code, 2) << bad << ": " << r.text;
    EXPECT_NE(r.text.find("--threads must be between 1 and 256"), std::string::npos) << r.text;
    EXPECT_FALSE(fs::exists(P("out.g2o")));
  }
  const Output word = RunTether("optimize " + P("m.g2o") + " --threads two");
  EXPECT_EQ(word.code, 2) << word.text;
}

TEST_F(ThreadsCliTest, TwoThreadsWriteTheSameFileAsOne) {
  ASSERT_EQ(RunTether("simulate sphere --poses 300 --seed 4 -o " + P("s.g2o")).code, 0);
  const Output one = RunTether("optimize " + P("s.g2o") + " -q -o " + P("one.g2o") + " --threads 1");
  ASSERT_EQ(one.code, 0) << one.text;
  const Output two = RunTether("optimize " + P("s.g2o") + " -q -o " + P("two.g2o") + " --threads 2");
  ASSERT_EQ(two.code, 0) << two.text;
  const std::string a = Slurp(P("one.g2o")), b = Slurp(P("two.g2o"));
  EXPECT_GT(a.size(), 1000u);
  EXPECT_EQ(a, b);
}

}  // namespace
