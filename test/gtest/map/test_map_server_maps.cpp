// The C++ reader on map_server's own test maps (navigation noetic, map_server/test/): the grids
// map_server's utest.cpp and rtest.cpp expect, in the modes and thresholds they load them with.
// The maps and the expected grids (test_constants.cpp) are read from the navigation source tarball
// beside the checkout, which users do not have: without it the tests skip.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "marl_mrta/map/occupancy_map.h"

namespace fs = std::filesystem;
using marl_mrta::map::loadMap;
using marl_mrta::map::MapError;
using marl_mrta::map::MapMode;
using marl_mrta::map::MapYaml;
using marl_mrta::map::occupancyFromImage;
using marl_mrta::map::OccupancyMap;
using marl_mrta::map::readMapImage;

namespace {

const char* const kFiles[] = {"testmap.png", "testmap2.png", "spectrum.png",
                              "testmap.yaml", "testmap2.yaml", "test_constants.cpp"};

fs::path tarball() {
  return fs::path(MARL_MRTA_SOURCE_DIR) / ".." / "shared" / "external" / "navigation_noetic" /
         "navigation_noetic.tar.gz";
}

// A directory removed with everything in it at the end of the test program.
struct TemporaryDirectory {
  fs::path path;
  ~TemporaryDirectory() {
    std::error_code ignored;
    if (!path.empty()) fs::remove_all(path, ignored);
  }
};

// map_server/test/ of the tarball, extracted once into a temporary directory ("" without the tarball).
const fs::path& testDir() {
  static const TemporaryDirectory dir{[] {
    if (!fs::exists(tarball())) return fs::path();
    fs::path out = fs::temp_directory_path() / ("marl_mrta_map_server_test_" + std::to_string(::getpid()));
    fs::create_directories(out);
    for (const char* file : kFiles) {
      const std::string command = "tar -xzOf '" + tarball().string() + "' ./map_server/test/" + file + " > '" +
                                  (out / file).string() + "'";
      if (std::system(command.c_str()) != 0) {
        fs::remove_all(out);
        return fs::path();
      }
    }
    return out;
  }()};
  return dir.path;
}

#define REQUIRE_MAP_SERVER_TESTS()                                                                     \
  if (testDir().empty()) {                                                                             \
    GTEST_SKIP() << "map_server's test maps not available: no " << tarball().lexically_normal().string() \
                 << " (the stock navigation source beside the checkout)";                             \
  }

// The expected grids of test_constants.cpp: testmap's first, then tmap2's (row-major, lowest row first).
std::vector<std::vector<int8_t>> expectedGrids() {
  std::ifstream file(testDir() / "test_constants.cpp");
  std::stringstream text;
  text << file.rdbuf();
  const std::string source = text.str();
  const std::regex array(R"(g_valid_image_content\[\]\s*=\s*\{([^}]*)\})");
  std::vector<std::vector<int8_t>> grids;
  for (auto it = std::sregex_iterator(source.begin(), source.end(), array); it != std::sregex_iterator(); ++it) {
    std::vector<int8_t> grid;
    std::stringstream values((*it)[1].str());
    std::string value;
    while (std::getline(values, value, ',')) {
      if (value.find_first_not_of(" \t\r\n") == std::string::npos) continue;
      grid.push_back(static_cast<int8_t>(std::stoi(value)));
    }
    grids.push_back(grid);
  }
  return grids;
}

// utest.cpp's call: loadMapFromFile(image, resolution, negate, occupied_thresh, free_thresh, origin 0, mode).
OccupancyMap loadImage(const std::string& image, double resolution, bool negate, double occupied_thresh,
                       double free_thresh, MapMode mode) {
  MapYaml params;
  params.image_path = (testDir() / image).string();
  params.resolution = resolution;
  params.negate = negate;
  params.occupied_thresh = occupied_thresh;
  params.free_thresh = free_thresh;
  params.mode = mode;
  const marl_mrta::map::MapImage pixels = readMapImage(params.image_path);
  OccupancyMap map;
  map.resolution = resolution;
  map.width = pixels.width;
  map.height = pixels.height;
  map.data = occupancyFromImage(pixels, params);
  return map;
}

std::map<int, int> counts(const OccupancyMap& map) {
  std::map<int, int> out;
  for (int8_t value : map.data) ++out[static_cast<uint8_t>(value)];
  return out;
}

}  // namespace

TEST(MapServerMaps, TheExpectedGridsAreFound) {
  REQUIRE_MAP_SERVER_TESTS();
  const auto grids = expectedGrids();
  ASSERT_EQ(2u, grids.size());
  EXPECT_EQ(100u, grids[0].size());
  EXPECT_EQ(144u, grids[1].size());
}

// utest.cpp, loadValidPNG: testmap.png at 0.1 m, not negated, thresholds 0.65 / 0.1, trinary.
TEST(MapServerMaps, LoadValidPng) {
  REQUIRE_MAP_SERVER_TESTS();
  const OccupancyMap map = loadImage("testmap.png", 0.1, false, 0.65, 0.1, MapMode::kTrinary);
  EXPECT_EQ(10, map.width);
  EXPECT_EQ(10, map.height);
  EXPECT_EQ(expectedGrids()[0], map.data);
}

// rtest.cpp, call_service: map_server started on testmap.yaml (thresholds 0.65 / 0.196, origin yaw 1).
TEST(MapServerMaps, TestmapYaml) {
  REQUIRE_MAP_SERVER_TESTS();
  const OccupancyMap map = loadMap((testDir() / "testmap.yaml").string());
  EXPECT_FLOAT_EQ(0.1f, static_cast<float>(map.resolution));
  EXPECT_EQ(10, map.width);
  EXPECT_EQ(10, map.height);
  EXPECT_DOUBLE_EQ(2.0, map.origin_x);
  EXPECT_DOUBLE_EQ(3.0, map.origin_y);
  EXPECT_DOUBLE_EQ(1.0, map.origin_yaw);
  EXPECT_EQ(expectedGrids()[0], map.data);
}

// rtest.cpp, change_map: testmap2.yaml (negate 1, thresholds 0.5 / 0.2) gives tmap2's grid.
TEST(MapServerMaps, Testmap2Yaml) {
  REQUIRE_MAP_SERVER_TESTS();
  const OccupancyMap map = loadMap((testDir() / "testmap2.yaml").string());
  EXPECT_FLOAT_EQ(0.1f, static_cast<float>(map.resolution));
  EXPECT_EQ(12, map.width);
  EXPECT_EQ(12, map.height);
  EXPECT_EQ(expectedGrids()[1], map.data);
}

// utest.cpp, testMapMode: spectrum.png (every grey once) at thresholds 0.65 / 0.1 in each mode.
TEST(MapServerMaps, SpectrumInEveryMode) {
  REQUIRE_MAP_SERVER_TESTS();
  std::map<int, int> trinary = counts(loadImage("spectrum.png", 0.1, false, 0.65, 0.1, MapMode::kTrinary));
  EXPECT_EQ(90, trinary[100]);
  EXPECT_EQ(26, trinary[0]);
  EXPECT_EQ(140, trinary[255]);

  std::map<int, int> scale = counts(loadImage("spectrum.png", 0.1, false, 0.65, 0.1, MapMode::kScale));
  EXPECT_EQ(90, scale[100]);
  EXPECT_EQ(26, scale[0]);
  int scaled = 0;
  for (int value = 1; value < 100; ++value) scaled += scale[value];
  EXPECT_EQ(140, scaled);

  std::map<int, int> raw = counts(loadImage("spectrum.png", 0.1, false, 0.65, 0.1, MapMode::kRaw));
  for (int value = 0; value < 256; ++value) EXPECT_EQ(1, raw[value]) << value;
}

// utest.cpp, loadInvalidFile: a file that is not there is an error.
TEST(MapServerMaps, LoadInvalidFile) {
  REQUIRE_MAP_SERVER_TESTS();
  EXPECT_THROW(readMapImage((testDir() / "foo").string()), MapError);
}
