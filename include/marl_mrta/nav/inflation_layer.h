// Inflation (costmap_2d's InflationLayer): every lethal cell spreads a cost that decays with
// the distance d to it: 254 at d = 0, 253 while d <= inscribed radius, then
// 252·exp(−cost_scaling_factor·(d − inscribed_radius)) out to inflation_radius; the master
// keeps the maximum. Cells are visited in order of distance to their nearest obstacle.
// Incremental: the layer keeps the inflation field and the costs beneath it, so an update
// re-inflates only around cells that became or stopped being lethal (nothing when none did)
// and rewrites the master where the field changed or the other layers wrote.
#pragma once

#include <cstdint>
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
    uint32_t index, x, y;  // the cell
    int16_t dx, dy;        // from the source it inherits (|dx|, |dy| <= the radius in cells)
  };
  void computeCaches();
  // Recomputes field_ inside `region` from the lethal cells within one radius of it.
  void reinflate(const CellWindow& region, unsigned size_x, unsigned size_y);
  // Master cells of `area` from the costs beneath and the field.
  void combine(std::vector<uint8_t>& master, const CellWindow& area, unsigned size_x) const;

  InflationLayerConfig config_;
  double resolution_ = 0.05;
  double inscribed_radius_ = 0.0;
  unsigned cell_inflation_radius_ = 0;
  unsigned size_x_ = 0;
  bool need_reinflation_ = true;
  double origin_x_ = 0.0, origin_y_ = 0.0;  // of the master when the caches were made
  std::vector<uint8_t> beneath_;  // master costs before inflation
  std::vector<uint8_t> lethal_;   // 1 where beneath_ is lethal
  std::vector<uint8_t> field_;    // inflation cost (0 beyond the radius)
  std::vector<uint8_t> cached_costs_;  // by (|dx|, |dy|), (radius + 2)^2 entries
  // Per cell of reinflate()'s search window: the lowest squared distance it was queued at
  // (the cell is taken from that bin, so later entries at or above it are never queued).
  static constexpr uint32_t kUnqueued = 0xFFFFFFFF;
  std::vector<uint32_t> best_sq_;
  // Bins by squared cell distance: exact distance order without a priority queue.
  std::vector<std::vector<CellData>> bins_;
};

}  // namespace nav
}  // namespace marl_mrta
