#include "marl_mrta/sim/lidar.h"

#include <cmath>
#include <limits>

namespace marl_mrta {
namespace sim {

double rayCircleDistance(double x, double y, double dir_x, double dir_y, const Circle& circle) {
  const double mx = x - circle.x, my = y - circle.y;
  const double c = mx * mx + my * my - circle.radius * circle.radius;
  if (c <= 0.0) return 0.0;
  const double b = mx * dir_x + my * dir_y;
  if (b > 0.0) return std::numeric_limits<double>::infinity();  // outside and pointing away
  const double discriminant = b * b - c;
  if (discriminant < 0.0) return std::numeric_limits<double>::infinity();
  return -b - std::sqrt(discriminant);
}

Lidar::Lidar(const LidarSpec& spec) : spec_(spec) {
  fan_.count = spec_.beams;
  fan_.angle_min = spec_.angle_min;
  fan_.increment = spec_.angleIncrement();
  beam_cos_.resize(spec_.beams);
  beam_sin_.resize(spec_.beams);
  for (int i = 0; i < spec_.beams; ++i) {
    const double angle = spec_.angle_min + i * spec_.angleIncrement();
    beam_cos_[i] = std::cos(angle);
    beam_sin_[i] = std::sin(angle);
  }
}

Pose2D Lidar::sensorPose(const Pose2D& robot_pose) const {
  const double c = std::cos(robot_pose.yaw), s = std::sin(robot_pose.yaw);
  return {robot_pose.x + c * spec_.mount_x - s * spec_.mount_y, robot_pose.y + s * spec_.mount_x + c * spec_.mount_y,
          robot_pose.yaw};
}

void Lidar::castExact(const ScanCaster& map, const Pose2D& robot_pose, const std::vector<Circle>& circles,
                      std::vector<float>& ranges) const {
  const int beams = spec_.beams;
  ranges.resize(beams);
  const Pose2D sensor = sensorPose(robot_pose);
  map.cast(sensor, fan_, spec_.range_max, ranges.data());
  const double c = std::cos(sensor.yaw), s = std::sin(sensor.yaw);
  // Robots: only the beams inside each circle's angular extent are tested.
  const double increment = spec_.angleIncrement();
  for (const Circle& circle : circles) {
    const double dx = circle.x - sensor.x, dy = circle.y - sensor.y;
    const double centre_distance = std::hypot(dx, dy);
    if (centre_distance - circle.radius > spec_.range_max) continue;
    int first = 0, last = beams - 1;
    if (centre_distance > circle.radius) {
      const double half_width = std::asin(circle.radius / centre_distance);
      const double bearing = std::atan2(dy, dx) - sensor.yaw - spec_.angle_min;
      first = static_cast<int>(std::floor((bearing - half_width) / increment));
      last = static_cast<int>(std::ceil((bearing + half_width) / increment));
    }
    for (int k = first; k <= last; ++k) {
      const int i = ((k % beams) + beams) % beams;
      const double dir_x = c * beam_cos_[i] - s * beam_sin_[i];
      const double dir_y = s * beam_cos_[i] + c * beam_sin_[i];
      const double distance = rayCircleDistance(sensor.x, sensor.y, dir_x, dir_y, circle);
      if (distance <= spec_.range_max && distance < ranges[i]) ranges[i] = static_cast<float>(distance);
    }
  }
}

void Lidar::applyNoiseAndEncode(std::vector<float>& ranges, double stddev, double dropout, Rng& rng) const {
  const float no_return = spec_.noReturnValue();
  const float too_close = spec_.tooCloseValue();
  if (stddev <= 0.0 && dropout <= 0.0) {  // the ideal sensor: encoding only
    const auto range_min = static_cast<float>(spec_.range_min), range_max = static_cast<float>(spec_.range_max);
    for (float& range : ranges) {
      if (range < range_min) {
        range = too_close;
      } else if (!(range <= range_max)) {  // beyond range, or +inf: nothing seen
        range = no_return;
      }
    }
    return;
  }
  for (float& range : ranges) {
    if (dropout > 0.0 && rng.uniform() < dropout) {
      range = no_return;
      continue;
    }
    if (!std::isfinite(range)) {
      range = no_return;
      continue;
    }
    double value = range;
    if (stddev > 0.0) value += stddev * rng.normal();
    if (value < spec_.range_min) {
      range = too_close;
    } else if (value > spec_.range_max) {
      range = no_return;
    } else {
      range = static_cast<float>(value);
    }
  }
}

}  // namespace sim
}  // namespace marl_mrta
