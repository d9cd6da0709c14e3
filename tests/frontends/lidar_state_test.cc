// The saved LiDAR state (lidar_state.h): a run's state written and read back identically, and
// every damaged file (another version, a cut, a flipped byte, a stated size that lies) refused
// with a ParseError naming the file, never a crash.
#include "tether/frontends/lidar/io/lidar_state.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "fuzz/read_lidar_state_fuzz.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"
#include "tether/frontends/simulation/lidar_world.h"

namespace tether {
namespace lidar {
namespace {

// A short simulated run, mapped once for every test.
const LidarState& RunState() {
  static const LidarState state = [] {
    LidarSimOptions o;
    o.scans = 300;
    o.seed = 7;
    const SimulatedLidar sim = SimulateLidar(o);
    LidarSlamOptions options;
    options.pose_graph.threads = 0;
    LidarSlam2D slam(options);
    slam.Run(sim.log);
    return slam.State();
  }();
  return state;
}

void ExpectSameGrid(const ProbabilityGrid& a, const ProbabilityGrid& b) {
  EXPECT_EQ(a.resolution(), b.resolution());
  EXPECT_EQ(a.origin(), b.origin());
  EXPECT_EQ(a.min_probability(), b.min_probability());
  EXPECT_EQ(a.max_probability(), b.max_probability());
  EXPECT_TRUE((a.min_cell() == b.min_cell()).all());
  EXPECT_TRUE((a.size() == b.size()).all());
  EXPECT_EQ(a.values(), b.values());
}

void ExpectSamePose(const SE2d& a, const SE2d& b) {
  EXPECT_EQ(a.x(), b.x());
  EXPECT_EQ(a.y(), b.y());
  EXPECT_EQ(a.theta(), b.theta());
}

TEST(LidarStateTest, ARunsStateReadsBackIdentically) {
  const LidarState& s = RunState();
  ASSERT_EQ(s.Problem(), "");
  ASSERT_EQ(s.scans.size(), 300u);
  ASSERT_GT(s.submaps.size(), 2u);
  ASSERT_NE(s.map, nullptr);
  const std::string bytes = LidarStateBytes(s);
  const LidarState r = ParseLidarState(bytes, "run.tether");
  EXPECT_EQ(r.trajectories, s.trajectories);
  ASSERT_EQ(r.scans.size(), s.scans.size());
  for (std::size_t i = 0; i < s.scans.size(); ++i) {
    const SavedScan &a = s.scans[i], &b = r.scans[i];
    EXPECT_EQ(a.stamp, b.stamp);
    EXPECT_EQ(a.trajectory, b.trajectory);
    ExpectSamePose(a.pose, b.pose);
    ExpectSamePose(a.local_pose, b.local_pose);
    ExpectSamePose(a.laser_in_robot, b.laser_in_robot);
    EXPECT_EQ(a.submaps, b.submaps);
    ASSERT_EQ(a.points.size(), b.points.size());
    for (std::size_t k = 0; k < a.points.size(); ++k) {
      // Points are stored as floats: within a float's rounding of the scan's.
      EXPECT_EQ(static_cast<float>(a.points[k].x()), b.points[k].x());
      EXPECT_EQ(static_cast<float>(a.points[k].y()), b.points[k].y());
    }
  }
  ASSERT_EQ(r.submaps.size(), s.submaps.size());
  for (std::size_t j = 0; j < s.submaps.size(); ++j) {
    EXPECT_EQ(r.submaps[j].trajectory, s.submaps[j].trajectory);
    EXPECT_EQ(r.submaps[j].num_scans, s.submaps[j].num_scans);
    ExpectSamePose(r.submaps[j].pose, s.submaps[j].pose);
    ExpectSamePose(r.submaps[j].local_pose, s.submaps[j].local_pose);
    ExpectSameGrid(*r.submaps[j].grid, *s.submaps[j].grid);
  }
  ASSERT_EQ(r.closures.size(), s.closures.size());
  for (std::size_t c = 0; c < s.closures.size(); ++c) {
    EXPECT_EQ(r.closures[c].scan, s.closures[c].scan);
    EXPECT_EQ(r.closures[c].submap, s.closures[c].submap);
    ExpectSamePose(r.closures[c].relative, s.closures[c].relative);
    EXPECT_EQ(r.closures[c].score, s.closures[c].score);
  }
  ExpectSameGrid(*r.map, *s.map);
  // Written again, the same bytes.
  EXPECT_EQ(LidarStateBytes(r), bytes);
}

std::string ParseFailure(const std::string& bytes) {
  try {
    ParseLidarState(bytes, "damaged.tether");
  } catch (const ParseError& e) {
    return e.what();
  }
  return "";
}

template <class T>
void Poke(std::string* bytes, std::size_t at, T v) {
  std::memcpy(&(*bytes)[at], &v, sizeof(T));
}

TEST(LidarStateTest, AnotherVersionOrNoStateIsRefusedByName) {
  std::string bytes = LidarStateBytes(RunState());
  std::string other = bytes;
  Poke<std::uint32_t>(&other, 19, 2);
  const std::string why = ParseFailure(other);
  EXPECT_NE(why.find("damaged.tether"), std::string::npos) << why;
  EXPECT_NE(why.find("version 2"), std::string::npos) << why;
  EXPECT_NE(why.find("reads version 1"), std::string::npos) << why;
  EXPECT_NE(ParseFailure("P5\n10 10\n255\n").find("not a tether LiDAR state"), std::string::npos);
  EXPECT_NE(ParseFailure("").find("not a tether LiDAR state"), std::string::npos);
  // A payload stated far beyond what the stream could unpack to: refused before any allocation.
  std::string huge = bytes;
  Poke<std::uint64_t>(&huge, 23, std::uint64_t{1} << 60);
  EXPECT_NE(ParseFailure(huge).find("more than"), std::string::npos) << ParseFailure(huge);
  std::string grown = bytes + "x";
  EXPECT_NE(ParseFailure(grown).find("cut short or grown"), std::string::npos) << ParseFailure(grown);
}

TEST(LidarStateTest, EveryCutAndFlippedByteIsRefusedNeverACrash) {
  const std::string bytes = LidarStateBytes(RunState());
  std::mt19937 rng(11);
  std::uniform_int_distribution<std::size_t> at(0, bytes.size() - 1);
  int refused = 0;
  for (int k = 0; k < 300; ++k) {
    std::string damaged = bytes;
    if (k % 3 == 0) {
      damaged.resize(at(rng));  // cut short
    } else {
      damaged[at(rng)] ^= static_cast<char>(1 + rng() % 255);  // a byte changed
    }
    const std::string why = ParseFailure(damaged);
    if (!why.empty()) {
      EXPECT_NE(why.find("damaged.tether"), std::string::npos) << why;
      ++refused;
      continue;
    }
    // Not refused: the change fell on bits the stream ignores (a block's padding), and the
    // state is the same.
    EXPECT_EQ(LidarStateBytes(ParseLidarState(damaged, "damaged.tether")), bytes) << "damage " << k;
  }
  EXPECT_GT(refused, 290);
}

// A small state made by hand: two scans, one submap, a loop closure, a map of a few cells.
LidarState TinyState() {
  LidarState s;
  auto grid = [](double x0) {
    auto g = std::make_shared<ProbabilityGrid>(0.05, Eigen::Vector2d(x0, 0));
    g->SetProbability(ProbabilityGrid::Cell(0, 0), 0.9);
    g->SetProbability(ProbabilityGrid::Cell(2, 1), 0.2);
    g->ShrinkToKnown();
    return g;
  };
  for (int i = 0; i < 2; ++i) {
    SavedScan scan;
    scan.stamp = 10 + i;
    scan.pose = SE2d(0.1 * i, 0, 0.01 * i);
    scan.local_pose = scan.pose;
    scan.submaps = {0};
    scan.points = {Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1.5)};
    s.scans.push_back(scan);
  }
  s.submaps.push_back(SavedSubmap{0, SE2d(), SE2d(), 2, grid(0)});
  s.closures.push_back(SavedClosure{1, 0, SE2d(0.1, 0, 0.01), 0.7});
  s.map = grid(-1);
  return s;
}

// Random changes to a payload, packed with a correct CRC: the reader's checks of the contents
// (counts, indices, grids, numbers) refuse each, or what reads is whole and writes back alike.
TEST(LidarStateTest, DamagedContentsBehindACorrectCrcAreRefusedNeverACrash) {
  const std::string payload = fuzz::UnpackLidarStatePayload(LidarStateBytes(TinyState()));
  ASSERT_EQ(LidarStateBytes(ParseLidarState(fuzz::PackLidarStatePayload(payload), "tiny")),
            LidarStateBytes(TinyState()));
  std::mt19937 rng(5);
  int refused = 0;
  for (int k = 0; k < 3000; ++k) {
    std::string damaged = "\x01" + payload;
    const int changes = 1 + static_cast<int>(rng() % 4);
    for (int c = 0; c < changes; ++c) {
      const std::size_t at = 1 + rng() % payload.size();
      if (rng() % 5 == 0) {
        damaged.resize(at);
      } else {
        damaged[at] = static_cast<char>(rng() % 256);
      }
    }
    fuzz::ReadLidarStateOnce(reinterpret_cast<const std::uint8_t*>(damaged.data()), damaged.size());
    try {
      ParseLidarState(fuzz::PackLidarStatePayload(damaged.substr(1)), "damaged");
    } catch (const ParseError&) {
      ++refused;
    }
  }
  EXPECT_GT(refused, 1000);  // most changes land on a checked field
}

// The fuzz target's kept inputs (tests/fuzz/regressions/lidar_state; its seeds and findings).
TEST(LidarStateTest, EveryKeptFuzzInputReadsOrIsRefusedCleanly) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(TETHER_SOURCE_DIR) / "tests/fuzz/regressions/lidar_state";
  int replayed = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().extension() == ".md") continue;
    std::ifstream in(e.path(), std::ios::binary);
    std::stringstream bytes;
    bytes << in.rdbuf();
    SCOPED_TRACE(e.path().filename().string());
    fuzz::ReadLidarStateOnce(reinterpret_cast<const std::uint8_t*>(bytes.str().data()), bytes.str().size());
    ++replayed;
  }
  EXPECT_GE(replayed, 2) << "no kept inputs in " << dir;
}

TEST(LidarStateTest, AStateWithAnIndexOutOfRangeIsNotWritten) {
  LidarState s = RunState();
  s.scans[3].submaps.push_back(static_cast<int>(s.submaps.size()));
  EXPECT_NE(s.Problem().find("scan 3"), std::string::npos) << s.Problem();
  EXPECT_THROW(LidarStateBytes(s), InvalidArgument);
}

TEST(LidarStateTest, AMissingFileIsAnIoError) { EXPECT_THROW(ReadLidarState("/nonexistent/state.tether"), IoError); }

}  // namespace
}  // namespace lidar
}  // namespace tether
