// What the simulator knows about a TurtleBot3 Burger: collision circle, drive limits, LDS-01
// lidar (the defaults are config/robot_burger.yaml's values), and the noise a real one shows
// (the profiles of config/noise_profiles.yaml).
#pragma once

namespace marl_mrta {
namespace sim {

struct DriveLimits {
  double max_linear_velocity = 0.22;      // [m/s]   TB3 Burger
  double max_angular_velocity = 2.84;     // [rad/s] TB3 Burger
  double max_linear_acceleration = 2.5;   // [m/s^2]   TB3's DWA acc_lim_x
  double max_angular_acceleration = 3.2;  // [rad/s^2] TB3's DWA acc_lim_theta
};

// LDS-01: readings counter-clockwise from angle_min over a full turn.
struct LidarSpec {
  int beams = 360;
  double range_min = 0.12;  // [m]
  double range_max = 3.5;   // [m]
  double angle_min = 0.0;   // [rad] in the sensor frame
  double mount_x = -0.032;  // [m] base_scan in base_footprint (TB3 Burger URDF)
  double mount_y = 0.0;
  // No return: 0 like the real driver, or +inf (-inf when too close) per REP 117.
  bool invalid_as_inf = false;

  double angleIncrement() const;
  float noReturnValue() const;
  float tooCloseValue() const;
};

struct RobotSpec {
  double radius = 0.105;  // [m] collision circle
  DriveLimits limits;
  LidarSpec lidar;
};

// Differences between a real robot and the ideal model. All zero / one in the ideal profile.
// config/noise_profiles.yaml gives them as linear_speed_scale, command_latency [min, max],
// pause_rate, pause_duration [min, max], lidar_range_stddev, lidar_dropout [min, max],
// odom_translation_stddev, odom_rotation_stddev.
struct NoiseModel {
  double linear_speed_scale = 1.0;     // achieved / commanded linear velocity
  double command_latency_min = 0.0;    // [s] delay before a command reaches the wheels,
  double command_latency_max = 0.0;    //     drawn per command in [min, max]
  double pause_rate = 0.0;             // [1/s] rate of spontaneous stops while driving
  double pause_duration_min = 0.0;     // [s]
  double pause_duration_max = 0.0;     // [s]
  double lidar_range_stddev = 0.0;     // [m] Gaussian noise on each valid reading
  double lidar_dropout_min = 0.0;      // probability that a reading is lost,
  double lidar_dropout_max = 0.0;      //     drawn per scan in [min, max]
  double odom_translation_stddev = 0.0;  // relative error of each step's distance
  double odom_rotation_stddev = 0.0;     // relative error of each step's rotation
};

}  // namespace sim
}  // namespace marl_mrta
