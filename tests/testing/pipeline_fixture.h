#pragma once
// Shared test fixture of the pipeline tests (tests/frontends/pipeline_simulated_test.cc,
// tests/tools/pipeline_cli_test.cc): a folder of the test's own, simulated graphs written as
// g2o files into it, and a file's bytes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "testing/simulated.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"

namespace tether {
namespace testing {

inline std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class PipelineFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("tether_pipeline_" + std::to_string(::getpid()) + "_" +
                                                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }

  /// A simulated world (seed 7) written as `name` in the test's folder; its path.
  std::string Simulated(const std::string& name, SimWorld world, int poses) {
    const SimulatedGraph sim = SimulateWorld(world, poses, 7);
    WriteG2oFile(P(name), sim.initial, sim.graph, DefaultRegistry());
    return P(name);
  }

  std::filesystem::path dir_;
};

}  // namespace testing
}  // namespace tether
