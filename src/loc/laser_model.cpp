#include "marl_mrta/loc/laser_model.h"

#include <algorithm>
#include <cmath>

namespace marl_mrta {
namespace loc {

LikelihoodFieldModel::LikelihoodFieldModel(const LaserModelParams& params, const LocalizationMap& map)
    : params_(params), map_(map) {}

bool LikelihoodFieldModel::effectiveRanges(const ScanObservation& scan, double& range_min, double& range_max) const {
  range_max = params_.max_range > 0.0 ? std::min(scan.range_max, params_.max_range) : scan.range_max;
  range_min = params_.min_range > 0.0 ? std::max(scan.range_min, params_.min_range) : scan.range_min;
  return range_max > 0.0 && range_min >= 0.0;
}

std::vector<int> LikelihoodFieldModel::usedBeams(const ScanObservation& scan) const {
  std::vector<int> used;
  double range_min, range_max;
  if (!effectiveRanges(scan, range_min, range_max)) return used;
  const int count = static_cast<int>(scan.ranges.size());
  const int step = params_.max_beams > 1 ? std::max(1, (count - 1) / (params_.max_beams - 1)) : std::max(1, count);
  for (int i = 0; i < count; i += step) {
    const double range = scan.ranges[i];
    // Written so that NaN fails too.
    if (range > range_min && range < range_max) used.push_back(i);
  }
  return used;
}

void LikelihoodFieldModel::prepareScores(double range_max) {
  if (range_max == scores_range_max_) return;
  const double denominator = 2.0 * params_.sigma_hit * params_.sigma_hit;
  const double random_term = params_.z_rand / range_max;
  const auto cube = [](double v) { return v * v * v; };
  const auto score = [&](double d) { return cube(params_.z_hit * std::exp(-(d * d) / denominator) + random_term); };
  const map::OccupancyMap& grid = map_.occupancy();
  cell_score_.resize(static_cast<size_t>(grid.width) * grid.height);
  for (size_t cell = 0; cell < cell_score_.size(); ++cell) cell_score_[cell] = score(map_.obstacleDistance(cell));
  outside_score_ = score(map_.maxObstacleDistance());  // off the map: as far as the field goes
  scores_range_max_ = range_max;
}

bool LikelihoodFieldModel::weigh(const ScanObservation& scan, std::vector<Particle>& particles) {
  double range_min, range_max;
  if (!effectiveRanges(scan, range_min, range_max)) return false;
  prepareScores(range_max);
  beam_x_.clear();
  beam_y_.clear();
  for (int i : usedBeams(scan)) {
    const double bearing = scan.angle_min + i * scan.angle_increment;
    beam_x_.push_back(scan.ranges[i] * std::cos(bearing));
    beam_y_.push_back(scan.ranges[i] * std::sin(bearing));
  }
  const map::OccupancyMap& grid = map_.occupancy();
  for (Particle& particle : particles) {
    const Pose2D& pose = particle.pose;
    const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
    const double laser_x = pose.x + c * scan.laser_x - s * scan.laser_y;
    const double laser_y = pose.y + s * scan.laser_x + c * scan.laser_y;
    double likelihood = 1.0;
    for (size_t b = 0; b < beam_x_.size(); ++b) {
      int cx, cy;
      const bool on_map = grid.worldToCell(laser_x + c * beam_x_[b] - s * beam_y_[b],
                                           laser_y + s * beam_x_[b] + c * beam_y_[b], cx, cy);
      likelihood += on_map ? cell_score_[static_cast<size_t>(cy) * grid.width + cx] : outside_score_;
    }
    particle.weight *= likelihood;
  }
  return true;
}

}  // namespace loc
}  // namespace marl_mrta
