#include "marl_mrta/nav/layered_costmap.h"

#include <cmath>

namespace marl_mrta {
namespace nav {

LayeredCostmap::LayeredCostmap(bool rolling_window, bool track_unknown_space) : rolling_window_(rolling_window) {
  costmap_.setDefaultValue(track_unknown_space ? kNoInformation : kFreeSpace);
}

void LayeredCostmap::addLayer(std::unique_ptr<Layer> layer) {
  layer->matchSize(*this);
  layer->onFootprintChanged(*this);
  layers_.push_back(std::move(layer));
}

void LayeredCostmap::resizeMap(unsigned size_x, unsigned size_y, double resolution, double origin_x,
                               double origin_y) {
  costmap_.resize(size_x, size_y, resolution, origin_x, origin_y);
  for (auto& layer : layers_) layer->matchSize(*this);
  // Radii in cells depend on the resolution.
  for (auto& layer : layers_) layer->onFootprintChanged(*this);
}

void LayeredCostmap::setFootprint(const Polygon& footprint) {
  footprint_ = footprint;
  inscribed_radius_ = nav::inscribedRadius(footprint);
  circumscribed_radius_ = nav::circumscribedRadius(footprint);
  for (auto& layer : layers_) layer->onFootprintChanged(*this);
}

void LayeredCostmap::updateMap(const Pose2D& robot) {
  if (rolling_window_) {
    costmap_.centreWindowOn(robot.x, robot.y);
  }
  last_window_ = CellWindow{};
  if (layers_.empty() || costmap_.sizeX() == 0 || costmap_.sizeY() == 0) return;
  Bounds bounds;
  for (auto& layer : layers_) layer->updateBounds(robot, bounds);
  if (bounds.empty()) {
    initialized_ = true;
    return;
  }
  // Clamp before converting: untouched sides hold +-1e30.
  const double lo_x = std::max(bounds.min_x, costmap_.originX() - 1.0);
  const double lo_y = std::max(bounds.min_y, costmap_.originY() - 1.0);
  const double hi_x = std::min(bounds.max_x, costmap_.originX() + costmap_.sizeMetersX() + 1.0);
  const double hi_y = std::min(bounds.max_y, costmap_.originY() + costmap_.sizeMetersY() + 1.0);
  const CellIndex lo = costmap_.worldToMapEnforceBounds(lo_x, lo_y);
  const CellIndex hi = costmap_.worldToMapEnforceBounds(hi_x, hi_y);
  CellWindow window{std::max(0, lo.x), std::max(0, lo.y), std::min(static_cast<int>(costmap_.sizeX()), hi.x + 1),
                    std::min(static_cast<int>(costmap_.sizeY()), hi.y + 1)};
  if (window.empty()) {
    initialized_ = true;
    return;
  }
  costmap_.resetRegion(window.min_x, window.min_y, window.max_x, window.max_y);
  for (auto& layer : layers_) layer->updateCosts(costmap_, window);
  last_window_ = window;
  initialized_ = true;
}

void LayeredCostmap::resetLayers() {
  costmap_.resetAll();
  for (auto& layer : layers_) layer->reset();
}

bool LayeredCostmap::isCurrent(double now) const {
  for (const auto& layer : layers_) {
    if (!layer->isCurrent(now)) return false;
  }
  return true;
}

}  // namespace nav
}  // namespace marl_mrta
