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

}  // namespace lidar
}  // namespace tether
