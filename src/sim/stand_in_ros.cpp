#include "marl_mrta/sim/stand_in_ros.h"

#include <ros/callback_queue.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/ros_conversions.h"
#include "marl_mrta/publish_shared.h"

namespace marl_mrta {
namespace sim {

namespace {

// Further behind real time than this [wall s], pacing starts afresh rather than racing.
constexpr double kMaxPacingLag = 0.5;
constexpr double kGravity = 9.80665;  // [m/s^2] what the IMU's accelerometer reads at rest
// The Earth's field as a magnetometer in the lab might read it [T]: horizontal along the map's x.
constexpr double kFieldHorizontal = 2.0e-5, kFieldVertical = -4.5e-5;
// turtlebot3_core's covariances (Turtlebot3Sensor::getIMU).
constexpr double kOrientationVariance = 0.0025, kGyroVariance = 0.02, kAccelVariance = 0.04;
// The LDS-01 reports an intensity with every return; the simulator has no surfaces to take it from.
constexpr float kReturnIntensity = 1000.0f;
constexpr double kDesignCapacity = 1.8;   // [Ah] turtlebot3_core's BatteryState.design_capacity
constexpr double kNominalVoltage = 11.1;  // [V] turtlebot3_core's percentage = voltage / 11.1
constexpr double kFlushPeriod = 1.0;      // [wall s] ground truth file flushes

void throwWithPrefix(const std::string& prefix, const nav::ParamError& e) {
  throw nav::ParamError(prefix + e.where(), e.problem());
}

}  // namespace

StandInRos::StandInRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh) {
  const std::string prefix = private_nh.getNamespace() + "/";
  if (ros::Time::isSimTime()) {
    throw nav::ParamError("/use_sim_time", "must be false for the stand-in (a robot's clock is the wall clock)");
  }
  const nav::ParamNode params(nav::ros_conversions::parameterTree(private_nh), private_nh.getNamespace());
  stand_in_ = readStandInConfig(params);  // first: its keys are then known to readSimConfig
  config_ = readSimConfig(params);
  WorldConfig world_config;
  try {
    checkStandIn(stand_in_, config_);
    world_config = makeWorldConfig(config_);
  } catch (const nav::ParamError& e) {
    throwWithPrefix(prefix, e);
  }
  const map::OccupancyMap map = map::loadMap(config_.map_file);
  try {
    world_ = std::make_unique<World>(map, world_config);
  } catch (const nav::ParamError& e) {
    throwWithPrefix(prefix, e);
  }
  if (!stand_in_.ground_truth_file.empty()) {
    ground_truth_.open(stand_in_.ground_truth_file);
    if (!ground_truth_) throw nav::ParamError(prefix + "ground_truth_file", "cannot write " + stand_in_.ground_truth_file);
    ground_truth_ << "kind,stamp,robot,x,y,yaw,linear,angular,other\n";
  }
  advertise(nh);
  pacer_ = std::make_unique<RealTimePacer>(config_.physics_rate, 1.0, kMaxPacingLag);
  std::string names;
  for (const Burger& burger : burgers_) names += (names.empty() ? "" : ", ") + burger.ns;
  ROS_INFO("stand-in: TurtleBot3 Burger%s %s on %s, wall time, noise %s; physics %g Hz, odom %g Hz, scans %g Hz",
           burgers_.size() > 1 ? "s" : "", names.c_str(), config_.map_file.c_str(), config_.noise_profile.c_str(),
           config_.physics_rate, config_.odom_rate, config_.scan_rate);
}

void StandInRos::advertise(ros::NodeHandle& nh) {
  const std::vector<std::string> names = robotNamespaces(config_);
  burgers_.resize(names.size());
  const LidarSpec& lidar = world_->config().robot.lidar;
  for (size_t g = 0; g < burgers_.size(); ++g) {
    Burger& burger = burgers_[g];
    burger.ns = names[g];
    const std::string base = "/" + burger.ns + "/";
    burger.cmd_vel_sub = nh.subscribe<geometry_msgs::Twist>(
        base + "cmd_vel", 10,
        boost::function<void(const geometry_msgs::Twist::ConstPtr&)>(
            [this, g](const geometry_msgs::Twist::ConstPtr& msg) { onCmdVel(g, msg); }),
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
    burger.odom_pub = nh.advertise<nav_msgs::Odometry>(base + "odom", 10);
    burger.tf_pub = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
    burger.joint_states_pub = nh.advertise<sensor_msgs::JointState>(base + "joint_states", 10);
    burger.imu_pub = nh.advertise<sensor_msgs::Imu>(base + "imu", 10);
    burger.mag_pub = nh.advertise<sensor_msgs::MagneticField>(base + "magnetic_field", 10);
    burger.battery_pub = nh.advertise<sensor_msgs::BatteryState>(base + "battery_state", 10);
    burger.scan_pub = nh.advertise<sensor_msgs::LaserScan>(base + "scan", 10);
    burger.rpms_pub = nh.advertise<std_msgs::UInt16>(base + "rpms", 10);

    // turtlebot3_core with tf_prefix = multi_robot_name: <ns>/odom -> <ns>/base_footprint,
    // imu <ns>/imu_link, magnetic field <ns>/mag_link, joint states <ns>/base_link.
    burger.msgs = robotMessages(burger.ns, lidar, config_.scan_rate);
    burger.tf.transforms.resize(1);
    burger.tf.transforms[0].header.frame_id = burger.msgs.odom.header.frame_id;
    burger.tf.transforms[0].child_frame_id = burger.msgs.odom.child_frame_id;
    burger.joints.header.frame_id = burger.ns + "/base_link";
    burger.joints.name = {"wheel_left_joint", "wheel_right_joint"};
    burger.joints.position.assign(2, 0.0);
    burger.joints.velocity.assign(2, 0.0);
    burger.joints.effort.assign(2, 0.0);
    burger.imu.header.frame_id = burger.ns + "/imu_link";
    for (int i : {0, 4, 8}) {
      burger.imu.orientation_covariance[i] = kOrientationVariance;
      burger.imu.angular_velocity_covariance[i] = kGyroVariance;
      burger.imu.linear_acceleration_covariance[i] = kAccelVariance;
    }
    burger.mag.header.frame_id = burger.ns + "/mag_link";
    burger.battery.design_capacity = kDesignCapacity;
    burger.battery.present = true;
    burger.yaw_at_start = world_->robot(static_cast<int>(g)).pose.yaw;

    // The LDS-01 driver's scan header: a full turn from 0 (its angle_max is 2 pi), 0.12-3.5 m,
    // the time between readings from the motor speed as the driver computes it (motor_speed /
    // good_sets / 1e8: the raw speed, rpm x 10, over 1e8), scan_time left 0, intensities given.
    sensor_msgs::LaserScan& scan = burger.msgs.scan;
    scan.angle_min = 0.0;
    scan.angle_increment = 2.0 * M_PI / lidar.beams;
    scan.angle_max = 2.0 * M_PI;
    scan.time_increment = stand_in_.lds_rpm * 10.0 / 1e8;
    scan.scan_time = 0.0;
  }
}

void StandInRos::onCmdVel(size_t robot, const geometry_msgs::Twist::ConstPtr& msg) {
  // World::setCommand clamps to the firmware's limits (0.22 m/s, 2.84 rad/s) and its watchdog
  // stops the wheels cmd_vel_timeout (turtlebot3_core: 0.5 s) after the last command.
  if (!world_->setCommand(static_cast<int>(robot), {msg->linear.x, msg->angular.z})) {
    ROS_WARN_THROTTLE(5.0, "%s/cmd_vel: command with a non-finite value ignored", burgers_[robot].ns.c_str());
  }
}

void StandInRos::publishDrive(Burger& burger, const RobotState& state, const ros::Time& now) {
  fillOdometry(burger.msgs.odom, now, state.odom_pose, state.velocity);
  publishShared(burger.odom_pub, burger.msgs.odom);
  fillTransform(burger.tf.transforms[0], now, state.odom_pose);
  publishShared(burger.tf_pub, burger.tf);
  const double dt = 1.0 / config_.odom_rate;
  const double half_track = 0.5 * stand_in_.wheel_separation;
  const double left = (state.velocity.linear - state.velocity.angular * half_track) / stand_in_.wheel_radius;
  const double right = (state.velocity.linear + state.velocity.angular * half_track) / stand_in_.wheel_radius;
  burger.wheel_left += left * dt;
  burger.wheel_right += right * dt;
  burger.joints.header.stamp = now;
  burger.joints.position = {burger.wheel_left, burger.wheel_right};
  burger.joints.velocity = {left, right};
  publishShared(burger.joint_states_pub, burger.joints);
  const double hours = (ros::WallTime::now() - started_).toSec() / 3600.0;
  burger.battery.header.stamp = now;
  burger.battery.voltage = static_cast<float>(std::max(0.0, stand_in_.battery_voltage - stand_in_.battery_drain * hours));
  burger.battery.percentage = static_cast<float>(burger.battery.voltage / kNominalVoltage);
  publishShared(burger.battery_pub, burger.battery);
}

void StandInRos::publishImu(Burger& burger, const RobotState& state, const ros::Time& now) {
  const double heading = normalizeAngle(state.pose.yaw - burger.yaw_at_start);
  const double dt = 1.0 / stand_in_.imu_rate;
  burger.imu.header.stamp = now;
  burger.imu.orientation = yawQuaternion(heading);
  burger.imu.angular_velocity.z = state.velocity.angular;
  burger.imu.linear_acceleration.x = (state.velocity.linear - burger.last_linear) / dt;
  burger.imu.linear_acceleration.y = state.velocity.linear * state.velocity.angular;
  burger.imu.linear_acceleration.z = kGravity;
  burger.last_linear = state.velocity.linear;
  publishShared(burger.imu_pub, burger.imu);
  burger.mag.header.stamp = now;
  burger.mag.magnetic_field.x = kFieldHorizontal * std::cos(state.pose.yaw);
  burger.mag.magnetic_field.y = -kFieldHorizontal * std::sin(state.pose.yaw);
  burger.mag.magnetic_field.z = kFieldVertical;
  publishShared(burger.mag_pub, burger.mag);
}

void StandInRos::castScan(Burger& burger, const RobotState& state, const ros::WallTime& now) {
  sensor_msgs::LaserScan& scan = burger.pending_scan;
  scan = burger.msgs.scan;
  scan.ranges = state.scan;
  scan.intensities.assign(scan.ranges.size(), 0.0f);
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    if (scan.ranges[i] > 0.0f) scan.intensities[i] = kReturnIntensity;
  }
  burger.scan_due = now + ros::WallDuration(stand_in_.scan_stamp_lag);
  burger.scan_pending = true;
}

void StandInRos::publishDueScans(const ros::WallTime& now) {
  for (Burger& burger : burgers_) {
    if (!burger.scan_pending || now < burger.scan_due) continue;
    burger.pending_scan.header.stamp = ros::Time::now();  // the driver stamps the turn when it has read it
    publishShared(burger.scan_pub, burger.pending_scan);
    std_msgs::UInt16 rpms;
    rpms.data = static_cast<uint16_t>(std::lround(stand_in_.lds_rpm));
    burger.rpms_pub.publish(rpms);
    burger.scan_pending = false;
  }
}

void StandInRos::recordGroundTruth(const StepReport& report, const ros::Time& now) {
  if (!ground_truth_.is_open()) return;
  char line[256];
  if (report.odom_due) {
    for (size_t g = 0; g < burgers_.size(); ++g) {
      const RobotState& state = world_->robot(static_cast<int>(g));
      std::snprintf(line, sizeof(line), "pose,%.6f,%s,%.6f,%.6f,%.6f,%.4f,%.4f,\n", now.toSec(), burgers_[g].ns.c_str(),
                    state.pose.x, state.pose.y, state.pose.yaw, state.velocity.linear, state.velocity.angular);
      ground_truth_ << line;
    }
  }
  for (const CollisionEvent& event : report.collisions) {
    const std::string other = event.other_robot == CollisionEvent::kWall ? "wall" : burgers_[event.other_robot].ns;
    std::snprintf(line, sizeof(line), "contact,%.6f,%s,%.6f,%.6f,,,,%s\n", now.toSec(), burgers_[event.robot].ns.c_str(),
                  event.contact.x, event.contact.y, other.c_str());
    ground_truth_ << line;
  }
  const ros::WallTime wall = ros::WallTime::now();
  if ((wall - flushed_).toSec() >= kFlushPeriod) {
    ground_truth_.flush();
    flushed_ = wall;
  }
}

void StandInRos::publish(const StepReport& report, bool initial) {
  const ros::Time now = ros::Time::now();
  const ros::WallTime wall = ros::WallTime::now();
  const bool imu_due = initial || World::due(world_->tick(), stand_in_.imu_rate, config_.physics_rate);
  for (size_t g = 0; g < burgers_.size(); ++g) {
    Burger& burger = burgers_[g];
    const RobotState& state = world_->robot(static_cast<int>(g));
    if (initial || report.odom_due) publishDrive(burger, state, now);
    if (imu_due) publishImu(burger, state, now);
    if (config_.scan_rate > 0.0 && (initial || report.scan_updated)) castScan(burger, state, wall);
  }
  StepReport truth = report;
  truth.odom_due = initial || report.odom_due;
  recordGroundTruth(truth, now);
}

int StandInRos::run() {
  started_ = flushed_ = ros::WallTime::now();
  ros::CallbackQueue& queue = *ros::getGlobalCallbackQueue();
  publish(StepReport{}, true);
  while (ros::ok()) {
    queue.callAvailable();
    const ros::WallTime now = ros::WallTime::now();
    publishDueScans(now);
    const double wait = pacer_->waitBeforeStep(now.toSec(), world_->tick());
    if (wait > 0.0) {
      queue.callAvailable(ros::WallDuration(std::min(wait, 0.002)));
      continue;
    }
    publish(world_->step(), false);
  }
  if (ground_truth_.is_open()) ground_truth_.flush();
  return 0;
}

}  // namespace sim
}  // namespace marl_mrta
