#pragma once
// Shared test helpers for the LiDAR front-end's readers: a per-test temporary folder, text and
// gzip files written into it and read back, the message of the error a call throws, and the datasets' paths.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace tether {
namespace testing {

/// A fixture with a fresh temporary folder per test (removed afterwards).
class LidarFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("tether_lidar_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->test_suite_name() + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }

  /// Writes `text` to the folder's file `name` and returns its path.
  std::string Write(const std::string& name, const std::string& text) const {
    std::ofstream(P(name), std::ios::binary) << text;
    return P(name);
  }
  /// The bytes of the folder's file `name` ("" where it cannot be read).
  std::string Read(const std::string& name) const {
    std::ifstream in(P(name), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return bytes;
  }
  /// Writes `text` gzip-compressed.
  std::string WriteGz(const std::string& name, const std::string& text) const {
    gzFile f = gzopen(P(name).c_str(), "wb");
    EXPECT_NE(f, nullptr);
    EXPECT_EQ(gzwrite(f, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
    gzclose(f);
    return P(name);
  }
  std::filesystem::path dir_;
};

/// The message of the exception of type E that `f` throws, or "(no error)"; another exception
/// type fails the test.
template <class E, class F>
std::string ErrorOf(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  return "(no error)";
}

/// Why the bag tests skip in a build without bag support.
constexpr const char* kNoBagSupport =
    "built without ROS 1 bag support (TETHER_WITH_ROSBAG=OFF; it is on where librosbag-storage-dev, "
    "libsensor-msgs-dev and libnav-msgs-dev are found: scripts/install_deps.sh installs them)";

/// ../shared/datasets/lidar/<name>; "" (after GTEST_SKIP by the caller) where absent.
inline std::string LidarDataset(const std::string& name) {
  const std::string p = std::string(TETHER_DATASETS_DIR) + "/lidar/" + name;
  return std::ifstream(p).good() ? p : "";
}

}  // namespace testing
}  // namespace tether
