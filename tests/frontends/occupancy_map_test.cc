// The occupancy map as files: pixels, orientation, PGM, PNG (decoded back with zlib) and YAML.
#include "tether/frontends/lidar/io/occupancy_map.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include "tether/core/error.h"

namespace tether {
namespace lidar {
namespace {

using Cell = ProbabilityGrid::Cell;

std::uint32_t BigEndian32(const std::string& s, std::size_t at) {
  return (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at])) << 24) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 1])) << 16) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 2])) << 8) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 3]));
}

// A 0.1 m grid with its origin at (-2, 1): an occupied cell (3, 7), a free cell (0, 4), the
// corner cells known at (0, 4) and (3, 7) bounding a 4 x 4 box; the rest unknown.
ProbabilityGrid SmallGrid() {
  ProbabilityGrid g(0.1, Eigen::Vector2d(-2, 1));
  g.SetProbability(Cell(3, 7), 0.9);
  g.SetProbability(Cell(0, 4), 0.2);
  g.SetProbability(Cell(1, 5), 0.5);
  return g;
}

TEST(OccupancyMapTest, RendersTopRowFirstWithRosPixelValues) {
  EXPECT_EQ(PixelOfProbability(0.8), 51);   // 255 * 0.2
  EXPECT_EQ(PixelOfProbability(0.2), 204);  // 255 * 0.8
  EXPECT_EQ(PixelOfProbability(0.0), 255);
  EXPECT_EQ(PixelOfProbability(1.0), 0);
  const ProbabilityGrid g = SmallGrid();
  const OccupancyImage image = RenderOccupancy(g, 1);
  ASSERT_EQ(image.width, 4 + 2);
  ASSERT_EQ(image.height, 4 + 2);
  EXPECT_DOUBLE_EQ(image.resolution, 0.1);
  // The lower-left pixel is cell (-1, 3): its corner at (-2 - 0.1, 1 + 0.3).
  EXPECT_NEAR(image.origin.x(), -2.1, 1e-12);
  EXPECT_NEAR(image.origin.y(), 1.3, 1e-12);
  // Cell (3, 7) is the top row's (row 1 after the padding) column 4; cell (0, 4) row 4, column 1.
  const auto q = [&](double p) { return g.ValueToProbability(g.ProbabilityToValue(p)); };
  EXPECT_EQ(image.Pixel(4, 1), PixelOfProbability(q(0.9)));
  EXPECT_EQ(image.Pixel(1, 4), PixelOfProbability(q(0.2)));
  EXPECT_EQ(image.Pixel(2, 3), PixelOfProbability(q(0.5)));
  EXPECT_EQ(image.Pixel(0, 0), kUnknownPixel);
  EXPECT_EQ(image.Pixel(3, 3), kUnknownPixel);
  EXPECT_THROW(RenderOccupancy(ProbabilityGrid(0.1)), InvalidArgument);
  EXPECT_THROW(RenderOccupancy(g, -1), InvalidArgument);
}

TEST(OccupancyMapTest, PgmPngAndYaml) {
  const OccupancyImage image = RenderOccupancy(SmallGrid(), 0);
  const std::string pgm = PgmBytes(image);
  const std::string header = "P5\n4 4\n255\n";
  ASSERT_EQ(pgm.substr(0, header.size()), header);
  ASSERT_EQ(pgm.size(), header.size() + 16);
  for (int i = 0; i < 16; ++i) EXPECT_EQ(static_cast<std::uint8_t>(pgm[header.size() + i]), image.pixels[i]);

  const std::string png = PngBytes(image);
  ASSERT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n"));
  // Chunks: IHDR (13 bytes), IDAT, IEND; each CRC over its type and data.
  std::size_t at = 8;
  std::string idat;
  std::vector<std::string> types;
  while (at < png.size()) {
    const std::uint32_t length = BigEndian32(png, at);
    const std::string type = png.substr(at + 4, 4);
    const std::string data = png.substr(at + 8, length);
    const uLong crc = crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(png.data() + at + 4), length + 4);
    EXPECT_EQ(BigEndian32(png, at + 8 + length), static_cast<std::uint32_t>(crc)) << type;
    types.push_back(type);
    if (type == "IHDR") {
      EXPECT_EQ(BigEndian32(data, 0), 4u);
      EXPECT_EQ(BigEndian32(data, 4), 4u);
      EXPECT_EQ(data.substr(8), std::string("\x08\x00\x00\x00\x00", 5));
    }
    if (type == "IDAT") idat += data;
    at += 12 + length;
  }
  EXPECT_EQ(types, (std::vector<std::string>{"IHDR", "IDAT", "IEND"}));
  std::string raw(4 * 5, '\0');
  uLongf size = static_cast<uLongf>(raw.size());
  ASSERT_EQ(uncompress(reinterpret_cast<Bytef*>(&raw[0]), &size, reinterpret_cast<const Bytef*>(idat.data()),
                       static_cast<uLong>(idat.size())),
            Z_OK);
  ASSERT_EQ(size, 20u);
  for (int row = 0; row < 4; ++row) {
    EXPECT_EQ(raw[static_cast<std::size_t>(row * 5)], '\0');  // filter none
    for (int c = 0; c < 4; ++c)
      EXPECT_EQ(static_cast<std::uint8_t>(raw[static_cast<std::size_t>(row * 5 + 1 + c)]), image.Pixel(c, row));
  }

  const std::string yaml = MapYaml(image, "map.pgm");
  EXPECT_NE(yaml.find("image: map.pgm\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("resolution: 0.1\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("origin: [-2, 1.4, 0.0]\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("negate: 0\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("occupied_thresh: 0.65\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("free_thresh: 0.196\n"), std::string::npos) << yaml;
}

}  // namespace
}  // namespace lidar
}  // namespace tether
