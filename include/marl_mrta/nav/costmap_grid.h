// A 2D grid of cell costs with its placement in the world (costmap_2d::Costmap2D's geometry).
//
// Cell (mx, my) covers [origin + m·res, origin + (m+1)·res) on each axis; its centre is at
// origin + (m + 0.5)·res. Row-major storage, row 0 at the origin side.
#pragma once

#include <cstdint>
#include <algorithm>
#include <cmath>
#include <vector>

#include "marl_mrta/nav/cost_values.h"

namespace marl_mrta {
namespace nav {

struct CellIndex {
  int x = 0;
  int y = 0;
};

class CostGrid {
 public:
  CostGrid() = default;
  CostGrid(unsigned size_x, unsigned size_y, double resolution, double origin_x, double origin_y,
           uint8_t default_value = kFreeSpace);

  // Reallocates and fills every cell with the default value.
  void resize(unsigned size_x, unsigned size_y, double resolution, double origin_x, double origin_y);
  void setDefaultValue(uint8_t value) { default_value_ = value; }
  uint8_t defaultValue() const { return default_value_; }
  void resetAll();
  // Cells [x0, xn) x [y0, yn) back to the default value (clamped to the grid).
  void resetRegion(int x0, int y0, int xn, int yn);

  unsigned sizeX() const { return size_x_; }
  unsigned sizeY() const { return size_y_; }
  double resolution() const { return resolution_; }
  double originX() const { return origin_x_; }
  double originY() const { return origin_y_; }
  double sizeMetersX() const { return size_x_ * resolution_; }
  double sizeMetersY() const { return size_y_ * resolution_; }

  unsigned index(unsigned mx, unsigned my) const { return my * size_x_ + mx; }
  uint8_t cost(unsigned mx, unsigned my) const { return cells_[index(mx, my)]; }
  void setCost(unsigned mx, unsigned my, uint8_t value) { cells_[index(mx, my)] = value; }
  const std::vector<uint8_t>& cells() const { return cells_; }
  std::vector<uint8_t>& cells() { return cells_; }

  // Cell containing (wx, wy); false (and cell 0, 0) when outside the grid, NaN included.
  // Inline: hot in DWA.
  bool worldToMap(double wx, double wy, unsigned& mx, unsigned& my) const {
    mx = my = 0;
    if (!(wx >= origin_x_ && wy >= origin_y_)) return false;
    const double fx = (wx - origin_x_) / resolution_;
    const double fy = (wy - origin_y_) / resolution_;
    if (!(fx < size_x_ && fy < size_y_)) return false;
    mx = static_cast<unsigned>(fx);
    my = static_cast<unsigned>(fy);
    return mx < size_x_ && my < size_y_;
  }
  // Cell coordinates without bounds checks (may be negative or past the end).
  CellIndex worldToMapNoBounds(double wx, double wy) const;
  // Cell coordinates clamped into the grid.
  CellIndex worldToMapEnforceBounds(double wx, double wy) const;
  // Centre of a cell.
  void mapToWorld(unsigned mx, unsigned my, double& wx, double& wy) const;
  bool inBounds(int mx, int my) const {
    return mx >= 0 && my >= 0 && mx < static_cast<int>(size_x_) && my < static_cast<int>(size_y_);
  }
  // A world distance in whole cells, rounded up.
  unsigned cellDistance(double world_distance) const;

  // Moves the grid so that its origin is (new_origin_x, new_origin_y) snapped to whole cells,
  // keeping the cells that stay inside and resetting the rest (rolling window).
  void updateOrigin(double new_origin_x, double new_origin_y);
  // A rolling window's move to the robot at (x, y). costmap_2d centres its window with
  // getSizeInMetersX(), which reaches the last cell's centre, (size - 0.5) * resolution, not its
  // far edge; the same span here puts the window on the same cells as costmap_2d's (DWA's
  // distance grids and local goal depend on where the window ends).
  void centreWindowOn(double x, double y) {
    updateOrigin(x - (size_x_ - 0.5) * resolution_ / 2.0, y - (size_y_ - 0.5) * resolution_ / 2.0);
  }

  // Bresenham line from (x0, y0) to (x1, y1), both in the grid, at most max_length cells
  // long; visit(index) is called for every cell including both ends (costmap_2d's raytrace).
  template <class Visitor>
  void raytraceLine(Visitor&& visit, unsigned x0, unsigned y0, unsigned x1, unsigned y1,
                    unsigned max_length = 0xffffffffu) const;

  // Cells inside a convex polygon given in world coordinates (outline included).
  std::vector<unsigned> convexFillCells(const std::vector<double>& xs, const std::vector<double>& ys) const;
  // Cells on the closed outline of a polygon given in world coordinates.
  std::vector<unsigned> polygonOutlineCells(const std::vector<double>& xs, const std::vector<double>& ys) const;

 private:
  unsigned size_x_ = 0, size_y_ = 0;
  double resolution_ = 0.05;
  double origin_x_ = 0.0, origin_y_ = 0.0;
  // The origin given to resize() and the whole cells moved since: origin = anchor + cells moved * res,
  // never a running sum, so the same shift gives the same origin whatever the path to it.
  double anchor_x_ = 0.0, anchor_y_ = 0.0;
  long cells_moved_x_ = 0, cells_moved_y_ = 0;
  uint8_t default_value_ = kFreeSpace;
  std::vector<uint8_t> cells_;
};

template <class Visitor>
void CostGrid::raytraceLine(Visitor&& visit, unsigned x0, unsigned y0, unsigned x1, unsigned y1,
                            unsigned max_length) const {
  const int dx = static_cast<int>(x1) - static_cast<int>(x0);
  const int dy = static_cast<int>(y1) - static_cast<int>(y0);
  const unsigned abs_dx = dx < 0 ? -dx : dx;
  const unsigned abs_dy = dy < 0 ? -dy : dy;
  const int step_x = dx > 0 ? 1 : (dx < 0 ? -1 : 0);
  const int step_y = (dy > 0 ? 1 : (dy < 0 ? -1 : 0)) * static_cast<int>(size_x_);
  unsigned offset = y0 * size_x_ + x0;
  const double length = std::sqrt(static_cast<double>(dx) * dx + static_cast<double>(dy) * dy);
  const double scale = length == 0.0 ? 1.0 : std::min(1.0, max_length / length);
  // Walk the dominant axis; the other advances when its error term overflows.
  const bool x_dominant = abs_dx >= abs_dy;
  const unsigned abs_a = x_dominant ? abs_dx : abs_dy;
  const unsigned abs_b = x_dominant ? abs_dy : abs_dx;
  const int step_a = x_dominant ? step_x : step_y;
  const int step_b = x_dominant ? step_y : step_x;
  int error_b = static_cast<int>(abs_a / 2);
  const unsigned end = std::min(static_cast<unsigned>(scale * abs_a), abs_a);
  for (unsigned i = 0; i < end; ++i) {
    visit(offset);
    offset += step_a;
    error_b += abs_b;
    if (static_cast<unsigned>(error_b) >= abs_a) {
      offset += step_b;
      error_b -= abs_a;
    }
  }
  visit(offset);
}

}  // namespace nav
}  // namespace marl_mrta
