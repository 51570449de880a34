// The hardware stand-in's own settings (docs/guide/real_robots.md): which Burgers
// this process plays, how its messages are timed like TurtleBot3's bringup, where the ground
// truth goes (a file, never a topic). ROS-free: read from the same parameter tree as SimConfig.
#pragma once

#include <string>
#include <vector>

#include "marl_mrta/nav/param_tree.h"
#include "marl_mrta/sim/sim_config.h"

namespace marl_mrta {
namespace sim {

struct StandInConfig {
  bool enabled = false;                  // ~stand_in (the robots: SimConfig::robot_names)
  double imu_rate = 200.0;               // [Hz] imu, magnetic_field (turtlebot3_core's IMU_PUBLISH_FREQUENCY)
  // [s] a scan is published, and stamped, this long after the instant its ranges show: the
  // LDS-01 driver (hls_lfcd_lds_driver 1.1) stamps a rotation when it has read all of it, and
  // the simulator casts a rotation's rays at one instant, its middle.
  double scan_stamp_lag = 0.1;
  double lds_rpm = 300.0;                // LDS-01 motor speed: rpms topic, time_increment
  double wheel_radius = 0.033;           // [m] joint_states (config/robot_burger.yaml)
  double wheel_separation = 0.160;       // [m]
  double battery_voltage = 12.0;         // [V] at start (3S LiPo, 11.1 V nominal)
  double battery_drain = 0.5;            // [V/h] while the node runs
  std::string ground_truth_file;         // CSV of true poses and contacts ("": none)
};

// A list of robot names, or one string of names separated by spaces or commas (a launch
// argument); `default_value` when the key is absent. Shared with readSimConfig (lockstep_robots).
std::vector<std::string> readNameList(const nav::ParamNode& params, const std::string& key,
                                      const std::vector<std::string>& default_value);

// Reads the stand-in's keys of `params` (marking them read, so that readSimConfig on the same
// tree does not take them for unknown ones). Throws nav::ParamError naming the parameter.
StandInConfig readStandInConfig(const nav::ParamNode& params);

// Checks the stand-in against the simulator settings it runs with and fills in what follows from
// them (the robot count from robot_names). Throws nav::ParamError naming the parameter.
void checkStandIn(StandInConfig& stand_in, SimConfig& config);

}  // namespace sim
}  // namespace marl_mrta
