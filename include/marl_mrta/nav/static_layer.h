// The static map as costs (costmap_2d's StaticLayer): occupied -> lethal, unknown -> 255 or
// free, the rest free (trinary) or scaled. In a non-rolling costmap it sizes the master grid.
#pragma once

#include <cstdint>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/layered_costmap.h"

namespace marl_mrta {
namespace nav {

struct StaticLayerConfig {
  std::string map_topic = "map";
  bool first_map_only = false;
  bool subscribe_to_updates = false;
  bool track_unknown_space = true;
  bool use_maximum = false;
  int unknown_cost_value = -1;
  bool trinary_costmap = true;
  int lethal_cost_threshold = 100;
};

class StaticLayer : public Layer {
 public:
  StaticLayer(std::string name, const StaticLayerConfig& config, LayeredCostmap& master);

  // A new map (nav_msgs/OccupancyGrid values). Ignored after the first when first_map_only.
  void setMap(const map::OccupancyMap& occupancy);
  bool hasMap() const { return map_received_; }
  const StaticLayerConfig& config() const { return config_; }
  // True when a lethal map cell lies within `radius` of (wx, wy) (no map: false).
  bool lethalWithin(double wx, double wy, double radius) const;
  // OccupancyGrid value -> cost.
  uint8_t interpretValue(int8_t value) const;

  void updateBounds(const Pose2D& robot, Bounds& bounds) override;
  void updateCosts(CostGrid& master, const CellWindow& window) override;
  void reset() override;

 private:
  StaticLayerConfig config_;
  LayeredCostmap& master_;
  CostGrid grid_;
  bool map_received_ = false;
  bool has_updated_data_ = false;
};

}  // namespace nav
}  // namespace marl_mrta
