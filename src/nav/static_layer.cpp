#include "marl_mrta/nav/static_layer.h"

#include <algorithm>

#include "marl_mrta/nav/layered_costmap.h"

namespace marl_mrta {
namespace nav {

StaticLayer::StaticLayer(std::string name, const StaticLayerConfig& config, LayeredCostmap& master)
    : Layer(std::move(name)), config_(config), master_(master) {}

uint8_t StaticLayer::interpretValue(int8_t value) const {
  // Compared as unsigned bytes like costmap_2d, so -1 and 255 name the same value.
  if (static_cast<uint8_t>(value) == static_cast<uint8_t>(config_.unknown_cost_value)) return config_.track_unknown_space ? kNoInformation : kFreeSpace;
  const int unsigned_value = static_cast<uint8_t>(value);
  if (unsigned_value >= config_.lethal_cost_threshold) return kLethalObstacle;
  if (config_.trinary_costmap) return kFreeSpace;
  return static_cast<uint8_t>(static_cast<double>(unsigned_value) / config_.lethal_cost_threshold * kLethalObstacle);
}

void StaticLayer::setMap(const map::OccupancyMap& occupancy) {
  if (map_received_ && config_.first_map_only) return;
  const unsigned size_x = occupancy.width, size_y = occupancy.height;
  const CostGrid& master = master_.costmap();
  if (!master_.isRolling() &&
      (master.sizeX() != size_x || master.sizeY() != size_y || master.resolution() != occupancy.resolution ||
       master.originX() != occupancy.origin_x || master.originY() != occupancy.origin_y)) {
    master_.resizeMap(size_x, size_y, occupancy.resolution, occupancy.origin_x, occupancy.origin_y);
    master_.setSizeLocked(true);
  }
  grid_.setDefaultValue(config_.track_unknown_space ? kNoInformation : kFreeSpace);
  grid_.resize(size_x, size_y, occupancy.resolution, occupancy.origin_x, occupancy.origin_y);
  for (size_t i = 0; i < occupancy.data.size() && i < grid_.cells().size(); ++i) {
    grid_.cells()[i] = interpretValue(occupancy.data[i]);
  }
  map_received_ = true;
  has_updated_data_ = true;
}

void StaticLayer::updateBounds(const Pose2D& /*robot*/, Bounds& bounds) {
  if (!map_received_) return;
  if (master_.isRolling()) {
    // The window moves over the map: everything in it may change.
    const CostGrid& master = master_.costmap();
    bounds.touch(master.originX(), master.originY());
    bounds.touch(master.originX() + master.sizeMetersX(), master.originY() + master.sizeMetersY());
    return;
  }
  if (!has_updated_data_) return;
  bounds.touch(grid_.originX(), grid_.originY());
  bounds.touch(grid_.originX() + grid_.sizeMetersX(), grid_.originY() + grid_.sizeMetersY());
  has_updated_data_ = false;
}

void StaticLayer::updateCosts(CostGrid& master, const CellWindow& window) {
  if (!map_received_) return;
  auto combine = [this](uint8_t& target, uint8_t value) {
    if (!config_.use_maximum) {
      target = value;
    } else if (value != kNoInformation && (target == kNoInformation || target < value)) {
      target = value;
    }
  };
  if (!master_.isRolling()) {
    for (int y = window.min_y; y < window.max_y; ++y) {
      for (int x = window.min_x; x < window.max_x; ++x) combine(master.cells()[master.index(x, y)], grid_.cost(x, y));
    }
    return;
  }
  // Rolling window: look the map cell up at each master cell's centre.
  for (int y = window.min_y; y < window.max_y; ++y) {
    for (int x = window.min_x; x < window.max_x; ++x) {
      double wx, wy;
      unsigned mx, my;
      master.mapToWorld(x, y, wx, wy);
      if (grid_.worldToMap(wx, wy, mx, my)) combine(master.cells()[master.index(x, y)], grid_.cost(mx, my));
    }
  }
}

bool StaticLayer::lethalWithin(double wx, double wy, double radius) const {
  if (!map_received_) return false;
  const CellIndex lo = grid_.worldToMapNoBounds(wx - radius, wy - radius);
  const CellIndex hi = grid_.worldToMapNoBounds(wx + radius, wy + radius);
  for (int y = lo.y; y <= hi.y; ++y) {
    for (int x = lo.x; x <= hi.x; ++x) {
      if (!grid_.inBounds(x, y) || grid_.cost(x, y) != kLethalObstacle) continue;
      // Distance from the point to the cell (0 inside it).
      const double cx0 = grid_.originX() + x * grid_.resolution(), cy0 = grid_.originY() + y * grid_.resolution();
      const double dx = std::max({cx0 - wx, 0.0, wx - (cx0 + grid_.resolution())});
      const double dy = std::max({cy0 - wy, 0.0, wy - (cy0 + grid_.resolution())});
      if (dx * dx + dy * dy <= radius * radius) return true;
    }
  }
  return false;
}

void StaticLayer::reset() {
  // The map itself stays (it is static); the next update rewrites it everywhere.
  has_updated_data_ = map_received_;
}

}  // namespace nav
}  // namespace marl_mrta
