#include "amcl_ros.h"

#include <geometry_msgs/PoseArray.h>
#include <nav_msgs/GetMap.h>

#include <stdexcept>

#include "marl_mrta/nav/ground_truth_localization.h"
#include "marl_mrta/nav/ros_conversions.h"

namespace marl_mrta {
namespace loc {

namespace conv = nav::ros_conversions;

AmclRos::AmclRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh)
    : nh_(nh), private_nh_(private_nh), tf_listener_(tf_buffer_) {
  config_ = readAmclConfig(nav::ParamNode(conv::parameterTree(private_nh_), private_nh_.getNamespace().substr(1)));
  localizer_ = std::make_unique<Localizer>(config_);

  // Latched, as stock amcl: a late subscriber still gets the last estimate and cloud.
  pose_pub_ = nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("amcl_pose", 2, true);
  cloud_pub_ = nh_.advertise<geometry_msgs::PoseArray>("particlecloud", 2, true);
  global_srv_ = nh_.advertiseService("global_localization", &AmclRos::onGlobalLocalization, this);
  nomotion_srv_ = nh_.advertiseService("request_nomotion_update", &AmclRos::onNoMotionUpdate, this);
  set_map_srv_ = nh_.advertiseService("set_map", &AmclRos::onSetMap, this);
  scan_sub_ = nh_.subscribe("scan", kMaxQueuedScans, &AmclRos::onScan, this, ros::TransportHints().tcpNoDelay());
  initial_pose_sub_ = nh_.subscribe("initialpose", 2, &AmclRos::onInitialPose, this);
  retry_timer_ = nh_.createWallTimer(ros::WallDuration(0.01), [this](const ros::WallTimerEvent&) {
    if (start_to_announce_) announceStart();
    processScans();
  });
  if (config_.use_map_topic) {
    map_sub_ = nh_.subscribe("map", 1, &AmclRos::onMap, this);
    ROS_INFO("amcl: subscribed to the map topic %s", map_sub_.getTopic().c_str());
  } else {
    requestMap();
  }
}

void AmclRos::onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg) {
  if (config_.first_map_only && map_received_) return;
  useMap(*msg);
}

void AmclRos::useMap(const nav_msgs::OccupancyGrid& grid) {
  ROS_INFO("amcl: received a %u x %u map at %.3f m/cell", grid.info.width, grid.info.height, grid.info.resolution);
  if (withoutLeadingSlash(grid.header.frame_id) != config_.global_frame_id) {
    ROS_WARN("amcl: the map's frame '%s' is not global_frame_id '%s'", grid.header.frame_id.c_str(),
             config_.global_frame_id.c_str());
  }
  try {
    localizer_->setMap(conv::toOccupancyMap(grid));
  } catch (const std::exception& error) {
    ROS_ERROR("amcl: map ignored: %s", error.what());
    return;
  }
  if (!map_received_) {
    // The parameters' initial pose can only be checked against the first map: a robot that
    // cannot stand there is a configuration error (stock amcl would start a filter there).
    const Pose2D& start = config_.initial_pose;
    const std::string problem = localizer_->map()->standingProblem(start.x, start.y);
    if (!problem.empty()) {
      const std::string ns = withoutLeadingSlash(private_nh_.getNamespace());
      ROS_FATAL("amcl: %s/initial_pose_x, initial_pose_y: (%.2f, %.2f) %s", ns.c_str(), start.x, start.y,
                problem.c_str());
      failed_ = true;
      ros::shutdown();
      return;
    }
  }
  map_received_ = true;
  if (pending_initial_pose_) {
    const geometry_msgs::PoseWithCovarianceStamped pending = *pending_initial_pose_;
    pending_initial_pose_.reset();
    applyInitialPose(pending);
  }
  announceStart();
}

void AmclRos::requestMap() {
  nav_msgs::GetMap srv;
  ROS_INFO("amcl: requesting the map from %s", ros::names::resolve("static_map").c_str());
  while (ros::ok() && !ros::service::call("static_map", srv)) {
    ROS_WARN_THROTTLE(5.0, "amcl: request for the map failed; trying again...");
    ros::WallDuration(0.5).sleep();
  }
  if (ros::ok()) useMap(srv.response.map);
}

bool AmclRos::initialPose(const geometry_msgs::PoseWithCovarianceStamped& msg, Pose2D& pose,
                          PoseCovariance& covariance) {
  const std::string frame = withoutLeadingSlash(msg.header.frame_id);
  if (frame.empty()) {
    ROS_WARN("amcl: initial pose with an empty frame_id, taken as %s", config_.global_frame_id.c_str());
  } else if (frame != config_.global_frame_id) {
    ROS_WARN("amcl: ignoring an initial pose in frame '%s': it must be in '%s'", frame.c_str(),
             config_.global_frame_id.c_str());
    return false;
  }
  // A pose given for an earlier instant moves on by the odometry since then (stock amcl).
  nav::Transform2D moved_since;
  try {
    const Pose2D then = conv::toPose2D(tf_buffer_.lookupTransform(config_.odom_frame_id, config_.base_frame_id,
                                                                   msg.header.stamp, ros::Duration(0.5)));
    const Pose2D now = conv::toPose2D(tf_buffer_.lookupTransform(config_.odom_frame_id, config_.base_frame_id, ros::Time(0)));
    moved_since = nav::compose(nav::inverse(nav::asTransform(then)), nav::asTransform(now));
  } catch (const tf2::TransformException& error) {
    if (sent_transform_) ROS_WARN("amcl: initial pose taken as it is, odometry since its stamp unknown: %s", error.what());
  }
  const nav::Transform2D given = nav::asTransform(conv::toPose2D(msg.pose.pose));
  const nav::Transform2D result = nav::compose(given, moved_since);
  pose = {result.x, result.y, result.yaw};
  const auto& c = msg.pose.covariance;
  covariance = {c[0], c[1], c[7], c[35]};
  return true;
}

void AmclRos::onInitialPose(const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& msg) {
  if (!localizer_->hasMap()) {
    pending_initial_pose_ = *msg;  // checked and applied when the map arrives
    return;
  }
  applyInitialPose(*msg);
}

void AmclRos::applyInitialPose(const geometry_msgs::PoseWithCovarianceStamped& msg) {
  Pose2D pose;
  PoseCovariance covariance;
  if (!initialPose(msg, pose, covariance)) return;
  // A pose where the robot cannot stand is a mistake of the sender: the filter keeps its estimate.
  const std::string problem = localizer_->map()->standingProblem(pose.x, pose.y);
  if (!problem.empty()) {
    ROS_WARN("amcl: %s: (%.2f, %.2f) %s: ignored", withoutLeadingSlash(initial_pose_sub_.getTopic()).c_str(), pose.x,
             pose.y, problem.c_str());
    return;
  }
  ROS_INFO("amcl: setting the pose to (%.3f, %.3f, %.3f)", pose.x, pose.y, pose.yaw);
  // Scans taken before the pose was given show the robot before it (a reset may have moved it):
  // the first scan of the new start must not be one of them.
  while (!scans_.empty() && scans_.front()->header.stamp < msg.header.stamp) scans_.pop_front();
  localizer_->setInitialPose(pose, covariance);
  announceStart();
}

void AmclRos::announceStart() {
  start_to_announce_ = false;
  if (!localizer_->startMean() || !config_.tf_broadcast) return;
  geometry_msgs::TransformStamped odom;
  try {
    odom = tf_buffer_.lookupTransform(config_.odom_frame_id, config_.base_frame_id, ros::Time(0));
  } catch (const tf2::TransformException&) {
    start_to_announce_ = true;  // no odometry yet
    return;
  }
  const nav::Transform2D map_to_odom =
      nav::mapToOdom(nav::asTransform(*localizer_->startMean()), conv::toPose2D(odom));
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = odom.header.stamp;
  tf.header.frame_id = config_.global_frame_id;
  tf.child_frame_id = config_.odom_frame_id;
  tf.transform.translation.x = map_to_odom.x;
  tf.transform.translation.y = map_to_odom.y;
  tf.transform.rotation = conv::quaternionFromYaw(map_to_odom.yaw);
  tf_broadcaster_.sendTransform(tf);
  sent_transform_ = true;
}

bool AmclRos::onGlobalLocalization(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  ROS_INFO("amcl: spreading the particles uniformly over the free cells");
  localizer_->globalLocalization();
  return true;
}

bool AmclRos::onNoMotionUpdate(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  localizer_->requestNoMotionUpdate();
  return true;
}

bool AmclRos::onSetMap(nav_msgs::SetMap::Request& req, nav_msgs::SetMap::Response& res) {
  Pose2D pose;
  PoseCovariance covariance;
  res.success = false;
  if (!initialPose(req.initial_pose, pose, covariance)) return true;
  ROS_INFO("amcl: new map, setting the pose to (%.3f, %.3f, %.3f)", pose.x, pose.y, pose.yaw);
  try {
    localizer_->setMapAndPose(conv::toOccupancyMap(req.map), pose, covariance);
    map_received_ = true;
    res.success = true;
    announceStart();
  } catch (const std::exception& error) {
    ROS_ERROR("amcl: set_map refused: %s", error.what());
  }
  return true;
}

}  // namespace loc
}  // namespace marl_mrta
