// move_base's outputs: velocity commands, plans, costmaps and the action's feedback and results.
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Path.h>

#include <algorithm>

#include "move_base_ros.h"
#include "marl_mrta/nav/ros_conversions.h"
#include "marl_mrta/publish_shared.h"

namespace marl_mrta {
namespace nav {

namespace conv = ros_conversions;

void MoveBaseRos::endGoal() {
  // Between ticks (a goal refused or cancelled) it counts on the last tick answered.
  const int64_t tick = tick_in_progress_ >= 0 ? tick_in_progress_ : last_acked_tick_;
  goal_end_tick_ = static_cast<uint64_t>(std::max<int64_t>(tick, 0));
}

void MoveBaseRos::publishCommand(const Velocity2D& command) {
  geometry_msgs::Twist twist;
  twist.linear.x = command.x;
  twist.linear.y = command.y;
  twist.angular.z = command.theta;
  publishShared(cmd_vel_pub_, twist);
  ++cmd_vel_count_;
}

void MoveBaseRos::publishOutputs(const CycleOutput& out, const Pose2D& pose, const ros::Time& stamp) {
  if (out.publish_command) publishCommand(out.command);
  if (!out.recovery_started.empty()) ROS_WARN("%s: running recovery behavior %s", log_name_.c_str(), out.recovery_started.c_str());
  if (out.new_plan && plan_pub_.getNumSubscribers() > 0) plan_pub_.publish(conv::toPath(out.plan, global_frame_, stamp));
  if (!out.local_plan.empty() && local_plan_pub_.getNumSubscribers() > 0) {
    local_plan_pub_.publish(conv::toPath(out.local_plan, local_frame_, stamp));
  }
  publishDwaClouds(out, stamp);
  if (!action_server_.isActive()) return;
  waitForClock(stamp);  // actionlib stamps what follows with ros::Time::now()
  switch (out.outcome) {
    case CycleOutput::Outcome::kSucceeded:
      ROS_INFO("%s: %s", log_name_.c_str(), out.message.c_str());
      endGoal();
      action_server_.setSucceeded(move_base_msgs::MoveBaseResult(), out.message);
      break;
    case CycleOutput::Outcome::kAborted:
      ROS_ERROR("%s: %s", log_name_.c_str(), out.message.c_str());
      endGoal();
      action_server_.setAborted(move_base_msgs::MoveBaseResult(), out.message);
      break;
    case CycleOutput::Outcome::kNone: {
      if (!out.message.empty()) warnThrottled("cycle", 1.0, out.message);
      move_base_msgs::MoveBaseFeedback feedback;
      feedback.base_position.header.frame_id = global_frame_;
      feedback.base_position.header.stamp = stamp;
      feedback.base_position.pose.position.x = pose.x;
      feedback.base_position.pose.position.y = pose.y;
      feedback.base_position.pose.orientation = conv::quaternionFromYaw(pose.yaw);
      action_server_.publishFeedback(feedback);
      break;
    }
  }
}

void MoveBaseRos::publishDwaClouds(const CycleOutput& out, const ros::Time& stamp) {
  // Fields and rows as dwa_local_planner's: scored rollouts (discarded ones left out), and the
  // cells its distance critics score.
  if (!out.explored.empty()) {
    std::vector<float> values;
    for (const Trajectory& rollout : out.explored) {
      if (rollout.cost < 0.0) continue;
      for (const Pose2D& p : rollout.points) {
        values.insert(values.end(), {static_cast<float>(p.x), static_cast<float>(p.y), 0.0f,
                                     static_cast<float>(p.yaw), static_cast<float>(rollout.cost)});
      }
    }
    trajectory_cloud_pub_.publish(conv::toPointCloud2({"x", "y", "z", "theta", "cost"}, values, local_frame_, stamp));
  }
  if (!out.cell_costs.empty()) {
    std::vector<float> values;
    for (const DwaPlanner::CellCosts& c : out.cell_costs) {
      values.insert(values.end(), {static_cast<float>(c.x), static_cast<float>(c.y), 0.0f, static_cast<float>(c.path),
                                   static_cast<float>(c.goal), static_cast<float>(c.occupancy),
                                   static_cast<float>(c.total)});
    }
    cost_cloud_pub_.publish(conv::toPointCloud2({"x", "y", "z", "path_cost", "goal_cost", "occ_cost", "total_cost"},
                                                values, local_frame_, stamp));
  }
}

void MoveBaseRos::publishCostmaps(double now, const ros::Time& stamp) {
  const MoveBaseConfig& config = core_->config();
  auto publish = [&](ros::Publisher& pub, LayeredCostmap& costmap, const CostmapConfig& cc, double& next) {
    if (cc.publish_frequency <= 0.0 || now < next || pub.getNumSubscribers() == 0) return;
    next = now + 1.0 / cc.publish_frequency - 1e-9;
    pub.publish(conv::costmapToOccupancyGrid(costmap.costmap(), cc.global_frame, stamp));
  };
  publish(global_costmap_pub_, core_->globalCostmap(), config.global_costmap, next_global_publish_);
  publish(local_costmap_pub_, core_->localCostmap(), config.local_costmap, next_local_publish_);
}

}  // namespace nav
}  // namespace marl_mrta
