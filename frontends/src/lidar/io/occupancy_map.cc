#include "tether/frontends/lidar/io/occupancy_map.h"

#include <zlib.h>

#include <cmath>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/registry.h"

namespace tether {
namespace lidar {

namespace {

void PutBigEndian32(std::string* out, std::uint32_t v) {
  out->push_back(static_cast<char>((v >> 24) & 0xff));
  out->push_back(static_cast<char>((v >> 16) & 0xff));
  out->push_back(static_cast<char>((v >> 8) & 0xff));
  out->push_back(static_cast<char>(v & 0xff));
}

// A PNG chunk: length, type, data, CRC of type and data.
void PutChunk(std::string* out, const char type[4], const std::string& data) {
  PutBigEndian32(out, static_cast<std::uint32_t>(data.size()));
  const std::string typed = std::string(type, 4) + data;
  out->append(typed);
  const uLong crc =
      crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(typed.data()), static_cast<uInt>(typed.size()));
  PutBigEndian32(out, static_cast<std::uint32_t>(crc));
}

}  // namespace

std::uint8_t PixelOfProbability(double p) {
  const double v = std::round(255.0 * (1.0 - p));
  return static_cast<std::uint8_t>(v < 0 ? 0 : (v > 255 ? 255 : v));
}

OccupancyImage RenderOccupancy(const ProbabilityGrid& grid, int padding) {
  if (padding < 0) throw InvalidArgument("RenderOccupancy: padding must not be negative");
  ProbabilityGrid::Cell lo, hi;
  if (!grid.KnownBounds(&lo, &hi)) {
    throw InvalidArgument("RenderOccupancy: the grid has no known cell (nothing was inserted): no map to write");
  }
  lo -= padding;
  hi += padding;
  OccupancyImage image;
  image.width = hi.x() - lo.x() + 1;
  image.height = hi.y() - lo.y() + 1;
  image.resolution = grid.resolution();
  image.origin = grid.origin() + grid.resolution() * lo.cast<double>().matrix();
  image.pixels.resize(static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height));
  for (int row = 0; row < image.height; ++row) {
    const int y = hi.y() - row;  // the first row is the top
    for (int column = 0; column < image.width; ++column) {
      const ProbabilityGrid::Cell c(lo.x() + column, y);
      image.pixels[static_cast<std::size_t>(row * image.width + column)] =
          grid.IsKnown(c) ? PixelOfProbability(grid.Probability(c)) : kUnknownPixel;
    }
  }
  return image;
}

std::string PgmBytes(const OccupancyImage& image) {
  std::string out = "P5\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n255\n";
  out.append(image.pixels.begin(), image.pixels.end());
  return out;
}

namespace {

// An 8-bit PNG of `channels` (1 greyscale, 3 RGB) bytes a pixel, rows top first.
std::string Png(int width, int height, int channels, const std::uint8_t* pixels) {
  if (width <= 0 || height <= 0) throw InvalidArgument("PngBytes: an empty image");
  const std::size_t row_bytes = static_cast<std::size_t>(width) * static_cast<std::size_t>(channels);
  std::string raw;
  raw.reserve((row_bytes + 1) * static_cast<std::size_t>(height));
  for (int row = 0; row < height; ++row) {
    raw.push_back('\0');  // filter type 0 (none)
    const std::uint8_t* begin = pixels + static_cast<std::size_t>(row) * row_bytes;
    raw.append(begin, begin + row_bytes);
  }
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  std::string compressed(size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(&compressed[0]), &size, reinterpret_cast<const Bytef*>(raw.data()),
                static_cast<uLong>(raw.size()), 6) != Z_OK) {
    throw Error("PngBytes: zlib could not compress the image");
  }
  compressed.resize(size);
  std::string out = "\x89PNG\r\n\x1a\n";
  std::string ihdr;
  PutBigEndian32(&ihdr, static_cast<std::uint32_t>(width));
  PutBigEndian32(&ihdr, static_cast<std::uint32_t>(height));
  ihdr.push_back('\x08');                           // 8 bits a channel
  ihdr.push_back(channels == 3 ? '\x02' : '\x00');  // RGB or greyscale
  ihdr += std::string("\x00\x00\x00", 3);           // deflate, filter 0, no interlace
  PutChunk(&out, "IHDR", ihdr);
  PutChunk(&out, "IDAT", compressed);
  PutChunk(&out, "IEND", "");
  return out;
}

}  // namespace

std::string PngBytes(const OccupancyImage& image) {
  if (image.pixels.size() != static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height)) {
    throw InvalidArgument("PngBytes: the image's pixels do not match its size");
  }
  return Png(image.width, image.height, 1, image.pixels.data());
}

std::string PngBytesRgb(int width, int height, const std::vector<std::uint8_t>& rgb) {
  if (width < 0 || height < 0 || rgb.size() != 3 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    throw InvalidArgument("PngBytesRgb: " + std::to_string(rgb.size()) + " bytes for a " + std::to_string(width) +
                          " x " + std::to_string(height) + " RGB image");
  }
  return Png(width, height, 3, rgb.data());
}

std::string MapYaml(const OccupancyImage& image, const std::string& image_file) {
  std::ostringstream s;
  s << "image: " << image_file << "\n"
    << "resolution: " << FormatDouble(image.resolution) << "\n"
    << "origin: [" << FormatDouble(image.origin.x()) << ", " << FormatDouble(image.origin.y()) << ", 0.0]\n"
    << "negate: 0\n"
    << "occupied_thresh: 0.65\n"
    << "free_thresh: 0.196\n";
  return s.str();
}

}  // namespace lidar
}  // namespace tether
