// move_base's inputs and its clock: odometry, scans, tf lookups and the simulator's lock-step
// ticks (or the wall-clock timer without lock-step), each control step fed from them.
#include <cmath>
#include <thread>

#include "move_base_ros.h"
#include "marl_mrta/nav/ros_conversions.h"
#include "marl_mrta/publish_shared.h"

namespace marl_mrta {
namespace nav {

namespace conv = ros_conversions;

void MoveBaseRos::onOdom(const nav_msgs::Odometry::ConstPtr& msg) {
  last_odom_ = msg;
  if (lockstep_) processTicks();
}

void MoveBaseRos::onScan(size_t input, const sensor_msgs::LaserScan::ConstPtr& msg) {
  pending_scans_.emplace_back(input, msg);
  if (msg->header.stamp > last_scan_stamp_) last_scan_stamp_ = msg->header.stamp;
  if (lockstep_) processTicks();
}

void MoveBaseRos::onTick(const marl_mrta::SimTick::ConstPtr& msg) {
  pending_ticks_.push_back({*msg, ros::WallTime::now()});
  processTicks();
}

void MoveBaseRos::onTimer(const ros::TimerEvent&) { controlStep(ros::Time::now(), ros::Time(0)); }

void MoveBaseRos::processTicks() {
  while (!pending_ticks_.empty()) {
    const marl_mrta::SimTick& tick = pending_ticks_.front().first;
    // Control on the first tick of each controller period counted from time 0, so that the
    // phase never depends on when move_base started or a goal arrived.
    const int64_t period_index = static_cast<int64_t>(std::floor(tick.stamp.toSec() / control_period_ + 1e-6));
    if (static_cast<int64_t>(tick.tick) > last_acked_tick_) {
      // This tick's inputs travel on other connections: wait for them (bounded by wall time).
      // Only a control tick uses them: the odometry of the tick and every scan up to it.
      const bool control = period_index != last_control_period_;
      const bool late = (ros::WallTime::now() - pending_ticks_.front().second).toSec() > tf_wait_;
      const bool odom_ready = !control || (last_odom_ && last_odom_->header.stamp >= tick.stamp);
      const bool scan_ready = !control || scan_inputs_.empty() || last_scan_stamp_ >= tick.last_scan_stamp;
      if (!(odom_ready && scan_ready) && !late) return;
      if (late) warnThrottled("late inputs", 5.0, "inputs of tick " + std::to_string(tick.tick) + " missing, going on");
      last_tick_time_ = tick.stamp;
      if (control) {
        last_control_period_ = period_index;
        tick_in_progress_ = static_cast<int64_t>(tick.tick);
        controlStep(tick.stamp, tick.stamp);
        tick_in_progress_ = -1;
      }
      last_acked_tick_ = static_cast<int64_t>(tick.tick);
    }
    // Every tick is answered (a re-sent one again); the simulator need not wait for the
    // answers before the next controller period (docs/reference/nodes_sim_nav.md, lock-step protocol).
    ack_.tick = tick.tick;
    ack_.cmd_vel_count = cmd_vel_count_;
    ack_.goal_end_tick = goal_end_tick_;
    ack_.next_stamp.fromSec((static_cast<double>(period_index) + 1.0 - 1e-6) * control_period_);
    publishShared(ack_pub_, ack_);
    pending_ticks_.pop_front();
  }
}

bool MoveBaseRos::pollUntil(const std::function<bool()>& done) const {
  // Inputs of a tick arrive on other threads (roscpp's clock thread) or connections (tf from
  // other processes), bounded in wall time. The thread that brings one usually has only to be
  // scheduled: yielding to it first goes on as soon as it has run, where a first sleep of 0.1 ms
  // (0.15-0.2 ms in practice) made the controllers of a nodelet graph wait for a fifth of its
  // wall time; a longer wait sleeps.
  constexpr int kYieldsBeforeSleeping = 200;
  const ros::WallDuration sleep(0.0001);
  if (done()) return true;
  const ros::WallTime start = ros::WallTime::now(), deadline = start + ros::WallDuration(tf_wait_);
  bool ok = true;
  for (int round = 0; !done(); ++round) {
    if (ros::WallTime::now() > deadline || !ros::ok()) {
      ok = false;
      break;
    }
    if (round < kYieldsBeforeSleeping) std::this_thread::yield(); else sleep.sleep();
  }
  ++input_waits_;
  input_wait_seconds_ += (ros::WallTime::now() - start).toSec();
  return ok;
}

void MoveBaseRos::waitForClock(const ros::Time& stamp) const {
  // actionlib stamps results, status and feedback with ros::Time::now(), which follows /clock
  // on roscpp's own thread and may still be a tick or two behind under load. The simulator sends
  // the clock before the tick, and this is asked after the control step's computation, so it
  // rarely waits; after it a result carries the tick it happened at.
  if (ros::Time::isSimTime()) pollUntil([&] { return ros::Time::now() >= stamp; });
}

bool MoveBaseRos::lookupPose(const std::string& target, const std::string& source, const ros::Time& time,
                             Pose2D& pose, std::string& error) {
  // The latest transform (time 0) is there or not: no waiting for it.
  tf_source_->drain();
  const bool available = time.isZero() ? tf_buffer_.canTransform(target, source, time, &error)
                                       : pollUntil([&] {
                                           tf_source_->drain();
                                           return tf_buffer_.canTransform(target, source, time, &error);
                                         });
  if (!available) return false;
  pose = conv::toPose2D(tf_buffer_.lookupTransform(target, source, time));
  return true;
}

void MoveBaseRos::insertScans(const ros::Time& time) {
  while (!pending_scans_.empty()) {
    const auto [input, scan] = pending_scans_.front();
    if (!time.isZero() && scan->header.stamp > time) return;  // belongs to a later tick
    const ros::Time at = lockstep_ ? scan->header.stamp : ros::Time(0);
    for (const ScanTarget& target : scan_inputs_[input].targets) {
      Pose2D sensor, origin;
      std::string error;
      if (!lookupPose(target.frame, scan->header.frame_id, at, sensor, error)) {
        warnThrottled("scan dropped", 5.0, "scan dropped, no transform " + target.frame + " <- " +
                                               scan->header.frame_id + ": " + error);
        continue;
      }
      LaserScanData data{scan->angle_min, scan->angle_increment, scan->range_min, scan->range_max, scan->ranges,
                         scan->header.stamp.toSec()};
      const ObservationSourceConfig& source = target.layer->config().sources[target.source];
      // Height of the sensor (the planar pose leaves it out): only for the height filters.
      const double z = tf_buffer_.lookupTransform(target.frame, scan->header.frame_id, at).transform.translation.z;
      Observation observation = laserScanToObservation(data, {sensor.x, sensor.y, z, sensor.yaw}, source);
      if (!target.sensor_frame.empty() && target.sensor_frame != scan->header.frame_id &&
          lookupPose(target.frame, target.sensor_frame, at, origin, error)) {
        observation.origin = {origin.x, origin.y, z};
      }
      target.layer->addObservation(target.source, std::move(observation));
    }
    pending_scans_.pop_front();
  }
}

void MoveBaseRos::controlStep(const ros::Time& stamp, const ros::Time& lookup_time) {
  insertScans(lookup_time);
  Pose2D pose_global, pose_local;
  std::string error;
  if (!lookupPose(global_frame_, global_base_frame_, lookup_time, pose_global, error) ||
      !lookupPose(local_frame_, local_base_frame_, lookup_time, pose_local, error)) {
    warnThrottled("no pose", 5.0, "robot pose unavailable: " + error);
    if (core_->active()) publishCommand({});
    return;
  }
  const double now = stamp.toSec();
  core_->updateCostmaps(now, pose_global, pose_local);
  publishCostmaps(now, stamp);
  if (!core_->active()) return;
  Velocity2D velocity;
  if (last_odom_) velocity = {last_odom_->twist.twist.linear.x, last_odom_->twist.twist.linear.y,
                              last_odom_->twist.twist.angular.z};
  const MoveBaseConfig& config = core_->config();
  core_->controller().recordDwaClouds(config.dwa_publish_traj_pc && trajectory_cloud_pub_.getNumSubscribers() > 0,
                                      config.dwa_publish_cost_grid_pc && cost_cloud_pub_.getNumSubscribers() > 0);
  const CycleOutput out = core_->runCycle({now, pose_global, pose_local, velocity});
  publishOutputs(out, pose_global, stamp);
}

}  // namespace nav
}  // namespace marl_mrta
