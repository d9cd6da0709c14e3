#include "tether/frontends/lidar/io/occupancy_map.h"

#include <zlib.h>

#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/fields.h"
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

namespace {

// The next header token of a PGM: skips whitespace and '#' comments up to the end of line.
bool NextPgmToken(const std::string& b, std::size_t* at, std::string* token) {
  std::size_t i = *at;
  while (i < b.size()) {
    if (b[i] == '#') {
      while (i < b.size() && b[i] != '\n' && b[i] != '\r') ++i;
    } else if (std::isspace(static_cast<unsigned char>(b[i]))) {
      ++i;
    } else {
      break;
    }
  }
  const std::size_t start = i;
  while (i < b.size() && !std::isspace(static_cast<unsigned char>(b[i])) && b[i] != '#') ++i;
  *token = b.substr(start, i - start);
  *at = i;
  return !token->empty();
}

long PgmNumber(const std::string& b, std::size_t* at, const std::string& name, const char* what) {
  std::string t;
  long v = -1;
  if (!NextPgmToken(b, at, &t) || std::from_chars(t.data(), t.data() + t.size(), v).ptr != t.data() + t.size() ||
      v < 0) {
    throw ParseError(name + ": the PGM header's " + what + " is " +
                     (t.empty() ? "missing" : "'" + QuoteToken(t) + "'") +
                     " (a map image is a PGM: P5 or P2, width, height, maxval up to 255)");
  }
  return v;
}

// The file's bytes, at most `limit` of them: a larger file (or an endless one: /dev/zero) is
// refused.
std::string ReadWhole(const std::string& path, const char* what, std::size_t limit) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path + ": cannot open the " + std::string(what));
  std::string bytes;
  std::vector<char> chunk(1 << 20);
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    bytes.append(chunk.data(), static_cast<std::size_t>(in.gcount()));
    if (bytes.size() > limit) {
      throw ParseError(path + ": the " + std::string(what) + " is larger than " + std::to_string(limit >> 20) +
                       " MB: not a map (a map image holds at most 2^28 pixels)");
    }
  }
  if (in.bad()) throw IoError(path + ": cannot read the " + std::string(what));
  return bytes;
}

double YamlNumber(const std::string& v, const std::string& where, const std::string& key) {
  double d = 0;
  const char* begin = v.data();
  if (!v.empty() && v[0] == '+') ++begin;
  const auto r = std::from_chars(begin, v.data() + v.size(), d);
  if (v.empty() || r.ptr != v.data() + v.size() || !std::isfinite(d)) {
    throw ParseError(where + key + " is '" + QuoteToken(v) + "', not a finite number");
  }
  return d;
}

std::string Trim(const std::string& s) {
  std::size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  std::string t = s.substr(a, b - a);
  if (t.size() >= 2 && (t.front() == '"' || t.front() == '\'') && t.back() == t.front()) t = t.substr(1, t.size() - 2);
  return t;
}

}  // namespace

OccupancyImage ParsePgm(const std::string& bytes, const std::string& name) {
  std::size_t at = 0;
  std::string magic;
  NextPgmToken(bytes, &at, &magic);
  if (magic != "P5" && magic != "P2") {
    throw ParseError(name + ": not a PGM image (it starts with '" + QuoteToken(magic) +
                     "', a PGM with P5 or P2); save the map as an 8-bit greyscale PGM");
  }
  OccupancyImage image;
  const long width = PgmNumber(bytes, &at, name, "width");
  const long height = PgmNumber(bytes, &at, name, "height");
  const long maxval = PgmNumber(bytes, &at, name, "maxval");
  if (width < 1 || height < 1 || width > (1L << 28) || height > (1L << 28) || width * height > (1L << 28)) {
    throw ParseError(name + ": a PGM of " + std::to_string(width) + " x " + std::to_string(height) +
                     " pixels (a map needs 1 to 2^28 pixels)");
  }
  if (maxval < 1 || maxval > 255) {
    throw ParseError(name + ": PGM maxval " + std::to_string(maxval) +
                     " (only 8-bit images, maxval 1 to 255, are read); save the map with 8 bits a pixel");
  }
  image.width = static_cast<int>(width);
  image.height = static_cast<int>(height);
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  image.pixels.resize(n);
  const auto scale = [maxval](long v) { return static_cast<std::uint8_t>((v * 255 + maxval / 2) / maxval); };
  if (magic == "P5") {
    ++at;  // the one whitespace byte after maxval
    if (at > bytes.size() || bytes.size() - at < n) {
      throw ParseError(name + ": the PGM header says " + std::to_string(n) + " pixels but " +
                       std::to_string(at > bytes.size() ? 0 : bytes.size() - at) + " bytes follow it (a cut file?)");
    }
    for (std::size_t i = 0; i < n; ++i) {
      const long v = static_cast<unsigned char>(bytes[at + i]);
      if (v > maxval) throw ParseError(name + ": pixel " + std::to_string(i) + " is above maxval");
      image.pixels[i] = scale(v);
    }
  } else {
    for (std::size_t i = 0; i < n; ++i) {
      const long v = PgmNumber(bytes, &at, name, "pixel");
      if (v > maxval) throw ParseError(name + ": pixel " + std::to_string(i) + " is above maxval");
      image.pixels[i] = scale(v);
    }
  }
  return image;
}

MapFile ReadMapYaml(const std::string& yaml_path) {
  std::istringstream text(ReadWhole(yaml_path, "map YAML", 1 << 20));
  MapFile map;
  std::string image, line;
  bool has_resolution = false, has_origin = false;
  for (long number = 1; std::getline(text, line); ++number) {
    const std::string where = yaml_path + ":" + std::to_string(number) + ": ";
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    if (Trim(line).empty()) continue;
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos) throw ParseError(where + "'" + QuoteToken(Trim(line)) + "' is not 'key: value'");
    const std::string key = Trim(line.substr(0, colon)), value = Trim(line.substr(colon + 1));
    if (key == "image") {
      image = value;
    } else if (key == "resolution") {
      map.image.resolution = YamlNumber(value, where, key);
      if (!(map.image.resolution >= 1e-4 && map.image.resolution <= 1e3)) {
        throw ParseError(where + "resolution " + FormatDouble(map.image.resolution) +
                         " (metres per pixel) is not between 0.0001 and 1000");
      }
      has_resolution = true;
    } else if (key == "origin") {
      if (value.size() < 2 || value.front() != '[' || value.back() != ']') {
        throw ParseError(where + "origin is '" + QuoteToken(value) + "', not [x, y, yaw]");
      }
      std::vector<double> xyz;
      std::istringstream parts(value.substr(1, value.size() - 2));
      for (std::string part; std::getline(parts, part, ',');) xyz.push_back(YamlNumber(Trim(part), where, key));
      if (xyz.size() != 3)
        throw ParseError(where + "origin has " + std::to_string(xyz.size()) + " numbers, not [x, y, yaw]");
      if (xyz[2] != 0) {
        throw ParseError(where + "origin's yaw is not 0: rotated maps are not supported; rotate the image");
      }
      if (std::abs(xyz[0]) > 1e7 || std::abs(xyz[1]) > 1e7) {
        throw ParseError(where + "origin lies more than 10000 km from 0: not a map's origin");
      }
      map.image.origin = Eigen::Vector2d(xyz[0], xyz[1]);
      has_origin = true;
    } else if (key == "negate") {
      map.negate = YamlNumber(value, where, key) != 0;
    } else if (key == "occupied_thresh") {
      map.occupied_thresh = YamlNumber(value, where, key);
    } else if (key == "free_thresh") {
      map.free_thresh = YamlNumber(value, where, key);
    }
  }
  const std::string file = yaml_path + ": ";
  if (image.empty()) throw ParseError(file + "no 'image:' key naming the map's PGM");
  if (!has_resolution) throw ParseError(file + "no 'resolution:' key (metres per pixel)");
  if (!has_origin) throw ParseError(file + "no 'origin:' key ([x, y, yaw] of the lower-left pixel)");
  if (!(map.free_thresh >= 0 && map.free_thresh < map.occupied_thresh && map.occupied_thresh <= 1)) {
    throw ParseError(file + "thresholds free_thresh " + FormatDouble(map.free_thresh) + ", occupied_thresh " +
                     FormatDouble(map.occupied_thresh) + ": they must keep 0 <= free < occupied <= 1");
  }
  const std::size_t slash = yaml_path.rfind('/');
  map.image_path = image[0] == '/' || slash == std::string::npos ? image : yaml_path.substr(0, slash + 1) + image;
  const double resolution = map.image.resolution;
  const Eigen::Vector2d origin = map.image.origin;
  map.image = ParsePgm(ReadWhole(map.image_path, "map image", (std::size_t{1} << 30) + (1 << 20)), map.image_path);
  map.image.resolution = resolution;
  map.image.origin = origin;
  return map;
}

}  // namespace lidar
}  // namespace tether
