#include "marl_mrta/nav/inflation_layer.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

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
  // The area the other layers rewrite is enough: updateCosts rewrites where the field changes.
  if (!need_reinflation_) return;
  bounds.touch(-1e20, -1e20);
  bounds.touch(1e20, 1e20);
}

void InflationLayer::reinflate(const CellWindow& region, unsigned size_x, unsigned size_y) {
  // Obstacles up to one inflation radius outside the region still reach into it: the search
  // window is the region widened by the radius.
  const int r = static_cast<int>(cell_inflation_radius_);
  const int min_x = std::max(0, region.min_x - r), min_y = std::max(0, region.min_y - r);
  const int max_x = std::min(static_cast<int>(size_x), region.max_x + r);
  const int max_y = std::min(static_cast<int>(size_y), region.max_y + r);
  for (int y = region.min_y; y < region.max_y; ++y) {
    const unsigned row = static_cast<unsigned>(y) * size_x;
    std::fill(field_.begin() + row + region.min_x, field_.begin() + row + region.max_x, 0);
  }
  const auto inside = [&](int x, int y) {
    return x >= region.min_x && x < region.max_x && y >= region.min_y && y < region.max_y;
  };
  for (int y = min_y; y < max_y; ++y) {
    const unsigned row = static_cast<unsigned>(y) * size_x;
    std::fill(best_sq_.begin() + row + min_x, best_sq_.begin() + row + max_x, kUnqueued);
  }
  for (int y = min_y; y < max_y; ++y) {
    const unsigned row = static_cast<unsigned>(y) * size_x;
    for (int x = min_x; x < max_x; ++x) {
      const unsigned index = row + x;
      if (!lethal_[index]) continue;
      best_sq_[index] = 0;
      // A source whose neighbours in the window are all sources spreads nothing: its own cost
      // is all it gives.
      const bool spreads = (x > min_x && !lethal_[index - 1]) || (x + 1 < max_x && !lethal_[index + 1]) ||
                           (y > min_y && !lethal_[index - size_x]) || (y + 1 < max_y && !lethal_[index + size_x]);
      if (spreads) {
        bins_[0].push_back({index, uint32_t(x), uint32_t(y), 0, 0});
      } else if (inside(x, y)) {
        field_[index] = kLethalObstacle;
      }
    }
  }
  const unsigned table = cell_inflation_radius_ + 2;
  const int radius = r, radius_sq = r * r;
  // Raw pointers: the queues' growth cannot move these arrays, so they need no reloading.
  uint32_t* const best_sq = best_sq_.data();
  uint8_t* const field = field_.data();
  const uint8_t* const costs_by_offset = cached_costs_.data();
  std::vector<CellData>* const bins = bins_.data();
  const size_t n_bins = bins_.size();
  unsigned bin = 0;
  // Cells are taken bin by bin (squared distance to the source they inherit), each bin in the
  // order it was filled; a cell takes its first entry in the lowest bin. So an entry that
  // cannot come first is never queued: one at or above the cell's best queued distance, or
  // one below the bin being taken (costmap_2d drops those as well).
  auto enqueue = [&](unsigned index, int x, int y, int dx, int dy) {
    if (dx > radius || dx < -radius || dy > radius || dy < -radius) return;
    const unsigned sq = static_cast<unsigned>(dx * dx + dy * dy);
    if (sq > static_cast<unsigned>(radius_sq) || sq >= best_sq[index] || sq < bin) return;
    best_sq[index] = sq;
    bins[sq].push_back({index, uint32_t(x), uint32_t(y), int16_t(dx), int16_t(dy)});
  };
  for (; bin < n_bins; ++bin) {
    // Cells appended to this bin while it is taken keep the distance order.
    std::vector<CellData>& queue = bins[bin];
    for (size_t k = 0; k < queue.size(); ++k) {
      const CellData cell = queue[k];
      if (best_sq[cell.index] != bin) continue;  // the cell has an entry in a lower bin
      const int x = cell.x, y = cell.y, dx = cell.dx, dy = cell.dy;
      if (inside(x, y)) field[cell.index] = costs_by_offset[std::abs(dx) * table + std::abs(dy)];
      if (x > min_x) enqueue(cell.index - 1, x - 1, y, dx - 1, dy);
      if (y > min_y) enqueue(cell.index - size_x, x, y - 1, dx, dy - 1);
      if (x + 1 < max_x) enqueue(cell.index + 1, x + 1, y, dx + 1, dy);
      if (y + 1 < max_y) enqueue(cell.index + size_x, x, y + 1, dx, dy + 1);
    }
    queue.clear();
  }
}

void InflationLayer::combine(std::vector<uint8_t>& master, const CellWindow& area, unsigned size_x) const {
  for (int y = area.min_y; y < area.max_y; ++y) {
    for (unsigned i = static_cast<unsigned>(y) * size_x + area.min_x, end = i + (area.max_x - area.min_x); i < end;
         ++i) {
      const uint8_t below = beneath_[i], cost = field_[i];
      if (below == kNoInformation) {
        // Unknown space stays unknown unless inflation says more (costmap_2d's rule).
        master[i] = (config_.inflate_unknown ? cost > kFreeSpace : cost >= kInscribedInflated) ? cost : below;
      } else {
        master[i] = std::max(below, cost);
      }
    }
  }
}

void InflationLayer::updateCosts(CostGrid& master, const CellWindow& window) {
  if (cell_inflation_radius_ == 0) return;
  const unsigned size_x = master.sizeX(), size_y = master.sizeY();
  const size_t cells = static_cast<size_t>(size_x) * size_y;
  // A moved (rolling) or resized grid invalidates what is kept: everything is recomputed.
  const bool full = need_reinflation_ || beneath_.size() != cells || master.originX() != origin_x_ ||
                    master.originY() != origin_y_;
  need_reinflation_ = false;
  std::vector<uint8_t>& costs = master.cells();
  CellWindow changed{static_cast<int>(size_x), static_cast<int>(size_y), 0, 0};
  if (full) {
    best_sq_.assign(cells, kUnqueued);
    // Outside the window the master holds last update's result: the best guess of what is beneath.
    beneath_ = costs;
    lethal_.assign(cells, 0);
    field_.assign(cells, 0);
    for (size_t i = 0; i < cells; ++i) lethal_[i] = beneath_[i] == kLethalObstacle;
    origin_x_ = master.originX();
    origin_y_ = master.originY();
    changed = CellWindow{0, 0, static_cast<int>(size_x), static_cast<int>(size_y)};
  } else {
    for (int y = window.min_y; y < window.max_y; ++y) {
      for (int x = window.min_x; x < window.max_x; ++x) {
        const unsigned i = static_cast<unsigned>(y) * size_x + x;
        const uint8_t value = costs[i];
        beneath_[i] = value;
        const uint8_t lethal = value == kLethalObstacle;
        if (lethal == lethal_[i]) continue;
        lethal_[i] = lethal;
        changed.min_x = std::min(changed.min_x, x);
        changed.min_y = std::min(changed.min_y, y);
        changed.max_x = std::max(changed.max_x, x + 1);
        changed.max_y = std::max(changed.max_y, y + 1);
      }
    }
  }
  if (!changed.empty()) {
    // The field changes only within one inflation radius of a cell whose lethality changed.
    const int r = static_cast<int>(cell_inflation_radius_);
    const CellWindow region{std::max(0, changed.min_x - r), std::max(0, changed.min_y - r),
                            std::min(static_cast<int>(size_x), changed.max_x + r),
                            std::min(static_cast<int>(size_y), changed.max_y + r)};
    reinflate(region, size_x, size_y);
    combine(costs, region, size_x);
  }
  combine(costs, window, size_x);
}

}  // namespace nav
}  // namespace marl_mrta
