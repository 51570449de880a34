// The built-in amcl node: stock amcl's interface around one loc::Localizer.
//   in:  scan (sensor_msgs/LaserScan), initialpose (PoseWithCovarianceStamped), map (topic with
//        ~use_map_topic, else the static_map service), odometry as tf <odom_frame_id> -> <base_frame_id>
//   out: amcl_pose (PoseWithCovarianceStamped), particlecloud (PoseArray), tf <global_frame_id> ->
//        <odom_frame_id> stamped scan stamp + transform_tolerance
//   services: global_localization, request_nomotion_update (std_srvs/Empty), set_map (nav_msgs/SetMap)
// Scans are taken strictly in stamp order, each once the odometry of its stamp is in tf.
#pragma once

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/SetMap.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_srvs/Empty.h>
#include <tf2/LinearMath/Quaternion.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "marl_mrta/loc/localizer.h"

namespace marl_mrta {
namespace loc {

class AmclRos {
 public:
  static constexpr size_t kMaxQueuedScans = 100;  // as stock amcl's message filter

  // Reads and checks the private namespace first: throws nav::ParamError naming a bad parameter.
  AmclRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh);
  // The node has shut ROS down on a configuration error it found after start (the initial pose
  // of the parameters off the first map or where the robot cannot stand): exit non-zero.
  bool failed() const { return failed_; }

 private:
  // amcl_ros.cpp: the map, the initial pose and the services.
  void onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg);
  void useMap(const nav_msgs::OccupancyGrid& grid);
  void requestMap();
  void onInitialPose(const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& msg);
  // An initial pose with the map known: refused with a warning where the robot cannot stand.
  void applyInitialPose(const geometry_msgs::PoseWithCovarianceStamped& msg);
  // The pose of a PoseWithCovarianceStamped, moved by the odometry since its stamp; false when
  // the frame is not the global one.
  bool initialPose(const geometry_msgs::PoseWithCovarianceStamped& msg, Pose2D& pose, PoseCovariance& covariance);
  // map -> odom from the mean the filter (re)started around and the latest odometry, stamped at that
  // odometry: until the first scan is taken, lookups from that instant on succeed (the transforms of
  // scans are stamped transform_tolerance later, and a lock-step move_base waits for map -> odom at
  // each tick). Retried by the timer until odometry is there.
  void announceStart();
  bool onGlobalLocalization(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  bool onNoMotionUpdate(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  bool onSetMap(nav_msgs::SetMap::Request& req, nav_msgs::SetMap::Response& res);

  // amcl_scans.cpp: scans in stamp order, and what the filter makes of them.
  void onScan(const sensor_msgs::LaserScan::ConstPtr& msg);
  void processScans();
  bool observation(const sensor_msgs::LaserScan& scan, ScanObservation& out);
  void publish(const ScanOutcome& outcome, const ros::Time& stamp);
  void savePose(const ros::Time& now);

  ros::NodeHandle nh_, private_nh_;
  std::unique_ptr<Localizer> localizer_;
  AmclConfig config_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Publisher pose_pub_, cloud_pub_;
  ros::Subscriber scan_sub_, initial_pose_sub_, map_sub_;
  ros::ServiceServer global_srv_, nomotion_srv_, set_map_srv_;
  ros::WallTimer retry_timer_;  // takes queued scans once their odometry has arrived
  bool map_received_ = false;
  bool sent_transform_ = false;
  bool start_to_announce_ = false;
  bool failed_ = false;
  std::optional<geometry_msgs::PoseWithCovarianceStamped> pending_initial_pose_;  // came before the map

  std::deque<sensor_msgs::LaserScan::ConstPtr> scans_;  // waiting, oldest stamp first
  ros::Time last_scan_stamp_;                          // of the latest scan taken
  // The laser's pose in the base frame, per scan frame (a fixed mount: looked up once).
  struct LaserMount {
    double x = 0.0, y = 0.0;    // [m]
    tf2::Quaternion rotation;   // laser frame -> base frame (amcl turns the beam angles with it)
  };
  std::map<std::string, LaserMount> mounts_;
  ros::Time last_cloud_stamp_, last_save_stamp_;
};

}  // namespace loc
}  // namespace marl_mrta
