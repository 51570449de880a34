#include "marl_mrta/sim/robot_model.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace marl_mrta {
namespace sim {

double LidarSpec::angleIncrement() const { return 2.0 * M_PI / beams; }

float LidarSpec::noReturnValue() const {
  return invalid_as_inf ? std::numeric_limits<float>::infinity() : 0.0f;
}

float LidarSpec::tooCloseValue() const {
  return invalid_as_inf ? -std::numeric_limits<float>::infinity() : 0.0f;
}

NoiseModel noiseProfile(const std::string& name) {
  NoiseModel noise;
  if (name == "ideal") return noise;
  if (name == "measured_tb3") {
    noise.linear_speed_scale = 0.19 / 0.22;
    noise.command_latency_min = 0.040;
    noise.command_latency_max = 0.070;
    noise.pause_rate = 4.5 / 120.0;  // 3-6 pauses per 120 s episode
    noise.pause_duration_min = 0.5;
    noise.pause_duration_max = 1.2;
    noise.lidar_range_stddev = 0.01;  // LDS-01 datasheet: +-15 mm below 0.5 m
    noise.lidar_dropout_min = 0.02;
    noise.lidar_dropout_max = 0.04;
    noise.odom_translation_stddev = 0.02;
    noise.odom_rotation_stddev = 0.05;
    return noise;
  }
  throw std::invalid_argument("unknown noise profile '" + name + "' (expected ideal or measured_tb3)");
}

std::vector<std::string> noiseProfileNames() { return {"ideal", "measured_tb3"}; }

}  // namespace sim
}  // namespace marl_mrta
