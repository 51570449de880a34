// Casts a whole lidar scan against the static map at once.
//
// The borders between occupied and free cells are merged into axis-aligned segments once,
// at construction (a few dozen for a building map). A scan then visits each segment within
// range that faces the sensor, finds the beams inside its angular extent, and keeps per beam
// the nearest crossing. The result is exact -- the entry point into the first occupied cell --
// and costs a few nanoseconds per beam, where a cell-by-cell walk costs hundreds (grazing
// beams along walls cross dozens of cells).
#pragma once

#include <cstdint>
#include <vector>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/sim/geometry.h"

namespace marl_mrta {
namespace sim {

// Beam directions relative to the sensor: angle_min + i * increment, i < count.
struct BeamFan {
  int count = 360;
  double angle_min = 0.0;  // [rad]
  double increment = 0.0;  // [rad], count * increment must not exceed 2 pi
};

class ScanCaster {
 public:
  // Occupied cells per isObstacle() (obstacle_grid.h).
  explicit ScanCaster(const map::OccupancyMap& map);

  // ranges[i] (count entries): distance [m] from `sensor` (map frame) along beam i to the
  // first occupied cell, +inf when none lies within max_range. Not thread-safe (scratch).
  void cast(const Pose2D& sensor, const BeamFan& beams, double max_range, float* ranges) const;

  size_t segmentCount() const { return segments_.size(); }

 private:
  // A cell border at `fixed` along one axis, spanning [low, high] along the other, seen only
  // from the side the free cell is on. Grid units (cells).
  struct Segment {
    double fixed, low, high;
    bool vertical;      // x = fixed (else y = fixed)
    bool seen_from_low; // visible from coordinates below `fixed`
  };
  void addSegment(const Segment& segment);

  int width_ = 0, height_ = 0;
  double resolution_ = 0.0, origin_x_ = 0.0, origin_y_ = 0.0, origin_yaw_ = 0.0;
  std::vector<uint8_t> occupied_;
  std::vector<Segment> segments_;
  // Segments by tile (kTile x kTile cells), so that a scan only looks at segments near it.
  int tiles_x_ = 0, tiles_y_ = 0;
  std::vector<std::vector<uint32_t>> tile_segments_;
  // Scratch reused by every scan.
  mutable std::vector<uint32_t> visited_stamp_;
  mutable uint32_t stamp_ = 0;
  mutable std::vector<double> dir_x_, dir_y_, inv_x_, inv_y_;
};

}  // namespace sim
}  // namespace marl_mrta
