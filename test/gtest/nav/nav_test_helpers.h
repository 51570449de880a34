// Hand-made grids and a tiny kinematic robot for the navigation core tests.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/costmap_grid.h"
#include "marl_mrta/nav/footprint.h"

namespace marl_mrta {
namespace nav {
namespace testing {

// A map from rows of text, top row first ('#' occupied, '.' free, '?' unknown).
inline map::OccupancyMap mapFromText(const std::vector<std::string>& rows, double resolution = 0.05,
                                     double origin_x = 0.0, double origin_y = 0.0) {
  map::OccupancyMap m;
  m.resolution = resolution;
  m.origin_x = origin_x;
  m.origin_y = origin_y;
  m.height = static_cast<int>(rows.size());
  m.width = static_cast<int>(rows.front().size());
  m.data.resize(static_cast<size_t>(m.width) * m.height);
  for (int y = 0; y < m.height; ++y) {
    const std::string& row = rows[m.height - 1 - y];  // row 0 of the grid is the bottom
    for (int x = 0; x < m.width; ++x) {
      m.data[static_cast<size_t>(y) * m.width + x] =
          row[x] == '#' ? map::OccupancyMap::kOccupied : (row[x] == '?' ? map::OccupancyMap::kUnknown : 0);
    }
  }
  return m;
}

// A rectangular room (walls one cell thick) with optional filled boxes inside [x0, x1) x [y0, y1) cells.
struct Box {
  int x0, y0, x1, y1;
};
inline map::OccupancyMap roomMap(int width, int height, const std::vector<Box>& boxes, double resolution = 0.05) {
  std::vector<std::string> rows(height, std::string(width, '.'));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      bool wall = x == 0 || y == 0 || x == width - 1 || y == height - 1;
      for (const Box& b : boxes) wall = wall || (x >= b.x0 && x < b.x1 && y >= b.y0 && y < b.y1);
      if (wall) rows[height - 1 - y][x] = '#';
    }
  }
  return mapFromText(rows, resolution);
}

inline Polygon burgerFootprint() {
  return {{-0.105, -0.105}, {-0.105, 0.105}, {0.041, 0.105}, {0.041, -0.105}};
}

inline double pathLength(const std::vector<Pose2D>& path) {
  double length = 0.0;
  for (size_t i = 1; i < path.size(); ++i) length += std::hypot(path[i].x - path[i - 1].x, path[i].y - path[i - 1].y);
  return length;
}

}  // namespace testing
}  // namespace nav
}  // namespace marl_mrta
