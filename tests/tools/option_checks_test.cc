// Every numeric option of every command, fed values no option should take as they are (NaN,
// +-inf) and values at the edges (0, -1, 1e300, 1e-300): refused with exit 2 naming the option,
// or taken and the command going on (here to a missing input: exit 1); never a crash, a hang
// or a silent exit 0 on a non-number.
#include "tether/tools/option_checks.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace tether {
namespace {

namespace fs = std::filesystem;

struct Result {
  int code = -1;  // exit code; -1 where killed by a signal
  std::string err;
};

class OptionChecksTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/tether_options_XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { fs::remove_all(dir_); }

  Result Run(const std::string& args) const {
    const std::string err = dir_ + "/stderr";
    const std::string cmd =
        "cd '" + dir_ + "' && timeout 60 '" + std::string(TETHER_CLI) + "' " + args + " > /dev/null 2> '" + err + "'";
    const int status = std::system(cmd.c_str());
    Result r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream in(err);
    std::stringstream s;
    s << in.rdbuf();
    r.err = s.str();
    return r;
  }

  // The numeric options --help lists for `command`: "--flag" of every "--flag FLOAT/INT/UINT".
  std::vector<std::string> NumericOptions(const std::string& command) const {
    const std::string help = dir_ + "/help";
    const std::string cmd = "'" + std::string(TETHER_CLI) + "' " + command + " --help > '" + help + "'";
    EXPECT_EQ(std::system(cmd.c_str()), 0);
    std::ifstream in(help);
    std::string line;
    std::vector<std::string> flags;
    const std::regex option(R"(^\s+(?:-\w,)?(--[a-z0-9-]+) (FLOAT|INT|UINT)\b)");
    while (std::getline(in, line)) {
      std::smatch m;
      if (std::regex_search(line, m, option)) flags.push_back(m[1]);
    }
    return flags;
  }

  std::string dir_;
};

// Arguments that make each command valid apart from the option under test, and end fast
// (a missing input) where the option is taken.
const struct {
  const char* command;
  const char* base;
  bool runs_without_input;
} kCommands[] = {
    {"optimize", "missing.g2o", false},
    {"simulate", "manhattan -o sim.g2o --poses 20", true},
    {"bench", "missing.g2o", false},
    {"replay", "missing.g2o", false},
    {"ekf-demo", "--seeds 1 --steps 3 --no-graph -q", true},
    {"lidar", "missing.clf -o out", false},
    {"lidar-eval", "missing.tum missing.relations", false},
    {"lidar-degrade", "missing.clf -o out.clf", false},
    {"localize", "missing.clf --state missing.tether -o out", false},
};

TEST_F(OptionChecksTest, EveryNumericOptionRefusesNonNumbersAndOutOfRangeValuesByName) {
  int options = 0, refused = 0, taken = 0;
  for (const auto& c : kCommands) {
    const std::vector<std::string> flags = NumericOptions(c.command);
    EXPECT_FALSE(flags.empty()) << c.command;
    for (const std::string& flag : flags) {
      ++options;
      const int width = flag == "--laser-offset" || flag == "--initial-pose" ? 3 : 1;  // x,y,theta
      for (const char* value : {"nan", "inf", "-inf", "1e300", "-1e300", "-1", "0", "1e-300"}) {
        std::string v = value;
        for (int k = 1; k < width; ++k) v += std::string(",") + value;
        const Result r = Run(std::string(c.command) + " " + c.base + " " + flag + " " + v);
        SCOPED_TRACE(std::string(c.command) + " " + flag + " " + v + ": exit " + std::to_string(r.code) + ", " + r.err);
        ASSERT_GE(r.code, 0) << "killed by a signal (or timed out)";
        ASSERT_NE(r.code, 124) << "timed out";
        const std::string text = value;
        if (text == "nan" || text == "inf" || text == "-inf" || text == "1e300" || text == "-1e300") {
          // Not a usable number for any option of tether's.
          EXPECT_EQ(r.code, 2);
        }
        if (r.code == 2) {
          ++refused;
          EXPECT_NE(r.err.find(flag), std::string::npos) << "the message does not name the option";
        } else {
          ++taken;
          // Commands with an input stop at the missing one; ekf-demo and simulate read none.
          if (!c.runs_without_input) {
            EXPECT_NE(r.code, 0) << "a missing input was not reported";
          }
        }
      }
    }
  }
  // Every option of the range table exists (a renamed flag would leave its range behind).
  for (const OptionRange& r : OptionRanges()) {
    const std::vector<std::string> flags = NumericOptions(r.command);
    EXPECT_NE(std::find(flags.begin(), flags.end(), r.flag), flags.end()) << r.command << " " << r.flag;
  }
  EXPECT_GT(options, 60);
  std::printf("[ options ] %d numeric options x 8 values: %d refused by name, %d taken\n", options, refused, taken);
}

TEST_F(OptionChecksTest, TheRangesAreShownInTheHelp) {
  const std::string help = dir_ + "/help";
  ASSERT_EQ(std::system(("'" + std::string(TETHER_CLI) + "' lidar --help > '" + help + "'").c_str()), 0);
  std::ifstream in(help);
  std::stringstream s;
  s << in.rdbuf();
  EXPECT_NE(s.str().find("--threads INT:in [0, 256]"), std::string::npos) << s.str().substr(0, 2000);
  const Result r = Run("lidar missing.clf -o out --threads 100000");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--threads: '100000' is outside its range [0, 256]"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ + "/out"));  // nothing made
}

}  // namespace
}  // namespace tether
