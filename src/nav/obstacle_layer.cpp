#include "marl_mrta/nav/obstacle_layer.h"

#include <cmath>

#include "marl_mrta/nav/layered_costmap.h"
#include "marl_mrta/nav/time_compare.h"

namespace marl_mrta {
namespace nav {

Observation laserScanToObservation(const LaserScanData& scan, const SensorPose& sensor,
                                   const ObservationSourceConfig& source) {
  Observation observation;
  observation.origin = {sensor.x, sensor.y, sensor.z};
  observation.obstacle_range = source.obstacle_range;
  observation.raytrace_range = source.raytrace_range;
  observation.stamp = scan.stamp;
  const double c = std::cos(sensor.yaw), s = std::sin(sensor.yaw);
  // The sensor sits at one height, so the height filter keeps all points or none.
  if (sensor.z < source.min_obstacle_height || sensor.z > source.max_obstacle_height) return observation;
  observation.points.reserve(scan.ranges.size());
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    double range = scan.ranges[i];
    if (source.inf_is_valid && std::isinf(range) && range > 0) range = scan.range_max - 1e-4;
    if (!(range < scan.range_max && range >= scan.range_min)) continue;
    const double angle = scan.angle_min + i * scan.angle_increment;
    const double px = range * std::cos(angle), py = range * std::sin(angle);
    observation.points.push_back({sensor.x + c * px - s * py, sensor.y + s * px + c * py, sensor.z});
  }
  return observation;
}

ObstacleLayer::ObstacleLayer(std::string name, const ObstacleLayerConfig& config)
    : Layer(std::move(name)), config_(config), buffers_(config.sources.size()) {
  grid_.setDefaultValue(config_.track_unknown_space ? kNoInformation : kFreeSpace);
}

void ObstacleLayer::matchSize(const LayeredCostmap& master) {
  const CostGrid& m = master.costmap();
  rolling_ = master.isRolling();
  grid_.resize(m.sizeX(), m.sizeY(), m.resolution(), m.originX(), m.originY());
  was_lethal_.assign(grid_.cells().size(), 0);
}

void ObstacleLayer::onFootprintChanged(const LayeredCostmap& master) { footprint_ = master.footprint(); }

void ObstacleLayer::addObservation(size_t source_index, Observation observation) {
  if (source_index >= buffers_.size()) return;
  SourceBuffer& buffer = buffers_[source_index];
  const double keep = config_.sources[source_index].observation_persistence;
  buffer.last_arrival = observation.stamp;
  buffer.observations.push_front(std::move(observation));
  buffer.unapplied = std::min(buffer.unapplied + 1, buffer.observations.size());
  // Forget what is older than the persistence (only the newest with persistence 0).
  const double newest = buffer.observations.front().stamp;
  while (buffer.observations.size() > 1 &&
         (keep <= 0.0 || newest - buffer.observations.back().stamp > keep)) {
    buffer.observations.pop_back();
  }
  buffer.unapplied = std::min(buffer.unapplied, buffer.observations.size());
}

void ObstacleLayer::touchCell(unsigned index, Bounds& bounds) const {
  const double x0 = grid_.originX() + (index % grid_.sizeX()) * grid_.resolution();
  const double y0 = grid_.originY() + (index / grid_.sizeX()) * grid_.resolution();
  bounds.touch(x0, y0);
  bounds.touch(x0 + grid_.resolution() * 0.999, y0 + grid_.resolution() * 0.999);
}

void ObstacleLayer::raytraceFreespace(const Observation& observation, Bounds& bounds) {
  const double ox = observation.origin.x, oy = observation.origin.y;
  unsigned x0, y0;
  if (!grid_.worldToMap(ox, oy, x0, y0)) return;
  const double map_x0 = grid_.originX(), map_y0 = grid_.originY();
  const double map_x1 = map_x0 + grid_.sizeMetersX(), map_y1 = map_y0 + grid_.sizeMetersY();
  const unsigned cell_range = grid_.cellDistance(observation.raytrace_range);
  uint8_t* cells = grid_.cells().data();
  for (const Point3& point : observation.points) {
    double wx = point.x, wy = point.y;
    const double a = wx - ox, b = wy - oy;
    // Clip the ray to the grid (costmap_2d's order of tests).
    if (wx < map_x0) {
      const double t = (map_x0 - ox) / a;
      wx = map_x0;
      wy = oy + b * t;
    }
    if (wy < map_y0) {
      const double t = (map_y0 - oy) / b;
      wx = ox + a * t;
      wy = map_y0;
    }
    if (wx > map_x1) {
      const double t = (map_x1 - ox) / a;
      wx = map_x1 - 0.001;
      wy = oy + b * t;
    }
    if (wy > map_y1) {
      const double t = (map_y1 - oy) / b;
      wx = ox + a * t;
      wy = map_y1 - 0.001;
    }
    unsigned x1, y1;
    if (!grid_.worldToMap(wx, wy, x1, y1)) continue;
    // Only cells whose value changes widen the update area (costmap_2d touches the whole ray;
    // the master keeps every cell outside the area, so the result is the same).
    grid_.raytraceLine(
        [&](unsigned index) {
          if (cells[index] == kFreeSpace) return;
          if (cells[index] == kLethalObstacle) {
            // Often marked again by this very scan (the hit cell): decided after marking.
            if (!was_lethal_[index]) cleared_.push_back(index);
            was_lethal_[index] = 1;
          } else {
            touchCell(index, bounds);
          }
          cells[index] = kFreeSpace;
        },
        x0, y0, x1, y1, cell_range);
  }
}

void ObstacleLayer::markObstacles(const Observation& observation, Bounds& bounds) {
  const double sq_range = observation.obstacle_range * observation.obstacle_range;
  for (const Point3& point : observation.points) {
    if (point.z > config_.max_obstacle_height) continue;
    const double dx = point.x - observation.origin.x, dy = point.y - observation.origin.y,
                 dz = point.z - observation.origin.z;
    if (dx * dx + dy * dy + dz * dz >= sq_range) continue;
    unsigned mx, my;
    if (!grid_.worldToMap(point.x, point.y, mx, my)) continue;
    const unsigned index = grid_.index(mx, my);
    if (grid_.cells()[index] == kLethalObstacle) continue;  // already marked: nothing changes
    grid_.cells()[index] = kLethalObstacle;
    if (was_lethal_[index]) {
      was_lethal_[index] = 0;  // cleared and marked again by the same update: unchanged
    } else {
      touchCell(index, bounds);
    }
  }
}

void ObstacleLayer::updateBounds(const Pose2D& robot, Bounds& bounds) {
  if (rolling_) grid_.centreWindowOn(robot.x, robot.y);
  if (!extra_bounds_.empty()) {
    bounds.touch(extra_bounds_.min_x, extra_bounds_.min_y);
    bounds.touch(extra_bounds_.max_x, extra_bounds_.max_y);
    extra_bounds_ = Bounds{};
  }
  // A moving window needs its observations again (new cells came in at the edge); a fixed
  // grid already holds what an observation wrote, so each is applied once.
  for (size_t s = 0; s < buffers_.size(); ++s) {
    SourceBuffer& buffer = buffers_[s];
    const size_t count = rolling_ ? buffer.observations.size() : buffer.unapplied;
    if (config_.sources[s].clearing) {
      for (size_t i = count; i-- > 0;) raytraceFreespace(buffer.observations[i], bounds);
    }
  }
  for (size_t s = 0; s < buffers_.size(); ++s) {
    SourceBuffer& buffer = buffers_[s];
    const size_t count = rolling_ ? buffer.observations.size() : buffer.unapplied;
    if (config_.sources[s].marking) {
      for (size_t i = count; i-- > 0;) markObstacles(buffer.observations[i], bounds);
    }
    buffer.unapplied = 0;
  }
  for (unsigned index : cleared_) {
    if (was_lethal_[index]) touchCell(index, bounds);  // cleared for good
    was_lethal_[index] = 0;
  }
  cleared_.clear();
  // The robot's own footprint is free space (costmap_2d clears it in updateCosts; done here so
  // that only a real change widens the update area).
  transformFootprint(footprint_, robot, footprint_x_, footprint_y_);
  if (config_.footprint_clearing_enabled) {
    for (unsigned index : grid_.convexFillCells(footprint_x_, footprint_y_)) {
      if (grid_.cells()[index] == kFreeSpace) continue;
      grid_.cells()[index] = kFreeSpace;
      touchCell(index, bounds);
    }
  }
  if (rolling_) {
    bounds.touch(grid_.originX(), grid_.originY());
    bounds.touch(grid_.originX() + grid_.sizeMetersX(), grid_.originY() + grid_.sizeMetersY());
  }
}

void ObstacleLayer::updateCosts(CostGrid& master, const CellWindow& window) {
  const std::vector<uint8_t>& layer = grid_.cells();
  std::vector<uint8_t>& target = master.cells();
  for (int y = window.min_y; y < window.max_y; ++y) {
    for (unsigned i = master.index(window.min_x, y), end = master.index(window.max_x, y); i < end; ++i) {
      const uint8_t value = layer[i];
      if (value == kNoInformation) continue;
      if (config_.combination_method == 0 || target[i] == kNoInformation || target[i] < value) target[i] = value;
    }
  }
}

void ObstacleLayer::clearArea(double x, double y, double side, bool invert_area) {
  const CellIndex lo = grid_.worldToMapNoBounds(x - side / 2.0, y - side / 2.0);
  const CellIndex hi = grid_.worldToMapNoBounds(x + side / 2.0, y + side / 2.0);
  // Strict inequalities and "unknown" as costmap_2d's clearArea (unknown reads as free
  // for this layer, which never overrides the master with 255).
  for (int cy = 0; cy < static_cast<int>(grid_.sizeY()); ++cy) {
    for (int cx = 0; cx < static_cast<int>(grid_.sizeX()); ++cx) {
      const bool inside = cx > lo.x && cx < hi.x && cy > lo.y && cy < hi.y;
      if (inside == invert_area) grid_.setCost(cx, cy, kNoInformation);
    }
  }
  extra_bounds_.touch(grid_.originX(), grid_.originY());
  extra_bounds_.touch(grid_.originX() + grid_.sizeMetersX(), grid_.originY() + grid_.sizeMetersY());
}

void ObstacleLayer::reset() {
  grid_.resetAll();
  for (SourceBuffer& buffer : buffers_) buffer = SourceBuffer{};
  extra_bounds_.touch(grid_.originX(), grid_.originY());
  extra_bounds_.touch(grid_.originX() + grid_.sizeMetersX(), grid_.originY() + grid_.sizeMetersY());
}

bool ObstacleLayer::isCurrent(double now) const {
  for (size_t s = 0; s < buffers_.size(); ++s) {
    const double rate = config_.sources[s].expected_update_rate;
    if (rate > 0.0 && (buffers_[s].last_arrival < 0.0 || isPast(now, buffers_[s].last_arrival, rate))) return false;
  }
  return true;
}

}  // namespace nav
}  // namespace marl_mrta
