// Maps built in code for the simulator tests: a walled room with obstacles at known places.
#pragma once

#include <cmath>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/sim/sim_config.h"
#include "marl_mrta/sim/world.h"

namespace marl_mrta {
namespace sim {
namespace testing {

constexpr double kResolution = 0.05;

// A free room of width_m x height_m (origin at its lower-left corner, the map frame's origin
// at origin_x/y) enclosed by one-cell walls on the grid's border cells.
inline map::OccupancyMap room(double width_m, double height_m, double origin_x = 0.0, double origin_y = 0.0) {
  map::OccupancyMap map;
  map.resolution = kResolution;
  map.width = static_cast<int>(std::lround(width_m / kResolution));
  map.height = static_cast<int>(std::lround(height_m / kResolution));
  map.origin_x = origin_x;
  map.origin_y = origin_y;
  map.data.assign(static_cast<size_t>(map.width) * map.height, map::OccupancyMap::kFree);
  for (int x = 0; x < map.width; ++x) {
    map.data[x] = map::OccupancyMap::kOccupied;
    map.data[static_cast<size_t>(map.height - 1) * map.width + x] = map::OccupancyMap::kOccupied;
  }
  for (int y = 0; y < map.height; ++y) {
    map.data[static_cast<size_t>(y) * map.width] = map::OccupancyMap::kOccupied;
    map.data[static_cast<size_t>(y) * map.width + map.width - 1] = map::OccupancyMap::kOccupied;
  }
  return map;
}

// Marks the cells whose centres lie in [x0, x1] x [y0, y1] (map frame, origin_yaw 0).
inline void addBox(map::OccupancyMap& map, double x0, double y0, double x1, double y1,
                   int8_t value = map::OccupancyMap::kOccupied) {
  for (int cy = 0; cy < map.height; ++cy) {
    for (int cx = 0; cx < map.width; ++cx) {
      double wx, wy;
      map.cellToWorld(cx, cy, wx, wy);
      if (wx >= x0 && wx <= x1 && wy >= y0 && wy <= y1) map.data[static_cast<size_t>(cy) * map.width + cx] = value;
    }
  }
}

// Marks the cells whose centres lie within `radius` of (x, y).
inline void addDisc(map::OccupancyMap& map, double x, double y, double radius) {
  for (int cy = 0; cy < map.height; ++cy) {
    for (int cx = 0; cx < map.width; ++cx) {
      double wx, wy;
      map.cellToWorld(cx, cy, wx, wy);
      if (std::hypot(wx - x, wy - y) <= radius) map.data[static_cast<size_t>(cy) * map.width + cx] = 100;
    }
  }
}

inline WorldConfig idealConfig(std::vector<Pose2D> start_poses, int arenas = 1) {
  WorldConfig config;
  config.arenas = arenas;
  config.start_poses = std::move(start_poses);
  config.cmd_vel_timeout = 0.0;  // tests command once and let the robot drive
  return config;
}

// A profile of config/noise_profiles.yaml.
inline NoiseModel noiseProfile(const std::string& name) {
  return loadNoiseProfiles(std::string(MARL_MRTA_SOURCE_DIR) + "/config/noise_profiles.yaml").at(name);
}

// Drives every robot with the same command for `ticks` ticks (the command is repeated each tick).
inline void driveAll(World& world, const Twist2D& command, int ticks) {
  for (int t = 0; t < ticks; ++t) {
    for (int g = 0; g < world.robotCount(); ++g) world.setCommand(g, command);
    world.step();
  }
}

}  // namespace testing
}  // namespace sim
}  // namespace marl_mrta
