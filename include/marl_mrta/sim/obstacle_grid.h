// The static obstacles of the map, prepared once for the collision checks: the clearance of a
// point (distance to the nearest occupied cell).
//
// A distance field computed at construction gives, for every cell, a lower bound of the
// distance from any point of the cell to any occupied cell, so that the exact (cell by cell)
// search only runs near obstacles.
#pragma once

#include <cstdint>
#include <vector>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/sim/geometry.h"

namespace marl_mrta {
namespace sim {

// Whether a map cell blocks robots and beams: the cells a costmap treats as lethal, value >= 100
// read as unsigned (so raw-mode values 100..254 too), never -1 (unknown, which is free here).
inline bool isObstacle(int8_t cell_value) {
  return cell_value != map::OccupancyMap::kUnknown && static_cast<uint8_t>(cell_value) >= 100;
}

class ObstacleGrid {
 public:
  // Obstacles per isObstacle(); outside the grid is free.
  explicit ObstacleGrid(const map::OccupancyMap& map);

  // Distance [m] from (x, y) to the nearest occupied cell, or `limit` when it is at least
  // `limit`. With `nearest`, also the closest obstacle point (only set when below limit).
  double clearance(double x, double y, double limit, Point2D* nearest = nullptr) const;

  // True when (x, y) is inside the grid on a cell known to be free (value 0..99).
  bool isKnownFree(double x, double y) const;

  int width() const { return width_; }
  int height() const { return height_; }
  double resolution() const { return resolution_; }

 private:
  // Map frame -> continuous grid coordinates [cells].
  void toGrid(double x, double y, double& gx, double& gy) const {
    const double dx = x - origin_x_, dy = y - origin_y_;
    gx = (cos_yaw_ * dx + sin_yaw_ * dy) * inv_resolution_;
    gy = (-sin_yaw_ * dx + cos_yaw_ * dy) * inv_resolution_;
  }
  void toWorld(double gx, double gy, double& x, double& y) const {
    gx *= resolution_;
    gy *= resolution_;
    x = origin_x_ + cos_yaw_ * gx - sin_yaw_ * gy;
    y = origin_y_ + sin_yaw_ * gx + cos_yaw_ * gy;
  }
  size_t index(int cx, int cy) const { return static_cast<size_t>(cy) * width_ + cx; }

  int width_ = 0, height_ = 0;
  double resolution_ = 0.0, inv_resolution_ = 0.0;
  double origin_x_ = 0.0, origin_y_ = 0.0, cos_yaw_ = 1.0, sin_yaw_ = 0.0;
  std::vector<uint8_t> occupied_;
  std::vector<uint8_t> known_free_;
  std::vector<float> free_radius_;  // [cells] lower bound of the distance from the cell to any obstacle
};

}  // namespace sim
}  // namespace marl_mrta
