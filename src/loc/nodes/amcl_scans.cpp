// The built-in amcl's scan input (in stamp order, each with the odometry of its stamp) and its
// outputs: particle cloud, pose estimate, map -> odom, and the saved pose.
#include <geometry_msgs/PoseArray.h>
#include <tf2/utils.h>

#include <algorithm>
#include <cmath>

#include "amcl_ros.h"
#include "marl_mrta/nav/ros_conversions.h"

namespace marl_mrta {
namespace loc {

namespace conv = nav::ros_conversions;

void AmclRos::onScan(const sensor_msgs::LaserScan::ConstPtr& msg) {
  if (!last_scan_stamp_.isZero() && msg->header.stamp <= last_scan_stamp_) {
    ROS_WARN_THROTTLE(5.0, "amcl: dropped a scan stamped %.3f, not after the last one taken (%.3f)",
                      msg->header.stamp.toSec(), last_scan_stamp_.toSec());
    return;
  }
  const auto later = std::upper_bound(scans_.begin(), scans_.end(), msg->header.stamp,
                                      [](const ros::Time& stamp, const auto& scan) { return stamp < scan->header.stamp; });
  scans_.insert(later, msg);
  if (scans_.size() > kMaxQueuedScans) {
    ROS_WARN_THROTTLE(5.0, "amcl: no odometry (%s -> %s) for the scan stamped %.3f: dropped", config_.odom_frame_id.c_str(),
                      config_.base_frame_id.c_str(), scans_.front()->header.stamp.toSec());
    scans_.pop_front();
  }
  processScans();
}

void AmclRos::processScans() {
  while (!scans_.empty()) {
    const sensor_msgs::LaserScan::ConstPtr scan = scans_.front();
    const ros::Time stamp = scan->header.stamp;
    // Wait for odometry newer than the scan: tf2 hands out its newest transform as stored, an older
    // one interpolated (to within a rounding), and the odometry a scan is taken with must not
    // depend on whether the next transform had arrived when it was looked up.
    ros::Time latest;
    try {
      latest = tf_buffer_.lookupTransform(config_.odom_frame_id, config_.base_frame_id, ros::Time(0)).header.stamp;
    } catch (const tf2::TransformException&) {
      return;  // no odometry yet
    }
    if (latest <= stamp) return;
    if (!tf_buffer_.canTransform(config_.odom_frame_id, config_.base_frame_id, stamp)) {
      ROS_WARN_THROTTLE(5.0, "amcl: no odometry at the stamp %.3f of a scan (older than tf keeps): dropped", stamp.toSec());
      scans_.pop_front();
      continue;
    }
    scans_.pop_front();
    last_scan_stamp_ = stamp;
    if (!localizer_->hasMap()) continue;  // as stock amcl: nothing to do before the map
    ScanObservation scan_in_base;
    if (!observation(*scan, scan_in_base)) continue;
    const Pose2D odom =
        conv::toPose2D(tf_buffer_.lookupTransform(config_.odom_frame_id, config_.base_frame_id, stamp));
    const ScanOutcome outcome = localizer_->processScan(scan_in_base, odom);
    if (!outcome.ignored_because.empty()) ROS_WARN_THROTTLE(5.0, "amcl: scan ignored: %s", outcome.ignored_because.c_str());
    publish(outcome, stamp);
    savePose(stamp);
  }
}

bool AmclRos::observation(const sensor_msgs::LaserScan& scan, ScanObservation& out) {
  const std::string frame = withoutLeadingSlash(scan.header.frame_id);
  auto mount = mounts_.find(frame);
  if (mount == mounts_.end()) {
    try {
      const geometry_msgs::TransformStamped t = tf_buffer_.lookupTransform(config_.base_frame_id, frame, ros::Time(0));
      LaserMount found;
      found.x = t.transform.translation.x;
      found.y = t.transform.translation.y;
      tf2::fromMsg(t.transform.rotation, found.rotation);
      mount = mounts_.emplace(frame, found).first;
      ROS_INFO("amcl: laser %s at (%.3f, %.3f) in %s", frame.c_str(), found.x, found.y, config_.base_frame_id.c_str());
    } catch (const tf2::TransformException& error) {
      ROS_WARN_THROTTLE(5.0, "amcl: scan dropped, no transform %s -> %s: %s", config_.base_frame_id.c_str(), frame.c_str(),
                        error.what());
      return false;
    }
  }
  // The beams' bearings in the base frame (a laser mounted upside down counts them the other way).
  tf2::Quaternion first, second;
  first.setRPY(0.0, 0.0, scan.angle_min);
  second.setRPY(0.0, 0.0, scan.angle_min + scan.angle_increment);
  out.angle_min = tf2::getYaw(mount->second.rotation * first);
  out.angle_increment = std::fmod(tf2::getYaw(mount->second.rotation * second) - out.angle_min + 5.0 * M_PI, 2.0 * M_PI) - M_PI;
  out.laser_x = mount->second.x;
  out.laser_y = mount->second.y;
  out.range_min = scan.range_min;
  out.range_max = scan.range_max;
  out.ranges = scan.ranges;
  return true;
}

void AmclRos::publish(const ScanOutcome& outcome, const ros::Time& stamp) {
  const bool cloud_due = config_.gui_publish_rate <= 0.0 || last_cloud_stamp_.isZero() ||
                         (stamp - last_cloud_stamp_).toSec() >= 1.0 / config_.gui_publish_rate;
  if (outcome.used && cloud_due) {
    geometry_msgs::PoseArray cloud;
    cloud.header.stamp = stamp;
    cloud.header.frame_id = config_.global_frame_id;
    cloud.poses.resize(localizer_->filter().particles().size());
    for (size_t i = 0; i < cloud.poses.size(); ++i) {
      const Pose2D& pose = localizer_->filter().particles()[i].pose;
      cloud.poses[i].position.x = pose.x;
      cloud.poses[i].position.y = pose.y;
      cloud.poses[i].orientation = conv::quaternionFromYaw(pose.yaw);
    }
    cloud_pub_.publish(cloud);
    last_cloud_stamp_ = stamp;
  }
  if (outcome.new_estimate) {
    geometry_msgs::PoseWithCovarianceStamped pose;
    pose.header.stamp = stamp;
    pose.header.frame_id = config_.global_frame_id;
    pose.pose.pose.position.x = outcome.estimate.pose.x;
    pose.pose.pose.position.y = outcome.estimate.pose.y;
    pose.pose.pose.orientation = conv::quaternionFromYaw(outcome.estimate.pose.yaw);
    const PoseCovariance& c = outcome.estimate.covariance;
    pose.pose.covariance[0] = c.xx;
    pose.pose.covariance[1] = pose.pose.covariance[6] = c.xy;
    pose.pose.covariance[7] = c.yy;
    pose.pose.covariance[35] = c.aa;
    pose_pub_.publish(pose);
  }
  if (outcome.map_to_odom && config_.tf_broadcast) {
    // Valid a little into the future, so that lookups at the latest odometry succeed.
    geometry_msgs::TransformStamped tf;
    tf.header.stamp = stamp + ros::Duration(config_.transform_tolerance);
    tf.header.frame_id = config_.global_frame_id;
    tf.child_frame_id = config_.odom_frame_id;
    tf.transform.translation.x = outcome.map_to_odom->x;
    tf.transform.translation.y = outcome.map_to_odom->y;
    tf.transform.rotation = conv::quaternionFromYaw(outcome.map_to_odom->yaw);
    tf_broadcaster_.sendTransform(tf);
    sent_transform_ = true;
  }
}

void AmclRos::savePose(const ros::Time& now) {
  if (config_.save_pose_rate <= 0.0) return;
  if (!last_save_stamp_.isZero() && (now - last_save_stamp_).toSec() < 1.0 / config_.save_pose_rate) return;
  const std::optional<PoseEstimate> estimate = localizer_->savePose();
  if (!estimate) return;
  // Where a restarted node (or the next map) starts from, as stock amcl keeps it.
  private_nh_.setParam("initial_pose_x", estimate->pose.x);
  private_nh_.setParam("initial_pose_y", estimate->pose.y);
  private_nh_.setParam("initial_pose_a", estimate->pose.yaw);
  private_nh_.setParam("initial_cov_xx", estimate->covariance.xx);
  private_nh_.setParam("initial_cov_yy", estimate->covariance.yy);
  private_nh_.setParam("initial_cov_aa", estimate->covariance.aa);
  last_save_stamp_ = now;
}

}  // namespace loc
}  // namespace marl_mrta
