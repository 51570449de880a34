// The move_base node's ROS interface around one MoveBaseCore: the move_base action,
// move_base_simple/goal, cmd_vel, odom and scan inputs, tf lookups, plan/costmap topics,
// ~make_plan and ~clear_costmaps, and the simulator's lock-step (ack every SimTick).
// Inputs, ticks and the control step: move_base_inputs.cpp; the rest: move_base_ros.cpp;
// tf: transform_source.h; as a nodelet: move_base_nodelet.cpp.
#pragma once

#include <actionlib/server/simple_action_server.h>
#include <geometry_msgs/PoseStamped.h>
#include <move_base_msgs/MoveBaseAction.h>
#include <nav_msgs/GetPlan.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_srvs/Empty.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <marl_mrta/LockstepAck.h>
#include <marl_mrta/SimTick.h>

#include "marl_mrta/nav/move_base_core.h"
#include "transform_source.h"

namespace marl_mrta {
namespace nav {

class MoveBaseRos {
 public:
  // Reads and checks every parameter (throws ParamError, one line), warns about unknown ones.
  MoveBaseRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh);
  ~MoveBaseRos();

 private:
  // Which obstacle layer source a scan topic feeds.
  struct ScanTarget {
    LayeredCostmap* costmap;
    ObstacleLayer* layer;
    size_t source;
    std::string frame;        // the costmap's global frame
    std::string sensor_frame;  // "" = the scan's own frame
  };
  struct ScanInput {
    std::string topic;
    ros::Subscriber sub;
    std::vector<ScanTarget> targets;
  };

  void onGoal();
  void onPreempt();
  // Before sending a goal's result: the tick the lock-step answers report it ended on.
  void endGoal();
  void onSimpleGoal(const geometry_msgs::PoseStamped::ConstPtr& msg);
  void onOdom(const nav_msgs::Odometry::ConstPtr& msg);
  void onScan(size_t input, const sensor_msgs::LaserScan::ConstPtr& msg);
  void onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg);
  void onTick(const marl_mrta::SimTick::ConstPtr& msg);
  void onTimer(const ros::TimerEvent& event);
  bool onMakePlan(nav_msgs::GetPlan::Request& req, nav_msgs::GetPlan::Response& res);
  bool onClearCostmaps(std_srvs::Empty::Request& req, std_srvs::Empty::Response& res);

  void processTicks();
  // One controller period at `stamp` (tf lookups at `lookup_time`).
  void controlStep(const ros::Time& stamp, const ros::Time& lookup_time);
  bool lookupPose(const std::string& target, const std::string& source, const ros::Time& time, Pose2D& pose,
                  std::string& error);
  void insertScans(const ros::Time& lookup_limit);
  bool pollUntil(const std::function<bool()>& done) const;
  void waitForClock(const ros::Time& stamp) const;
  void publishCommand(const Velocity2D& command);
  void publishOutputs(const CycleOutput& out, const Pose2D& pose, const ros::Time& stamp);
  void publishCostmaps(double now, const ros::Time& stamp);
  void publishDwaClouds(const CycleOutput& out, const ros::Time& stamp);
  double nowSeconds() const;
  void writeStats() const;
  // A warning at most once per `period` s of wall time for each `key`, for this robot alone:
  // ROS_WARN_THROTTLE throttles per line of code, which the move_bases of one nodelet manager
  // share, so one robot's warning would hide another's.
  void warnThrottled(const std::string& key, double period, const std::string& text) const;

  ros::NodeHandle nh_, private_nh_;
  std::unique_ptr<MoveBaseCore> core_;
  std::unique_ptr<TransformSource> tf_source_;
  tf2_ros::Buffer& tf_buffer_;
  actionlib::SimpleActionServer<move_base_msgs::MoveBaseAction> action_server_;
  ros::Publisher cmd_vel_pub_, current_goal_pub_, plan_pub_, local_plan_pub_, global_plan_pub_;
  ros::Publisher global_costmap_pub_, local_costmap_pub_, action_goal_pub_, ack_pub_;
  ros::Publisher trajectory_cloud_pub_, cost_cloud_pub_;  // DWA's publish_traj_pc, publish_cost_grid_pc
  ros::Subscriber simple_goal_sub_, odom_sub_, map_sub_, tick_sub_;
  ros::ServiceServer make_plan_srv_, clear_costmaps_srv_;
  ros::Timer control_timer_;
  std::vector<ScanInput> scan_inputs_;
  std::deque<std::pair<size_t, sensor_msgs::LaserScan::ConstPtr>> pending_scans_;
  nav_msgs::Odometry::ConstPtr last_odom_;
  std::deque<std::pair<marl_mrta::SimTick, ros::WallTime>> pending_ticks_;  // tick, arrival
  ros::WallTimer wait_timer_;
  ros::Time last_scan_stamp_, last_tick_time_;
  marl_mrta::LockstepAck ack_;

  std::string global_frame_, local_frame_, global_base_frame_, local_base_frame_;
  std::string robot_name_, stats_file_;
  std::string log_name_;  // "tb3_0/move_base": every log line says which robot's move_base it is
  mutable std::map<std::string, ros::WallTime> last_warned_;
  bool lockstep_ = false;
  double control_period_ = 0.1;
  int64_t last_control_period_ = -1;
  double next_global_publish_ = 0.0, next_local_publish_ = 0.0;
  int64_t last_acked_tick_ = -1;
  int64_t tick_in_progress_ = -1;  // the tick whose control step runs (-1: none)
  uint64_t goal_end_tick_ = 0;     // LockstepAck.goal_end_tick
  uint32_t cmd_vel_count_ = 0;
  double tf_wait_ = 2.0;
  // Inputs of a tick not there yet when needed (~stats_file): how often, and wall time waited.
  mutable uint64_t input_waits_ = 0;
  mutable double input_wait_seconds_ = 0.0;
  bool have_map_ = false;
};

}  // namespace nav
}  // namespace marl_mrta
