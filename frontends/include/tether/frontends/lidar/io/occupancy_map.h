#pragma once
// The occupancy map a LiDAR run leaves, as files: a probability grid rendered to an 8-bit
// image and written as PGM (binary P5) + YAML in the ROS map_server convention, and as PNG.
//
// Pixels: a known cell of probability p is round(255 (1 - p)) (occupied dark, free light), an
// unknown cell 205 (ROS map_saver's grey). map_server reads a pixel v back as p = (255 - v)/255
// (negate 0) and calls it occupied above occupied_thresh (0.65) and free below free_thresh
// (0.196). The image's first row is the top of the map (largest y); `origin` in the YAML is
// the map-frame position of the lower-left pixel's lower-left corner, yaw 0.
//
//   const OccupancyImage image = RenderOccupancy(grid);
//   outputs... Stage(PgmBytes(image)); Stage(MapYaml(image, "map.pgm")); Stage(PngBytes(image));
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "tether/factors/probability_grid.h"

namespace tether {
namespace lidar {

struct OccupancyImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> pixels;                  ///< row-major, first row the top of the map
  double resolution = 0;                             ///< metres per pixel
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  ///< the lower-left corner (map frame)
  std::uint8_t Pixel(int column, int row) const { return pixels[static_cast<std::size_t>(row * width + column)]; }
};

/// The pixel value of a cell, as above.
constexpr std::uint8_t kUnknownPixel = 205;
std::uint8_t PixelOfProbability(double p);

/// The grid's known cells (their bounding box, widened by `padding` cells on every side) as an
/// image. Throws InvalidArgument where the grid has no known cell or padding is negative.
OccupancyImage RenderOccupancy(const ProbabilityGrid& grid, int padding = 2);

/// Binary PGM (P5, maxval 255).
std::string PgmBytes(const OccupancyImage& image);
/// An 8-bit greyscale PNG (zlib-compressed, one filter byte 0 per row).
std::string PngBytes(const OccupancyImage& image);
/// An 8-bit RGB PNG of `rgb` (3 bytes a pixel, rows top first). Throws InvalidArgument where
/// the size does not match.
std::string PngBytesRgb(int width, int height, const std::vector<std::uint8_t>& rgb);
/// The map_server YAML naming `image_file` (written as given: relative to the YAML's folder).
std::string MapYaml(const OccupancyImage& image, const std::string& image_file);

/// A map as map_server reads it: the image and how its pixels are told apart.
struct MapFile {
  OccupancyImage image;
  /// A pixel v is p = (255 - v) / 255 (v / 255 where `negate`): occupied above occupied_thresh,
  /// free below free_thresh, unknown between.
  double occupied_thresh = 0.65;
  double free_thresh = 0.196;
  bool negate = false;
  std::string image_path;  ///< the image file as opened (relative names resolved against the YAML's folder)
};

/// The pixels of a PGM (binary P5 or plain P2, maxval 1..255, '#' comments in the header);
/// resolution and origin are left 0. Throws ParseError "name: what" on anything else (16-bit
/// images, a header that does not parse, fewer pixels than the header says, an image above
/// 2^28 pixels).
OccupancyImage ParsePgm(const std::string& bytes, const std::string& name);

/// Reads a map_server map: the YAML (`image`, `resolution`, `origin: [x, y, yaw]`, `negate`,
/// `occupied_thresh`, `free_thresh`; other keys such as `mode` ignored) and the PGM it names.
/// Throws IoError where a file cannot be opened and ParseError "file:line: what" on a missing
/// or malformed key, a resolution outside [0.0001, 1000] m, an origin beyond 1e7 m, thresholds outside
/// 0 <= free < occupied <= 1, or a rotated origin (yaw other than 0: not supported).
MapFile ReadMapYaml(const std::string& yaml_path);

}  // namespace lidar
}  // namespace tether
