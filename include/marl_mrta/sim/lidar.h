// The 360-beam LDS-01: exact ranges against the static map and the robots' circles, then the
// sensor's noise, dropout and invalid-reading encoding.
#pragma once

#include <vector>

#include "marl_mrta/sim/geometry.h"
#include "marl_mrta/sim/random.h"
#include "marl_mrta/sim/robot_model.h"
#include "marl_mrta/sim/scan_caster.h"

namespace marl_mrta {
namespace sim {

struct Circle {
  double x = 0.0;
  double y = 0.0;
  double radius = 0.0;
};

// Distance along the unit direction (dir_x, dir_y) from (x, y) to the circle, +inf if missed;
// 0 when (x, y) lies inside it.
double rayCircleDistance(double x, double y, double dir_x, double dir_y, const Circle& circle);

class Lidar {
 public:
  explicit Lidar(const LidarSpec& spec);

  const LidarSpec& spec() const { return spec_; }
  Pose2D sensorPose(const Pose2D& robot_pose) const;

  // ranges[i] (resized to the beam count): distance [m] from the sensor of a robot at
  // robot_pose to the first occupied cell or circle along beam i; +inf when nothing lies
  // within range_max. Circles are the other robots (never the robot itself).
  void castExact(const ScanCaster& map, const Pose2D& robot_pose, const std::vector<Circle>& circles,
                 std::vector<float>& ranges) const;

  // In place: drops each reading with probability `dropout`, adds N(0, stddev) to the others,
  // and encodes readings outside [range_min, range_max] as the spec's no-return values.
  void applyNoiseAndEncode(std::vector<float>& ranges, double stddev, double dropout, Rng& rng) const;

 private:
  LidarSpec spec_;
  BeamFan fan_;
  std::vector<double> beam_cos_, beam_sin_;  // beam directions in the sensor frame
};

}  // namespace sim
}  // namespace marl_mrta
