#include "marl_mrta/sim/obstacle_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace marl_mrta {
namespace sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kFar = 1e20;  // "no obstacle" in the squared distance transform

// Felzenszwalb & Huttenlocher's 1D squared Euclidean distance transform of `f` (stride `stride`).
void distanceTransform1d(double* f, int n, int stride, std::vector<double>& d, std::vector<int>& v,
                         std::vector<double>& z) {
  int k = 0;
  v[0] = 0;
  z[0] = -kInf;
  z[1] = kInf;
  for (int q = 1; q < n; ++q) {
    const double fq = f[q * stride] + double(q) * q;
    double s = (fq - (f[v[k] * stride] + double(v[k]) * v[k])) / (2.0 * q - 2.0 * v[k]);
    while (s <= z[k]) {
      --k;
      s = (fq - (f[v[k] * stride] + double(v[k]) * v[k])) / (2.0 * q - 2.0 * v[k]);
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = kInf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    d[q] = double(q - v[k]) * (q - v[k]) + f[v[k] * stride];
  }
  for (int q = 0; q < n; ++q) f[q * stride] = d[q];
}

}  // namespace

ObstacleGrid::ObstacleGrid(const map::OccupancyMap& map)
    : width_(map.width),
      height_(map.height),
      resolution_(map.resolution),
      inv_resolution_(1.0 / map.resolution),
      origin_x_(map.origin_x),
      origin_y_(map.origin_y),
      cos_yaw_(std::cos(map.origin_yaw)),
      sin_yaw_(std::sin(map.origin_yaw)) {
  const size_t cells = static_cast<size_t>(width_) * height_;
  occupied_.assign(cells, 0);
  known_free_.assign(cells, 0);
  for (size_t i = 0; i < cells; ++i) {
    const int8_t value = map.data[i];
    occupied_[i] = isObstacle(value);
    known_free_[i] = value >= 0 && value < 100;
  }

  // The distance between the centres of cell c and of a cell of the obstacles dilated by one
  // cell (8-neighbourhood) equals the smallest distance between any point of c and any point
  // of an obstacle cell: the per-cell jump length that can never skip an obstacle.
  std::vector<double> field(cells, kFar);
  for (int cy = 0; cy < height_; ++cy) {
    for (int cx = 0; cx < width_; ++cx) {
      if (!occupied_[index(cx, cy)]) continue;
      for (int ny = std::max(0, cy - 1); ny <= std::min(height_ - 1, cy + 1); ++ny) {
        for (int nx = std::max(0, cx - 1); nx <= std::min(width_ - 1, cx + 1); ++nx) field[index(nx, ny)] = 0.0;
      }
    }
  }
  const int longest = std::max(width_, height_);
  std::vector<double> d(longest);
  std::vector<int> v(longest);
  std::vector<double> z(longest + 1);
  for (int cx = 0; cx < width_; ++cx) distanceTransform1d(&field[cx], height_, width_, d, v, z);
  for (int cy = 0; cy < height_; ++cy) distanceTransform1d(&field[index(0, cy)], width_, 1, d, v, z);
  free_radius_.resize(cells);
  for (size_t i = 0; i < cells; ++i) {
    free_radius_[i] = field[i] >= kFar / 2 ? 1e9f : static_cast<float>(std::sqrt(field[i]));
  }
}

double ObstacleGrid::clearance(double x, double y, double limit, Point2D* nearest) const {
  double gx, gy;
  toGrid(x, y, gx, gy);
  const double limit_cells = limit * inv_resolution_;
  const int cx = static_cast<int>(std::floor(gx));
  const int cy = static_cast<int>(std::floor(gy));
  if (cx >= 0 && cy >= 0 && cx < width_ && cy < height_ && free_radius_[index(cx, cy)] >= limit_cells) {
    return limit;
  }
  // Cells more than floor(limit) + 1 cells away are farther than the limit.
  const int reach = static_cast<int>(limit_cells) + 1;
  double best_sq = limit_cells * limit_cells;
  double best_gx = 0.0, best_gy = 0.0;
  bool found = false;
  for (int ny = std::max(0, cy - reach); ny <= std::min(height_ - 1, cy + reach); ++ny) {
    for (int nx = std::max(0, cx - reach); nx <= std::min(width_ - 1, cx + reach); ++nx) {
      if (!occupied_[index(nx, ny)]) continue;
      // Closest point of the cell square [nx, nx+1] x [ny, ny+1].
      const double px = std::min(std::max(gx, double(nx)), double(nx + 1));
      const double py = std::min(std::max(gy, double(ny)), double(ny + 1));
      const double distance_sq = (gx - px) * (gx - px) + (gy - py) * (gy - py);
      if (distance_sq < best_sq) {
        best_sq = distance_sq;
        best_gx = px;
        best_gy = py;
        found = true;
      }
    }
  }
  if (!found) return limit;
  if (nearest) toWorld(best_gx, best_gy, nearest->x, nearest->y);
  return std::sqrt(best_sq) * resolution_;
}

bool ObstacleGrid::isKnownFree(double x, double y) const {
  double gx, gy;
  toGrid(x, y, gx, gy);
  if (!(gx >= 0.0 && gy >= 0.0 && gx < width_ && gy < height_)) return false;
  return known_free_[index(static_cast<int>(gx), static_cast<int>(gy))];
}

}  // namespace sim
}  // namespace marl_mrta
