// The hardware stand-in (`simulator` with ~stand_in true, docs/guide/real_robots.md):
// the simulator's World shown to the graph as a fleet of TurtleBot3 Burgers running TurtleBot3's
// bringup (turtlebot3_core + the LDS-01 driver), per robot in its namespace, on wall time.
// No /clock, no ground truth topic, no map -> odom, no services: only what a Burger shows.
#pragma once

#include <ros/ros.h>

#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <geometry_msgs/Twist.h>
#include <sensor_msgs/BatteryState.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/MagneticField.h>
#include <std_msgs/UInt16.h>
#include <tf2_msgs/TFMessage.h>

#include "marl_mrta/sim/lockstep_gate.h"
#include "marl_mrta/sim/sim_config.h"
#include "marl_mrta/sim/sim_messages_ros.h"
#include "marl_mrta/sim/stand_in_config.h"
#include "marl_mrta/sim/world.h"

namespace marl_mrta {
namespace sim {

class StandInRos {
 public:
  // Reads and checks the parameters (SimConfig and StandInConfig from the one private namespace),
  // loads the map, builds the world. Throws nav::ParamError or map::MapError (one line).
  StandInRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh);
  // Runs on wall time until shutdown; returns the exit code.
  int run();

 private:
  struct Burger {
    std::string ns;
    ros::Subscriber cmd_vel_sub;
    ros::Publisher odom_pub, tf_pub, joint_states_pub, imu_pub, mag_pub, battery_pub, scan_pub, rpms_pub;
    RobotMessages msgs;                // odom and scan frames filled once
    tf2_msgs::TFMessage tf;            // <ns>/odom -> <ns>/base_footprint, as turtlebot3_core sends it
    sensor_msgs::JointState joints;
    sensor_msgs::Imu imu;
    sensor_msgs::MagneticField mag;
    sensor_msgs::BatteryState battery;
    double wheel_left = 0.0, wheel_right = 0.0;   // [rad] integrated wheel angles
    double yaw_at_start = 0.0;                     // the IMU's heading counts from power-on
    double last_linear = 0.0;                      // [m/s] for the IMU's acceleration
    sensor_msgs::LaserScan pending_scan;           // cast, not yet published (scan_stamp_lag)
    ros::WallTime scan_due;
    bool scan_pending = false;
  };

  void advertise(ros::NodeHandle& nh);
  void onCmdVel(size_t robot, const geometry_msgs::Twist::ConstPtr& msg);
  void publish(const StepReport& report, bool initial);
  void publishDrive(Burger& burger, const RobotState& state, const ros::Time& now);
  void publishImu(Burger& burger, const RobotState& state, const ros::Time& now);
  void castScan(Burger& burger, const RobotState& state, const ros::WallTime& now);
  void publishDueScans(const ros::WallTime& now);
  void recordGroundTruth(const StepReport& report, const ros::Time& now);

  SimConfig config_;
  StandInConfig stand_in_;
  std::unique_ptr<World> world_;
  std::vector<Burger> burgers_;
  std::unique_ptr<RealTimePacer> pacer_;
  std::ofstream ground_truth_;
  ros::WallTime started_, flushed_;
};

}  // namespace sim
}  // namespace marl_mrta
