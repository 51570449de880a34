// The master cost grid and its ordered layers (costmap_2d's LayeredCostmap).
#pragma once

#include <memory>
#include <vector>

#include "marl_mrta/nav/layer.h"

namespace marl_mrta {
namespace nav {

class LayeredCostmap {
 public:
  // rolling_window: the grid follows the robot (local costmap). track_unknown_space: cells
  // no layer wrote stay unknown (255) instead of free.
  LayeredCostmap(bool rolling_window, bool track_unknown_space);

  void addLayer(std::unique_ptr<Layer> layer);
  const std::vector<std::unique_ptr<Layer>>& layers() const { return layers_; }
  template <class LayerType>
  std::vector<LayerType*> layersOfType() const {
    std::vector<LayerType*> found;
    for (const auto& layer : layers_) {
      if (auto* typed = dynamic_cast<LayerType*>(layer.get())) found.push_back(typed);
    }
    return found;
  }

  void resizeMap(unsigned size_x, unsigned size_y, double resolution, double origin_x, double origin_y);
  // The padded footprint; recomputes the inscribed/circumscribed radius and tells the layers.
  void setFootprint(const Polygon& footprint);

  // One update: move the window (rolling), collect bounds from every layer, reset the master
  // inside them and let every layer write its costs.
  void updateMap(const Pose2D& robot);
  // Every layer back to its initial state; the next update recomputes everything.
  void resetLayers();

  const CostGrid& costmap() const { return costmap_; }
  CostGrid& costmap() { return costmap_; }
  bool isRolling() const { return rolling_window_; }
  bool isSizeLocked() const { return size_locked_; }
  void setSizeLocked(bool locked) { size_locked_ = locked; }
  bool isCurrent(double now) const;
  bool isInitialized() const { return initialized_; }
  const Polygon& footprint() const { return footprint_; }
  double inscribedRadius() const { return inscribed_radius_; }
  double circumscribedRadius() const { return circumscribed_radius_; }
  // Cells recomputed by the last update (for incremental publishing).
  const CellWindow& lastUpdatedWindow() const { return last_window_; }

 private:
  CostGrid costmap_;
  std::vector<std::unique_ptr<Layer>> layers_;
  bool rolling_window_;
  bool size_locked_ = false;
  bool initialized_ = false;
  Polygon footprint_;
  double inscribed_radius_ = 0.0, circumscribed_radius_ = 0.0;
  CellWindow last_window_;
};

}  // namespace nav
}  // namespace marl_mrta
