// tether lidar --save-state and tether localize: a simulated office mapped over its first 800
// scans, the rest localised in the saved state from an unknown start and mapped as a second
// session of it (--continue); a damaged or missing state refused by name with nothing written.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "testing/cli.h"
#include "testing/lidar_files.h"
#include "tether/frontends/lidar/io/lidar_state.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"

namespace tether {
namespace {

using testing::CliRun;
using testing::Tether;

class LocalizeCliTest : public testing::LidarFilesTest {
 protected:
  void MapFirstPart(int scans, int mapped) {
    CliRun r = Tether("simulate lidar --scans " + std::to_string(scans) + " --seed 4 -q -o " + P("o.log") +
                      " --truth " + P("o.tum"));
    ASSERT_EQ(r.code, 0) << r.output;
    r = Tether("lidar " + P("o.log") + " -o " + P("map") + " -q --save-state --max-scans " + std::to_string(mapped) +
               " --threads 0");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("state.tether}"), std::string::npos) << r.output;
  }
};

TEST_F(LocalizeCliTest, TheRestOfTheRunIsLocalisedInTheSavedMap) {
  MapFirstPart(1200, 800);
  const lidar::LidarState state = lidar::ReadLidarState(P("map/state.tether"));
  EXPECT_EQ(state.scans.size(), 800u);
  const CliRun r = Tether("localize " + P("o.log") + " --state " + P("map/state.tether") + " -o " + P("loc") +
                          " --start-scan 800 --reference " + P("map/trajectory.tum"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("400 scans to localise from scan 801, global start"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("first fix at scan"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("wrote " + P("loc") + "/{poses.tum, localization.csv, localization.png}"), std::string::npos)
      << r.output;
  EXPECT_EQ(Read("loc/localization.png").rfind("\x89PNG", 0), 0u);
  const std::string csv = Read("loc/localization.csv");
  EXPECT_EQ(csv.rfind("scan,stamp,localized,x,y,theta,tracked,outside,score,fix,global", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 401);
  // The localised poses against the truth, in the map's frame (the truth moved so that the
  // mapping run's first pose lies on it).
  const std::vector<lidar::StampedPose2> poses = lidar::ReadTumFile(P("loc/poses.tum"));
  const std::vector<lidar::StampedPose2> truth = lidar::ReadTumFile(P("o.tum"));
  const std::vector<lidar::StampedPose2> mapped = lidar::ReadTumFile(P("map/trajectory.tum"));
  ASSERT_GT(poses.size(), 300u);
  const SE2d world_from_map = truth.front().pose * mapped.front().pose.Inverse();
  double sum = 0;
  for (const lidar::StampedPose2& p : poses) {
    const auto k = static_cast<std::size_t>(std::lround((p.stamp - truth.front().stamp) * 10));
    ASSERT_LT(k, truth.size());
    sum += ((world_from_map * p.pose).translation() - truth[k].pose.translation()).norm();
  }
  EXPECT_LT(sum / static_cast<double>(poses.size()), 0.05);
  // The same rest mapped as a second session of the saved map, and saved merged.
  ASSERT_EQ(Tether("lidar-degrade " + P("o.log") + " -o " + P("rest.log") + " --first-scan 800 -q").code, 0);
  const CliRun c = Tether("lidar " + P("rest.log") + " --continue " + P("map/state.tether") + " -o " + P("both") +
                          " --save-state --threads 0 --ground-truth " + P("o.tum"));
  ASSERT_EQ(c.code, 0) << c.output;
  EXPECT_NE(c.output.find("going on from " + P("map/state.tether") + ": 800 scans"), std::string::npos) << c.output;
  EXPECT_NE(c.output.find("a new session (the log after the saved state) at scan 801"), std::string::npos) << c.output;
  EXPECT_NE(c.output.find("joined the map at scan"), std::string::npos) << c.output;
  EXPECT_EQ(lidar::ReadLidarState(P("both/state.tether")).scans.size(), 1200u);
  EXPECT_EQ(lidar::ReadTumFile(P("both/trajectory.tum")).size(), 1200u);
}

TEST_F(LocalizeCliTest, ADamagedOrMissingStateIsRefusedByName) {
  MapFirstPart(200, 200);
  std::string bytes = Read("map/state.tether");
  bytes[bytes.size() / 2] ^= 0x5a;
  Write("bad.tether", bytes);
  CliRun r = Tether("localize " + P("o.log") + " --state " + P("bad.tether") + " -o " + P("out"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find(P("bad.tether") + ": "), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(P("out")));
  Write("old.tether", "tether lidar state\n\x02");
  r = Tether("localize " + P("o.log") + " --state " + P("old.tether") + " -o " + P("out"));
  EXPECT_EQ(r.code, 1) << r.output;
  r = Tether("localize " + P("o.log") + " --state " + P("none.tether") + " -o " + P("out"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("cannot open the state file"), std::string::npos) << r.output;
  r = Tether("lidar " + P("o.log") + " --continue " + P("bad.tether") + " -o " + P("out"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find(P("bad.tether") + ": "), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(P("out")));
  // A state is not a log, and a log is not a state.
  r = Tether("localize " + P("o.log") + " --state " + P("o.log") + " -o " + P("out"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("not a tether LiDAR state"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace tether
