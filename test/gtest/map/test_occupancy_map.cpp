// Map loading: map_server semantics on small fixtures, TurtleBot3's own map, world <-> cell
// boundaries, and one fixture per bad input with its message.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "marl_mrta/map/occupancy_map.h"

using marl_mrta::map::MapImage;
using marl_mrta::map::loadMap;
using marl_mrta::map::MapError;
using marl_mrta::map::OccupancyMap;
using marl_mrta::map::readMapImage;
using marl_mrta::map::readPgm;

namespace {

std::string fixture(const std::string& name) {
  return std::string(MARL_MRTA_SOURCE_DIR) + "/test/data/maps/" + name;
}

// Rows listed top (highest y) first, the way one reads a picture of the map.
std::vector<int8_t> gridFromTopRows(const std::vector<std::vector<int>>& rows_top_first) {
  std::vector<int8_t> grid;
  for (auto row = rows_top_first.rbegin(); row != rows_top_first.rend(); ++row) {
    for (int value : *row) grid.push_back(static_cast<int8_t>(value));
  }
  return grid;
}

// Message of the MapError thrown by loadMap(path), or "" when nothing is thrown.
std::string loadError(const std::string& path) {
  try {
    loadMap(path);
  } catch (const MapError& e) {
    return e.what();
  }
  return "";
}

OccupancyMap gridOfOnes(double resolution, int width, int height, double origin_x, double origin_y) {
  OccupancyMap map;
  map.resolution = resolution;
  map.width = width;
  map.height = height;
  map.origin_x = origin_x;
  map.origin_y = origin_y;
  map.data.assign(static_cast<size_t>(width) * height, 0);
  return map;
}

}  // namespace

TEST(MapLoading, TinyMapRowOrderThresholdsAndOrigin) {
  const OccupancyMap map = loadMap(fixture("tiny.yaml"));
  EXPECT_EQ(map.width, 4);
  EXPECT_EQ(map.height, 3);
  EXPECT_DOUBLE_EQ(map.resolution, 0.5);
  EXPECT_DOUBLE_EQ(map.origin_x, 1.0);
  EXPECT_DOUBLE_EQ(map.origin_y, -2.0);
  // Pixels 0 / 254 / 205 -> occupied / free / unknown (205: occ = 0.19608 lies between the thresholds).
  EXPECT_EQ(map.data, gridFromTopRows({{100, 0, 0, -1},  //
                                       {0, 0, 100, 0},
                                       {-1, 0, 0, 0}}));
  // The image's top-left black pixel is grid cell (0, 2), centred 0.25 m inside the origin corner.
  double wx = 0, wy = 0;
  map.cellToWorld(0, 2, wx, wy);
  EXPECT_DOUBLE_EQ(wx, 1.25);
  EXPECT_DOUBLE_EQ(wy, -0.75);
  int cx = -1, cy = -1;
  ASSERT_TRUE(map.worldToCell(2.2, -1.4, cx, cy));  // the black pixel in the image's middle row
  EXPECT_EQ(cx, 2);
  EXPECT_EQ(cy, 1);
  EXPECT_EQ(map.at(cx, cy), OccupancyMap::kOccupied);
}

TEST(MapLoading, NegateSwapsBlackAndWhite) {
  const OccupancyMap map = loadMap(fixture("tiny_negate.yaml"));
  // negate: mean -> 255 - mean before occ: black is free, white and grey 205 are occupied.
  EXPECT_EQ(map.data, gridFromTopRows({{0, 100, 100, 100},  //
                                       {100, 100, 0, 100},
                                       {100, 100, 100, 100}}));
}

TEST(MapLoading, AsciiPgmWithOtherMaxvalGivesTheSameMap) {
  const OccupancyMap binary = loadMap(fixture("tiny.yaml"));
  const OccupancyMap ascii = loadMap(fixture("tiny_ascii.yaml"));
  EXPECT_EQ(ascii.width, binary.width);
  EXPECT_EQ(ascii.height, binary.height);
  EXPECT_EQ(ascii.data, binary.data);
}

TEST(MapLoading, TrinaryScaleAndRawModes) {
  // Ramp pixels 0, 50, 100, 128, 150, 200, 230, 255.
  EXPECT_EQ(loadMap(fixture("ramp_trinary.yaml")).data,
            (std::vector<int8_t>{100, 100, -1, -1, -1, -1, 0, 0}));
  // scale: 1 + 98 (occ - free) / (occupied - free), truncated.
  EXPECT_EQ(loadMap(fixture("ramp_scale.yaml")).data, (std::vector<int8_t>{100, 100, 89, 66, 47, 5, 0, 0}));
  // raw: the grey value itself, stored in a signed byte.
  EXPECT_EQ(loadMap(fixture("ramp_raw.yaml")).data,
            (std::vector<int8_t>{0, 50, 100, -128, -106, -56, -26, -1}));
}

TEST(MapLoading, RotatedOriginIsHonoured) {
  const OccupancyMap map = loadMap(fixture("tiny_rotated.yaml"));
  EXPECT_NEAR(map.origin_yaw, M_PI / 2, 1e-12);
  // Grid x runs along world +y, grid y along world -x.
  double wx = 0, wy = 0;
  map.cellToWorld(3, 0, wx, wy);
  EXPECT_NEAR(wx, 0.75, 1e-12);
  EXPECT_NEAR(wy, -0.25, 1e-12);
  int cx = -1, cy = -1;
  ASSERT_TRUE(map.worldToCell(0.75, -0.25, cx, cy));
  EXPECT_EQ(cx, 3);
  EXPECT_EQ(cy, 0);
  EXPECT_FALSE(map.worldToCell(1.25, -1.75, cx, cy));  // would be inside without the rotation
}

TEST(MapLoading, PgmReaderKeepsFileRowOrder) {
  const MapImage image = readPgm(fixture("tiny.pgm"));
  ASSERT_EQ(image.pixels.size(), 12u);
  EXPECT_EQ(image.pixels[0], 0);     // top-left
  EXPECT_EQ(image.pixels[3], 205);   // top-right
  EXPECT_EQ(image.pixels[8], 205);   // bottom-left
}

TEST(MapLoading, PngMapsAreReadAsMapServerReadsThem) {
  // A grey PNG is the same map as the same PGM; 16-bit samples keep their high byte.
  const OccupancyMap pgm = loadMap(fixture("tiny.yaml"));
  EXPECT_EQ(loadMap(fixture("tiny_png.yaml")).data, pgm.data);
  EXPECT_EQ(loadMap(fixture("tiny_grey16.yaml")).data, pgm.data);
  // RGBA pixels (0,0,0,255), (254,254,254,0), (150,150,150,255), (150,150,150,0): trinary averages
  // alpha in with the colours; scale leaves it out, and alpha 0 between the thresholds is unknown.
  EXPECT_EQ(readMapImage(fixture("tiny_rgba.png")).channels, 4);
  EXPECT_EQ(loadMap(fixture("tiny_rgba_trinary.yaml")).data, (std::vector<int8_t>{100, -1, -1, -1}));
  EXPECT_EQ(loadMap(fixture("tiny_rgba_scale.yaml")).data, (std::vector<int8_t>{100, 0, 47, -1}));
}

TEST(MapLoading, TurtleBot3MapHasThePillarAtItsWorldCoordinates) {
  // The checkout's parent holds shared/external/... (the TurtleBot3 sources users already run).
  const std::filesystem::path source = std::filesystem::canonical(MARL_MRTA_SOURCE_DIR);
  const std::filesystem::path yaml =
      source / "../shared/external/turtlebot3_noetic/turtlebot3_navigation/maps/map.yaml";
  if (!std::filesystem::exists(yaml)) {
    GTEST_SKIP() << "TurtleBot3 map not found at " << yaml.string() << " (needs ../shared/external beside the checkout)";
  }
  const OccupancyMap map = loadMap(yaml.string());
  EXPECT_EQ(map.width, 384);
  EXPECT_EQ(map.height, 384);
  EXPECT_DOUBLE_EQ(map.resolution, 0.05);
  EXPECT_DOUBLE_EQ(map.origin_x, -10.0);
  EXPECT_DOUBLE_EQ(map.origin_y, -10.0);
  // The world's central pillar: a ring of occupied cells around (0.025, 0.025) whose
  // inside was never seen (unknown), with free space just outside it.
  int cx = -1, cy = -1;
  ASSERT_TRUE(map.worldToCell(-0.125, 0.025, cx, cy));  // west edge of the ring
  EXPECT_EQ(cx, 197);
  EXPECT_EQ(cy, 200);
  EXPECT_EQ(map.at(cx, cy), OccupancyMap::kOccupied);
  ASSERT_TRUE(map.worldToCell(0.025, 0.025, cx, cy));   // inside the pillar
  EXPECT_EQ(map.at(cx, cy), OccupancyMap::kUnknown);
  ASSERT_TRUE(map.worldToCell(-0.175, 0.025, cx, cy));  // one cell west of the ring
  EXPECT_EQ(map.at(cx, cy), OccupancyMap::kFree);
  ASSERT_TRUE(map.worldToCell(0.025, 0.175, cx, cy));   // north edge of the ring
  EXPECT_EQ(map.at(cx, cy), OccupancyMap::kOccupied);
  // The image's bottom-left pixel is grid cell (0, 0): unknown (205) outside the arena.
  EXPECT_EQ(map.at(0, 0), OccupancyMap::kUnknown);
}

// World <-> cell conversions at cell boundaries (cf. costmap_2d's coordinates test).
TEST(MapCoordinates, CellBoundaries) {
  const OccupancyMap map = gridOfOnes(1.0, 10, 10, 0.0, 0.0);
  int cx = -1, cy = -1;
  ASSERT_TRUE(map.worldToCell(0.25, 0.25, cx, cy));
  EXPECT_EQ(cx, 0);
  EXPECT_EQ(cy, 0);
  ASSERT_TRUE(map.worldToCell(0.9999, 0.9999, cx, cy));
  EXPECT_EQ(cx, 0);
  EXPECT_EQ(cy, 0);
  ASSERT_TRUE(map.worldToCell(1.0, 2.0, cx, cy));
  EXPECT_EQ(cx, 1);
  EXPECT_EQ(cy, 2);
  ASSERT_TRUE(map.worldToCell(9.9999, 9.9999, cx, cy));
  EXPECT_EQ(cx, 9);
  EXPECT_EQ(cy, 9);
  ASSERT_TRUE(map.worldToCell(0.0, 0.0, cx, cy));
  EXPECT_EQ(cx, 0);
  EXPECT_EQ(cy, 0);
}

TEST(MapCoordinates, OutOfBounds) {
  const OccupancyMap map = gridOfOnes(1.0, 10, 10, 0.0, 0.0);
  int cx = 42, cy = 42;
  EXPECT_FALSE(map.worldToCell(-0.0001, 5.0, cx, cy));
  EXPECT_FALSE(map.worldToCell(5.0, -0.0001, cx, cy));
  EXPECT_FALSE(map.worldToCell(10.0, 5.0, cx, cy));
  EXPECT_FALSE(map.worldToCell(5.0, 10.0, cx, cy));
  EXPECT_FALSE(map.worldToCell(1e300, 5.0, cx, cy));
  EXPECT_FALSE(map.worldToCell(std::nan(""), 5.0, cx, cy));
  EXPECT_EQ(cx, 42);  // untouched on failure
  EXPECT_EQ(cy, 42);
}

TEST(MapCoordinates, NonZeroOriginAndFineResolution) {
  const OccupancyMap map = gridOfOnes(0.05, 160, 120, -0.5, -0.5);
  int cx = -1, cy = -1;
  ASSERT_TRUE(map.worldToCell(-0.5 + 0.25 * 0.05, -0.5 + 0.9999 * 0.05, cx, cy));
  EXPECT_EQ(cx, 0);
  EXPECT_EQ(cy, 0);
  ASSERT_TRUE(map.worldToCell(1.76, 1.51, cx, cy));
  EXPECT_EQ(cx, 45);
  EXPECT_EQ(cy, 40);
  double wx = 0, wy = 0;
  map.cellToWorld(45, 40, wx, wy);
  EXPECT_NEAR(wx, 1.775, 1e-12);
  EXPECT_NEAR(wy, 1.525, 1e-12);
  // Round trip of every cell centre.
  for (int x = 0; x < map.width; x += 7) {
    for (int y = 0; y < map.height; y += 5) {
      map.cellToWorld(x, y, wx, wy);
      ASSERT_TRUE(map.worldToCell(wx, wy, cx, cy));
      EXPECT_EQ(cx, x);
      EXPECT_EQ(cy, y);
    }
  }
  EXPECT_FALSE(map.worldToCell(-0.5001, 0.0, cx, cy));
  EXPECT_FALSE(map.worldToCell(7.5, 0.0, cx, cy));
}

// One fixture per bad input; the message names the file, the field and the problem.
struct BadMapCase {
  const char* file;
  const char* expected_message_end;  // after "<fixture dir>/"
};

class BadMapInput : public ::testing::TestWithParam<BadMapCase> {};

TEST_P(BadMapInput, OneLineNamingFileFieldAndProblem) {
  const BadMapCase& c = GetParam();
  const std::string message = loadError(fixture(c.file));
  ASSERT_FALSE(message.empty()) << c.file << " loaded without error";
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  const std::string expected = fixture("") + c.expected_message_end;
  EXPECT_EQ(message.substr(0, expected.size()), expected) << message;
}

INSTANTIATE_TEST_SUITE_P(
    Fixtures, BadMapInput,
    ::testing::Values(
        BadMapCase{"bad_missing_image.yaml", "bad_missing_image.yaml: image: '"},
        BadMapCase{"bad_malformed.yaml", "bad_malformed.yaml: yaml: malformed YAML at line "},
        BadMapCase{"bad_negative_resolution.yaml", "bad_negative_resolution.yaml: resolution: must be positive, got -0.05"},
        BadMapCase{"bad_origin.yaml", "bad_origin.yaml: origin: must be a list [x, y, yaw] of 3 numbers"},
        BadMapCase{"bad_negate.yaml", "bad_negate.yaml: negate: must be 0 or 1, got '2'"},
        BadMapCase{"bad_mode.yaml", "bad_mode.yaml: mode: 'foo' is not one of trinary, scale, raw"},
        BadMapCase{"bad_thresholds.yaml", "bad_thresholds.yaml: free_thresh: must be in [0, occupied_thresh = 0.3], got 0.5"},
        BadMapCase{"bad_unknown_field.yaml", "bad_unknown_field.yaml: resolutoin: unknown field"},
        BadMapCase{"bad_no_image_field.yaml", "bad_no_image_field.yaml: image: missing"},
        BadMapCase{"bad_missing_resolution.yaml", "bad_missing_resolution.yaml: resolution: missing"},
        BadMapCase{"bad_truncated_image.yaml", "truncated.pgm: PGM data: truncated: expected 12 bytes, found 3"},
        BadMapCase{"bad_not_pgm.yaml",
                   "not_pgm.pgm: PGM header: not a PGM or PNG file (expected magic P5 or P2, or a PNG, found 'P6')"},
        BadMapCase{"bad_too_large.yaml",
                   "too_large.pgm: PGM header: 6000 x 5000 = 30000000 cells, more than the 25000000 a map may have"},
        BadMapCase{"bad_not_a_mapping.yaml", "bad_not_a_mapping.yaml: yaml: must be a mapping"},
        BadMapCase{"bad_palette.yaml",
                   "palette.png: PNG: a palette image; map_server reads its palette indices as grey values"},
        BadMapCase{"bad_truncated_png.yaml", "truncated.png: PNG: "},
        BadMapCase{"no_such_map.yaml", "no_such_map.yaml: yaml: cannot open file"}));

TEST(MapLoading, MissingImageMessageNamesTheImagePath) {
  const std::string message = loadError(fixture("bad_missing_image.yaml"));
  EXPECT_NE(message.find(fixture("does_not_exist.pgm")), std::string::npos) << message;
  EXPECT_NE(message.find("cannot open"), std::string::npos) << message;
}
