// The map as the particle filter uses it (amcl's map/): the occupancy grid, each cell's
// distance to the nearest obstacle out to a limit (for the likelihood field, map_cspace.cpp),
// and the free cells that global localisation spreads particles over.
//
// Cells as amcl reads a nav_msgs/OccupancyGrid: 100 is an obstacle, 0 is free, anything else is
// unknown (neither). Distances are exact Euclidean distances between cell centres (amcl's
// wavefront approximates them), capped at `max_obstacle_distance`.
#pragma once

#include <string>
#include <vector>

#include "marl_mrta/loc/random_source.h"
#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/footprint.h"

namespace marl_mrta {
namespace loc {

class LocalizationMap {
 public:
  // Throws std::invalid_argument for an empty grid or a non-positive resolution.
  LocalizationMap(const map::OccupancyMap& occupancy, double max_obstacle_distance);

  const map::OccupancyMap& occupancy() const { return occupancy_; }
  double maxObstacleDistance() const { return max_obstacle_distance_; }

  // [m] from the centre of `cell` (row-major index) to the nearest obstacle cell's centre,
  // at most maxObstacleDistance().
  double obstacleDistance(size_t cell) const { return distance_[cell]; }
  // [m] at a world point: that of its cell; maxObstacleDistance() outside the grid.
  double obstacleDistanceAt(double wx, double wy) const;

  // Why a robot cannot stand at (wx, wy) as the map has it: "" on a free cell, else "is off the
  // map (...)", "is inside an obstacle of the map" or "is on an unknown cell of the map".
  std::string standingProblem(double wx, double wy) const;

  size_t freeCellCount() const { return free_cells_.size(); }
  // A pose uniformly distributed over the free cells (a uniform point in a uniformly chosen
  // free cell), yaw uniform in [-pi, pi). Throws std::logic_error when there is no free cell.
  nav::Pose2D randomFreePose(RandomSource& rng) const;

 private:
  map::OccupancyMap occupancy_;
  double max_obstacle_distance_;
  std::vector<float> distance_;
  std::vector<size_t> free_cells_;
};

}  // namespace loc
}  // namespace marl_mrta
