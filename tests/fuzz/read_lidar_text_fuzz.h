#pragma once
// The body of the fuzz target for the LiDAR text readers (read_lidar_text_fuzzer.cc): TUM
// trajectories and relation files, the bag record check (CheckBagRecords, tether's own
// parser of a bag's record lengths) and the map image reader (ParsePgm). The first byte picks
// the reader (0: TUM, 1: relations, 2: bag records, 3: PGM); the rest is the file.
//   TUM: a trajectory that reads must write (WriteTum) and read back to the same stamps and
//        poses (to rounding).
//   relations: a file that reads must score against a trajectory of its own stamps.
//   bag: the check either passes or throws ParseError; nothing else.
//   PGM: an image that reads (up to a million pixels) becomes a localisation map: its distance
//        transform and likelihood field must be finite or infinite, never NaN, and a cell's
//        distance 0 exactly where it is occupied.
// Anything but a tether::Error escaping, or a round trip that differs, is a finding (abort).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "scratch_path.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/eval/relations_metric.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/lidar/io/rosbag_reader.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/localization/measurement_model.h"
#include "tether/frontends/localization/occupancy_map_2d.h"

namespace tether {
namespace fuzz {

inline const std::string& BagScratchPath() {
  static const std::string path = ScratchPath("bag", "bag");
  return path;
}

inline int ReadLidarTextOnce(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const int reader = data[0] % 4;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    if (reader == 0) {
      std::istringstream in(text);
      const std::vector<lidar::StampedPose2> poses = lidar::ReadTum(in, "fuzz.tum");
      std::ostringstream out;
      lidar::WriteTum(out, poses);
      std::istringstream back_in(out.str());
      const std::vector<lidar::StampedPose2> back = lidar::ReadTum(back_in, "back.tum");
      if (back.size() != poses.size()) std::abort();
      for (std::size_t i = 0; i < poses.size(); ++i) {
        const double scale = 1 + std::abs(poses[i].stamp);
        if (std::abs(back[i].stamp - poses[i].stamp) > 1e-9 * scale) std::abort();
        if ((back[i].pose.translation() - poses[i].pose.translation()).norm() >
            1e-9 * (1 + poses[i].pose.translation().norm()))
          std::abort();
      }
    } else if (reader == 1) {
      std::istringstream in(text);
      const std::vector<lidar::Relation> relations = lidar::ReadRelations(in, "fuzz.relations");
      std::vector<lidar::StampedPose2> poses;
      for (const lidar::Relation& r : relations) {
        poses.push_back({r.t1, SE2d()});
        poses.push_back({r.t2, SE2d()});
      }
      std::sort(poses.begin(), poses.end(), [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
      lidar::EvaluateRelations(poses, relations, {});
    } else if (reader == 2) {
      { std::ofstream(BagScratchPath(), std::ios::binary) << text; }
      lidar::CheckBagRecords(BagScratchPath());
    } else {
      lidar::OccupancyImage image = lidar::ParsePgm(text, "fuzz.pgm");
      if (image.pixels.size() > 1000000) return 0;
      image.resolution = 0.05;
      const localization::OccupancyMap2D map(image);
      const localization::LikelihoodField field(map, {}, 30);
      for (int j = 0; j < map.height(); ++j) {
        for (int i = 0; i < map.width(); ++i) {
          const float d = map.Distance(i, j);
          if (std::isnan(d) || (d == 0) != (map.State(i, j) == localization::CellState::kOccupied)) std::abort();
          if (!std::isfinite(field.BeamScore(d))) std::abort();
        }
      }
    }
  } catch (const Error&) {
  }
  return 0;
}

}  // namespace fuzz
}  // namespace tether
