// Occupancy maps in map_server format (YAML + PGM or PNG), loaded without ROS.
//
// The semantics are map_server's (noetic): the image path is relative to the YAML file,
// occ = (255 - mean) / 255 (mean inverted first when `negate` is set), trinary / scale / raw
// modes, and grid row 0 is the bottom row of the image. The cell values follow
// nav_msgs/OccupancyGrid: 100 occupied, 0 free, -1 unknown (scale mode: 1..99 in between).
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace marl_mrta {
namespace map {

// A problem in a map file. what() is one line: "<file>: <field>: <problem>".
class MapError : public std::runtime_error {
 public:
  MapError(const std::string& file, const std::string& field, const std::string& problem);
  const std::string& file() const { return file_; }
  const std::string& field() const { return field_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string file_, field_, problem_;
};

enum class MapMode { kTrinary, kScale, kRaw };

// The most cells a map may have: a 250 m square at 0.05 m. Every robot's move_base holds costmaps
// and planner arrays of the map's size (about 17 bytes a cell), so 16 robots need some 7 GB at this
// size; a larger image (often a resolution typed too fine) is refused before its pixels are read.
// model/occupancy_map.py's MAX_MAP_CELLS is the same number (a test compares them).
constexpr size_t kMaxMapCells = 25000000;

struct OccupancyMap {
  static constexpr int8_t kFree = 0;
  static constexpr int8_t kOccupied = 100;
  static constexpr int8_t kUnknown = -1;

  double resolution = 0.0;   // [m / cell]
  double origin_x = 0.0;     // pose of the outer corner of cell (0, 0) in the map frame [m, m, rad]
  double origin_y = 0.0;
  double origin_yaw = 0.0;
  int width = 0;             // cells along x
  int height = 0;            // cells along y
  std::vector<int8_t> data;  // row-major, row 0 at the bottom (origin side)
  std::string yaml_path;     // where the map was loaded from (for messages); empty if built in code

  // Cell containing the world point; false (cx, cy untouched) when outside the grid.
  bool worldToCell(double wx, double wy, int& cx, int& cy) const;
  // World coordinates of the centre of a cell (also defined outside the grid).
  void cellToWorld(int cx, int cy, double& wx, double& wy) const;
  bool inBounds(int cx, int cy) const { return cx >= 0 && cy >= 0 && cx < width && cy < height; }
  // Value of an in-bounds cell.
  int8_t at(int cx, int cy) const { return data[static_cast<size_t>(cy) * width + cx]; }
};

// The fields of a map_server YAML file, checked (image path made absolute).
struct MapYaml {
  std::string image_path;
  double resolution = 0.0;
  double origin_x = 0.0, origin_y = 0.0, origin_yaw = 0.0;
  bool negate = false;
  double occupied_thresh = 0.65;
  double free_thresh = 0.196;
  MapMode mode = MapMode::kTrinary;
};

// A map's image as map_server's loader (SDL_image) hands it over: 8-bit samples, row-major, row 0
// at the top (as stored in the file), `channels` per pixel: 1 (grey), 2 (a grey PNG with a
// transparent grey, tRNS: grey + alpha), 3 (RGB) or 4 (RGBA; a PNG's grey + alpha arrives as RGBA).
struct MapImage {
  int width = 0;
  int height = 0;
  int channels = 1;
  std::vector<uint8_t> pixels;
};

// Loads a map_server YAML file and its image. Throws MapError.
OccupancyMap loadMap(const std::string& yaml_path);

// The steps of loadMap, for tools and tests.
MapYaml readMapYaml(const std::string& yaml_path);
// The image of a map, PGM or PNG by its first bytes. Throws MapError.
MapImage readMapImage(const std::string& path);
// Binary (P5) or ASCII (P2) PGM of maxval 1..255, scaled to 0..255 below 255 (SDL_image refuses
// more bits). Throws MapError.
MapImage readPgm(const std::string& path);
// PNG: grey (1-, 2- and 4-bit scaled to 0..255; with a tRNS grey, grey + alpha), grey + alpha (as
// RGBA), RGB, RGBA; 16-bit samples keep their high byte. A palette image is refused (map_server
// would read its indices as grey values); what libpng refuses is refused. Throws MapError.
MapImage readPng(const std::string& path);
// map_server's pixel -> cell conversion (including the bottom-up row order).
std::vector<int8_t> occupancyFromImage(const MapImage& image, const MapYaml& params);

}  // namespace map
}  // namespace marl_mrta
