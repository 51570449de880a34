#include "marl_mrta/loc/localization_map.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace marl_mrta {
namespace loc {
namespace {

constexpr int8_t kObstacle = 100;  // the only value amcl counts as occupied

// Squared distance transform of one line (Felzenszwalb & Huttenlocher): out[q] =
// min_p (q - p)² + in[p]. `in` holds 0 at obstacles and a large value elsewhere.
void distanceTransform1D(const std::vector<double>& in, std::vector<double>& out, std::vector<int>& v,
                         std::vector<double>& z) {
  const int n = static_cast<int>(in.size());
  const double inf = std::numeric_limits<double>::infinity();
  v.assign(n, 0);
  z.assign(n + 1, 0.0);
  int k = 0;
  z[0] = -inf;
  z[1] = inf;
  const auto intersection = [&](int q, int p) {
    return ((in[q] + q * double(q)) - (in[p] + p * double(p))) / (2.0 * q - 2.0 * p);
  };
  for (int q = 1; q < n; ++q) {
    double s = intersection(q, v[k]);
    while (s <= z[k]) s = intersection(q, v[--k]);  // ends at k = 0 at the latest: z[0] = -inf
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = inf;
  }
  k = 0;
  out.resize(n);
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    out[q] = (q - v[k]) * double(q - v[k]) + in[v[k]];
  }
}

}  // namespace

LocalizationMap::LocalizationMap(const map::OccupancyMap& occupancy, double max_obstacle_distance)
    : occupancy_(occupancy), max_obstacle_distance_(max_obstacle_distance) {
  if (occupancy_.width <= 0 || occupancy_.height <= 0 || !(occupancy_.resolution > 0.0) ||
      occupancy_.data.size() != static_cast<size_t>(occupancy_.width) * occupancy_.height) {
    throw std::invalid_argument("the map is empty or its size does not match its data");
  }
  const int width = occupancy_.width, height = occupancy_.height;
  // Beyond this (in cells²) the exact value does not matter: it is capped anyway.
  const double cap_cells = max_obstacle_distance_ / occupancy_.resolution + 2.0;
  const double far = cap_cells * cap_cells + static_cast<double>(width) * width + static_cast<double>(height) * height;
  std::vector<double> squared(static_cast<size_t>(width) * height);
  for (size_t i = 0; i < squared.size(); ++i) squared[i] = occupancy_.data[i] == kObstacle ? 0.0 : far;
  std::vector<double> line, result;
  std::vector<int> v;
  std::vector<double> z;
  for (int y = 0; y < height; ++y) {  // along x
    line.assign(squared.begin() + static_cast<long>(y) * width, squared.begin() + static_cast<long>(y + 1) * width);
    distanceTransform1D(line, result, v, z);
    std::copy(result.begin(), result.end(), squared.begin() + static_cast<long>(y) * width);
  }
  line.resize(height);
  for (int x = 0; x < width; ++x) {  // then along y
    for (int y = 0; y < height; ++y) line[y] = squared[static_cast<size_t>(y) * width + x];
    distanceTransform1D(line, result, v, z);
    for (int y = 0; y < height; ++y) squared[static_cast<size_t>(y) * width + x] = result[y];
  }
  distance_.resize(squared.size());
  for (size_t i = 0; i < squared.size(); ++i) {
    distance_[i] = static_cast<float>(std::min(max_obstacle_distance_, std::sqrt(squared[i]) * occupancy_.resolution));
    if (occupancy_.data[i] == map::OccupancyMap::kFree) free_cells_.push_back(i);
  }
}

double LocalizationMap::obstacleDistanceAt(double wx, double wy) const {
  int cx, cy;
  if (!occupancy_.worldToCell(wx, wy, cx, cy)) return max_obstacle_distance_;
  return distance_[static_cast<size_t>(cy) * occupancy_.width + cx];
}

std::string LocalizationMap::standingProblem(double wx, double wy) const {
  int cx, cy;
  if (!occupancy_.worldToCell(wx, wy, cx, cy)) {
    double x0, y0, x1, y1;  // the outer corners of the grid (an unrotated map: its usual case)
    occupancy_.cellToWorld(0, 0, x0, y0);
    occupancy_.cellToWorld(occupancy_.width - 1, occupancy_.height - 1, x1, y1);
    const double half = occupancy_.resolution / 2.0;
    char bounds[160];
    std::snprintf(bounds, sizeof bounds, "is off the map (x in [%.2f, %.2f], y in [%.2f, %.2f])", x0 - half, x1 + half,
                  y0 - half, y1 + half);
    return bounds;
  }
  const int8_t value = occupancy_.at(cx, cy);
  if (value == kObstacle) return "is inside an obstacle of the map";
  if (value != map::OccupancyMap::kFree) return "is on an unknown cell of the map";
  return "";
}

nav::Pose2D LocalizationMap::randomFreePose(RandomSource& rng) const {
  if (free_cells_.empty()) throw std::logic_error("the map has no free cell to place a particle in");
  const size_t cell = free_cells_[rng.index(free_cells_.size())];
  const int cx = static_cast<int>(cell % occupancy_.width), cy = static_cast<int>(cell / occupancy_.width);
  double wx, wy;
  occupancy_.cellToWorld(cx, cy, wx, wy);
  // Anywhere in the cell, not only its centre (amcl's), so that poses are not on a lattice.
  const double c = std::cos(occupancy_.origin_yaw), s = std::sin(occupancy_.origin_yaw);
  const double du = (rng.uniform() - 0.5) * occupancy_.resolution, dv = (rng.uniform() - 0.5) * occupancy_.resolution;
  const double yaw = (2.0 * rng.uniform() - 1.0) * M_PI;
  return {wx + c * du - s * dv, wy + s * du + c * dv, yaw};
}

}  // namespace loc
}  // namespace marl_mrta
