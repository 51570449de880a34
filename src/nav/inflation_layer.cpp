#include "marl_mrta/nav/inflation_layer.h"

#include <cmath>

#include "marl_mrta/nav/layered_costmap.h"

namespace marl_mrta {
namespace nav {

InflationLayer::InflationLayer(std::string name, const InflationLayerConfig& config)
    : Layer(std::move(name)), config_(config) {}

uint8_t InflationLayer::computeCost(double distance_cells) const {
  if (distance_cells == 0.0) return kLethalObstacle;
  const double distance = distance_cells * resolution_;
  if (distance <= inscribed_radius_) return kInscribedInflated;
  const double factor = std::exp(-config_.cost_scaling_factor * (distance - inscribed_radius_));
  return static_cast<uint8_t>((kInscribedInflated - 1) * factor);
}

void InflationLayer::matchSize(const LayeredCostmap& master) {
  const CostGrid& m = master.costmap();
  size_x_ = m.sizeX();
  resolution_ = m.resolution();
  seen_.assign(static_cast<size_t>(m.sizeX()) * m.sizeY(), 0);
  need_reinflation_ = true;
}

void InflationLayer::onFootprintChanged(const LayeredCostmap& master) {
  inscribed_radius_ = master.inscribedRadius();
  resolution_ = master.costmap().resolution();
  cell_inflation_radius_ = static_cast<unsigned>(std::max(0.0, std::ceil(config_.inflation_radius / resolution_)));
  computeCaches();
  need_reinflation_ = true;
}

void InflationLayer::computeCaches() {
  const unsigned n = cell_inflation_radius_ + 2;
  cached_costs_.assign(static_cast<size_t>(n) * n, 0);
  for (unsigned i = 0; i < n; ++i) {
    for (unsigned j = 0; j < n; ++j) cached_costs_[i * n + j] = computeCost(std::hypot(i, j));
  }
  const unsigned r = cell_inflation_radius_ + 1;
  bins_.assign(2 * r * r + 1, {});
}

void InflationLayer::updateBounds(const Pose2D& /*robot*/, Bounds& bounds) {
  if (need_reinflation_) {
    last_bounds_ = bounds;
    bounds.touch(-1e20, -1e20);
    bounds.touch(1e20, 1e20);
    need_reinflation_ = false;
    return;
  }
  // Cells inflated last time around a vanished obstacle must be recomputed too.
  const Bounds previous = last_bounds_;
  last_bounds_ = bounds;
  if (bounds.empty() && previous.empty()) return;
  if (!previous.empty()) {
    bounds.touch(previous.min_x, previous.min_y);
    bounds.touch(previous.max_x, previous.max_y);
  }
  bounds.min_x -= config_.inflation_radius;
  bounds.min_y -= config_.inflation_radius;
  bounds.max_x += config_.inflation_radius;
  bounds.max_y += config_.inflation_radius;
}

void InflationLayer::enqueue(unsigned index, unsigned x, unsigned y, unsigned src_x, unsigned src_y) {
  if (seen_[index]) return;
  const unsigned dx = x > src_x ? x - src_x : src_x - x;
  const unsigned dy = y > src_y ? y - src_y : src_y - y;
  if (dx > cell_inflation_radius_ || dy > cell_inflation_radius_) return;
  const unsigned sq = dx * dx + dy * dy;
  if (sq > cell_inflation_radius_ * cell_inflation_radius_) return;  // beyond the inflation radius
  bins_[sq].push_back({index, x, y, src_x, src_y});
}

void InflationLayer::updateCosts(CostGrid& master, const CellWindow& window) {
  if (cell_inflation_radius_ == 0) return;
  const unsigned size_x = master.sizeX(), size_y = master.sizeY();
  if (seen_.size() != static_cast<size_t>(size_x) * size_y) seen_.assign(static_cast<size_t>(size_x) * size_y, 0);
  std::fill(seen_.begin(), seen_.end(), 0);
  // Obstacles up to one inflation radius outside the window still reach into it.
  const int r = static_cast<int>(cell_inflation_radius_);
  const int min_x = std::max(0, window.min_x - r), min_y = std::max(0, window.min_y - r);
  const int max_x = std::min(static_cast<int>(size_x), window.max_x + r);
  const int max_y = std::min(static_cast<int>(size_y), window.max_y + r);
  std::vector<uint8_t>& cells = master.cells();
  for (int y = min_y; y < max_y; ++y) {
    for (int x = min_x; x < max_x; ++x) {
      const unsigned index = master.index(x, y);
      if (cells[index] == kLethalObstacle) bins_[0].push_back({index, unsigned(x), unsigned(y), unsigned(x), unsigned(y)});
    }
  }
  const unsigned table = cell_inflation_radius_ + 2;
  for (size_t bin = 0; bin < bins_.size(); ++bin) {
    // Cells appended to later bins while this one is processed keep the distance order.
    for (size_t k = 0; k < bins_[bin].size(); ++k) {
      const CellData cell = bins_[bin][k];
      if (seen_[cell.index]) continue;
      seen_[cell.index] = 1;
      const unsigned dx = cell.x > cell.src_x ? cell.x - cell.src_x : cell.src_x - cell.x;
      const unsigned dy = cell.y > cell.src_y ? cell.y - cell.src_y : cell.src_y - cell.y;
      const uint8_t cost = cached_costs_[dx * table + dy];
      uint8_t& old_cost = cells[cell.index];
      if (old_cost == kNoInformation &&
          (config_.inflate_unknown ? cost > kFreeSpace : cost >= kInscribedInflated)) {
        old_cost = cost;
      } else if (old_cost != kNoInformation || config_.inflate_unknown) {
        old_cost = std::max(old_cost, cost);
      }
      if (cell.x > 0) enqueue(cell.index - 1, cell.x - 1, cell.y, cell.src_x, cell.src_y);
      if (cell.y > 0) enqueue(cell.index - size_x, cell.x, cell.y - 1, cell.src_x, cell.src_y);
      if (cell.x + 1 < size_x) enqueue(cell.index + 1, cell.x + 1, cell.y, cell.src_x, cell.src_y);
      if (cell.y + 1 < size_y) enqueue(cell.index + size_x, cell.x, cell.y + 1, cell.src_x, cell.src_y);
    }
    bins_[bin].clear();
  }
}

}  // namespace nav
}  // namespace marl_mrta
