#include "marl_mrta/nav/costmap_grid.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace marl_mrta {
namespace nav {

CostGrid::CostGrid(unsigned size_x, unsigned size_y, double resolution, double origin_x, double origin_y,
                   uint8_t default_value)
    : default_value_(default_value) {
  resize(size_x, size_y, resolution, origin_x, origin_y);
}

void CostGrid::resize(unsigned size_x, unsigned size_y, double resolution, double origin_x, double origin_y) {
  size_x_ = size_x;
  size_y_ = size_y;
  resolution_ = resolution;
  origin_x_ = anchor_x_ = origin_x;
  origin_y_ = anchor_y_ = origin_y;
  cells_moved_x_ = cells_moved_y_ = 0;
  cells_.assign(static_cast<size_t>(size_x) * size_y, default_value_);
}

void CostGrid::resetAll() { std::fill(cells_.begin(), cells_.end(), default_value_); }

void CostGrid::resetRegion(int x0, int y0, int xn, int yn) {
  x0 = std::max(0, x0);
  y0 = std::max(0, y0);
  xn = std::min(static_cast<int>(size_x_), xn);
  yn = std::min(static_cast<int>(size_y_), yn);
  for (int y = y0; y < yn; ++y) {
    std::fill(cells_.begin() + index(x0, y), cells_.begin() + index(x0, y) + std::max(0, xn - x0), default_value_);
  }
}

CellIndex CostGrid::worldToMapNoBounds(double wx, double wy) const {
  return {static_cast<int>(std::floor((wx - origin_x_) / resolution_)),
          static_cast<int>(std::floor((wy - origin_y_) / resolution_))};
}

CellIndex CostGrid::worldToMapEnforceBounds(double wx, double wy) const {
  CellIndex cell = worldToMapNoBounds(wx, wy);
  cell.x = std::min(std::max(cell.x, 0), static_cast<int>(size_x_) - 1);
  cell.y = std::min(std::max(cell.y, 0), static_cast<int>(size_y_) - 1);
  return cell;
}

void CostGrid::mapToWorld(unsigned mx, unsigned my, double& wx, double& wy) const {
  wx = origin_x_ + (mx + 0.5) * resolution_;
  wy = origin_y_ + (my + 0.5) * resolution_;
}

unsigned CostGrid::cellDistance(double world_distance) const {
  return static_cast<unsigned>(std::max(0.0, std::ceil(world_distance / resolution_)));
}

void CostGrid::updateOrigin(double new_origin_x, double new_origin_y) {
  // Whole-cell shift keeps the grid aligned with its previous cells.
  const int shift_x = static_cast<int>((new_origin_x - origin_x_) / resolution_);
  const int shift_y = static_cast<int>((new_origin_y - origin_y_) / resolution_);
  if (shift_x == 0 && shift_y == 0) return;
  const int sx = static_cast<int>(size_x_), sy = static_cast<int>(size_y_);
  std::vector<uint8_t> shifted(cells_.size(), default_value_);
  for (int y = 0; y < sy; ++y) {
    const int old_y = y + shift_y;
    if (old_y < 0 || old_y >= sy) continue;
    for (int x = 0; x < sx; ++x) {
      const int old_x = x + shift_x;
      if (old_x < 0 || old_x >= sx) continue;
      shifted[index(x, y)] = cells_[index(old_x, old_y)];
    }
  }
  cells_.swap(shifted);
  cells_moved_x_ += shift_x;
  cells_moved_y_ += shift_y;
  origin_x_ = anchor_x_ + static_cast<double>(cells_moved_x_) * resolution_;
  origin_y_ = anchor_y_ + static_cast<double>(cells_moved_y_) * resolution_;
}

std::vector<unsigned> CostGrid::polygonOutlineCells(const std::vector<double>& xs,
                                                    const std::vector<double>& ys) const {
  std::vector<unsigned> cells;
  const size_t n = xs.size();
  std::vector<unsigned> mxs(n), mys(n);
  for (size_t i = 0; i < n; ++i) {
    if (!worldToMap(xs[i], ys[i], mxs[i], mys[i])) return {};
  }
  for (size_t i = 0; i < n; ++i) {
    const size_t j = (i + 1) % n;
    raytraceLine([&cells](unsigned idx) { cells.push_back(idx); }, mxs[i], mys[i], mxs[j], mys[j]);
  }
  return cells;
}

std::vector<unsigned> CostGrid::convexFillCells(const std::vector<double>& xs, const std::vector<double>& ys) const {
  if (xs.size() < 3) return {};
  const std::vector<unsigned> outline = polygonOutlineCells(xs, ys);
  if (outline.empty()) return {};
  // Per column, everything between the lowest and highest outline cell is inside.
  std::map<unsigned, std::pair<unsigned, unsigned>> column_span;
  for (unsigned idx : outline) {
    const unsigned x = idx % size_x_, y = idx / size_x_;
    auto it = column_span.find(x);
    if (it == column_span.end()) {
      column_span[x] = {y, y};
    } else {
      it->second.first = std::min(it->second.first, y);
      it->second.second = std::max(it->second.second, y);
    }
  }
  std::vector<unsigned> cells;
  for (const auto& [x, span] : column_span) {
    for (unsigned y = span.first; y <= span.second; ++y) cells.push_back(index(x, y));
  }
  return cells;
}

}  // namespace nav
}  // namespace marl_mrta
