// One stage of a layered costmap (costmap_2d's Layer): it first widens the area that needs
// recomputing this cycle (updateBounds), then writes its costs into the master grid inside
// that area (updateCosts). The orchestrator is LayeredCostmap.
#pragma once

#include <algorithm>
#include <string>

#include "marl_mrta/nav/costmap_grid.h"
#include "marl_mrta/nav/footprint.h"

namespace marl_mrta {
namespace nav {

class LayeredCostmap;

// An axis-aligned area in world coordinates; empty until touched.
struct Bounds {
  double min_x = 1e30, min_y = 1e30, max_x = -1e30, max_y = -1e30;
  void touch(double x, double y) {
    min_x = std::min(min_x, x);
    min_y = std::min(min_y, y);
    max_x = std::max(max_x, x);
    max_y = std::max(max_y, y);
  }
  bool empty() const { return min_x > max_x || min_y > max_y; }
};

// A cell window [min_x, max_x) x [min_y, max_y).
struct CellWindow {
  int min_x = 0, min_y = 0, max_x = 0, max_y = 0;
  bool empty() const { return max_x <= min_x || max_y <= min_y; }
};

class Layer {
 public:
  explicit Layer(std::string name) : name_(std::move(name)) {}
  virtual ~Layer() = default;
  const std::string& name() const { return name_; }

  // Called by LayeredCostmap when added and whenever the master grid is resized.
  virtual void matchSize(const LayeredCostmap& /*master*/) {}
  // Called when the robot footprint changes (inscribed/circumscribed radius).
  virtual void onFootprintChanged(const LayeredCostmap& /*master*/) {}
  virtual void updateBounds(const Pose2D& robot, Bounds& bounds) = 0;
  virtual void updateCosts(CostGrid& master, const CellWindow& window) = 0;
  // Back to the state right after construction (data forgotten, configuration kept).
  virtual void reset() {}
  // False when the layer's input is older than it should be (observation sources).
  virtual bool isCurrent(double /*now*/) const { return true; }

 private:
  std::string name_;
};

}  // namespace nav
}  // namespace marl_mrta
