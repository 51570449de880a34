// Inflation (costmap_2d's InflationLayer): every lethal cell spreads a cost that decays with
// the distance d to it: 254 at d = 0, 253 while d <= inscribed radius, then
// 252·exp(−cost_scaling_factor·(d − inscribed_radius)) out to inflation_radius; the master
// keeps the maximum. Cells are visited in order of distance to their nearest obstacle.
#pragma once

#include <vector>

#include "marl_mrta/nav/layer.h"

namespace marl_mrta {
namespace nav {

struct InflationLayerConfig {
  double inflation_radius = 0.55;     // [m]
  double cost_scaling_factor = 10.0;  // [1/m]
  bool inflate_unknown = false;
};

class InflationLayer : public Layer {
 public:
  InflationLayer(std::string name, const InflationLayerConfig& config);

  const InflationLayerConfig& config() const { return config_; }
  // Cost at a distance given in cells (the formula above).
  uint8_t computeCost(double distance_cells) const;
  double inscribedRadius() const { return inscribed_radius_; }

  void matchSize(const LayeredCostmap& master) override;
  void onFootprintChanged(const LayeredCostmap& master) override;
  void updateBounds(const Pose2D& robot, Bounds& bounds) override;
  void updateCosts(CostGrid& master, const CellWindow& window) override;
  void reset() override { need_reinflation_ = true; }

 private:
  struct CellData {
    unsigned index, x, y, src_x, src_y;
  };
  void computeCaches();
  void enqueue(unsigned index, unsigned x, unsigned y, unsigned src_x, unsigned src_y);

  InflationLayerConfig config_;
  double resolution_ = 0.05;
  double inscribed_radius_ = 0.0;
  unsigned cell_inflation_radius_ = 0;
  unsigned size_x_ = 0;
  bool need_reinflation_ = true;
  Bounds last_bounds_;
  std::vector<uint8_t> cached_costs_;  // by (|dx|, |dy|), (radius + 2)^2 entries
  std::vector<char> seen_;
  // Bins by squared cell distance: exact distance order without a priority queue.
  std::vector<std::vector<CellData>> bins_;
};

}  // namespace nav
}  // namespace marl_mrta
