#include "marl_mrta/nav/local_controller.h"

#include <array>
#include <cmath>
#include <sstream>
#include <string>

namespace marl_mrta {
namespace nav {

Pose2D Transform2D::apply(const Pose2D& p) const {
  const double c = std::cos(yaw), s = std::sin(yaw);
  return {x + c * p.x - s * p.y, y + s * p.x + c * p.y, normalizeAngleByFmod(p.yaw + yaw)};
}

Transform2D Transform2D::between(const Pose2D& a, const Pose2D& b) {
  // T·a = b  =>  yaw = b.yaw − a.yaw, t = b − R(yaw)·a.
  Transform2D t;
  t.yaw = normalizeAngleByFmod(b.yaw - a.yaw);
  const double c = std::cos(t.yaw), s = std::sin(t.yaw);
  t.x = b.x - (c * a.x - s * a.y);
  t.y = b.y - (s * a.x + c * a.y);
  return t;
}

namespace {

// `command` when the planner finds it collision-free, else no command and `collision_message`.
ControlResult checkedCommand(DwaPlanner& planner, const Pose2D& pose, const Velocity2D& velocity,
                             const Velocity2D& command, const char* collision_message) {
  ControlResult result;
  if (planner.checkTrajectory(pose, velocity, command)) {
    result.ok = true;
    result.command = command;
  } else {
    result.message = collision_message;
  }
  return result;
}

// " (N samples: k by <critic>, ...)": what discarded the samples, for the log line.
std::string discardReasons(size_t samples, const std::array<size_t, 8>& discards) {
  std::ostringstream out;
  out << " (" << samples << " samples";
  const char* separator = ": ";
  for (size_t code = 2; code < discards.size(); ++code) {
    if (discards[code] == 0) continue;
    out << separator << discards[code] << " " << DwaPlanner::discardReason(code);
    separator = ", ";
  }
  out << ")";
  return out.str();
}

}  // namespace

LocalController::LocalController(const DwaConfig& config) : planner_(config) {}

void LocalController::setPlan(const std::vector<Pose2D>& global_plan, PlanUpdate update) {
  global_plan_ = global_plan;
  xy_tolerance_latch_ = false;
  if (update == PlanUpdate::kNewRoute) planner_.resetOscillationFlags();
}

void LocalController::startGoal() {
  // Not in setPlan: re-planning at planner_frequency while turning on the spot would restart
  // the brake-then-turn sequence every time and make the final turn come in pulses.
  rotating_to_goal_ = false;
  xy_tolerance_latch_ = false;
}

std::vector<Pose2D> LocalController::transformAndPrunePlan(const CostGrid& costmap, const Pose2D& pose,
                                                           const Transform2D& global_to_local) {
  // Keep the stretch of plan within half the local map's size of the robot.
  const double threshold = std::max(costmap.sizeMetersX(), costmap.sizeMetersY()) / 2.0;
  const double sq_threshold = threshold * threshold;
  std::vector<Pose2D> transformed;
  size_t i = 0;
  double sq_dist = 0.0;
  auto sq_distance_to = [&](const Pose2D& p) {
    return (p.x - pose.x) * (p.x - pose.x) + (p.y - pose.y) * (p.y - pose.y);
  };
  for (; i < global_plan_.size(); ++i) {
    sq_dist = sq_distance_to(global_to_local.apply(global_plan_[i]));
    if (sq_dist <= sq_threshold) break;
  }
  while (i < global_plan_.size() && sq_dist <= sq_threshold) {
    const Pose2D p = global_to_local.apply(global_plan_[i]);
    transformed.push_back(p);
    sq_dist = sq_distance_to(p);
    ++i;
  }
  if (config().limits.prune_plan) {
    // Drop leading points farther than 1 m (behind the robot), from both plans.
    size_t erase = 0;
    while (erase < transformed.size() && sq_distance_to(transformed[erase]) >= 1.0) ++erase;
    transformed.erase(transformed.begin(), transformed.begin() + erase);
    global_plan_.erase(global_plan_.begin(), global_plan_.begin() + std::min(erase, global_plan_.size()));
  }
  return transformed;
}

bool LocalController::stopped(const Velocity2D& v) const {
  const LocalPlannerLimits& l = config().limits;
  return std::fabs(v.theta) <= l.theta_stopped_vel && std::fabs(v.x) <= l.trans_stopped_vel &&
         std::fabs(v.y) <= l.trans_stopped_vel;
}

bool LocalController::isPositionReached(const Pose2D& pose, const Transform2D& global_to_local) const {
  if (global_plan_.empty()) return false;
  const Pose2D goal = global_to_local.apply(global_plan_.back());
  return (config().latch_xy_goal_tolerance && xy_tolerance_latch_) ||
         std::hypot(goal.x - pose.x, goal.y - pose.y) <= config().limits.xy_goal_tolerance;
}

bool LocalController::isGoalReached(const Pose2D& pose, const Velocity2D& velocity,
                                    const Transform2D& global_to_local) {
  if (!isPositionReached(pose, global_to_local)) return false;
  if (config().latch_xy_goal_tolerance) xy_tolerance_latch_ = true;
  const Pose2D goal = global_to_local.apply(global_plan_.back());
  return std::fabs(normalizeAngleByFmod(goal.yaw - pose.yaw)) <= config().limits.yaw_goal_tolerance && stopped(velocity);
}

ControlResult LocalController::stopAndRotate(const Pose2D& pose, const Velocity2D& velocity, const Pose2D& goal) {
  const LocalPlannerLimits& l = config().limits;
  const double dt = config().sim_period;
  ControlResult result;
  if (config().latch_xy_goal_tolerance) xy_tolerance_latch_ = true;
  const double angle = normalizeAngleByFmod(goal.yaw - pose.yaw);
  if (std::fabs(angle) <= l.yaw_goal_tolerance) {
    result.ok = true;  // zero command: wait until stopped
    rotating_to_goal_ = false;
    return result;
  }
  auto sign = [](double v) { return v < 0.0 ? -1.0 : 1.0; };
  if (!rotating_to_goal_ && !stopped(velocity)) {
    // Brake as hard as the acceleration limits allow within one period.
    const Velocity2D brake{sign(velocity.x) * std::max(0.0, std::fabs(velocity.x) - l.acc_lim_x * dt),
                           sign(velocity.y) * std::max(0.0, std::fabs(velocity.y) - l.acc_lim_y * dt),
                           sign(velocity.theta) * std::max(0.0, std::fabs(velocity.theta) - l.acc_lim_theta * dt)};
    return checkedCommand(planner_, pose, velocity, brake, "stopping command in collision");
  }
  rotating_to_goal_ = true;
  // Turn towards the goal yaw: within the acceleration window, slow enough to stop at the
  // goal, and never below min_vel_theta (the robot would not turn at all).
  double vth = std::min(l.max_vel_theta, std::max(l.min_vel_theta, std::fabs(angle)));
  const double max_acc_vel = std::fabs(velocity.theta) + l.acc_lim_theta * dt;
  const double min_acc_vel = std::fabs(velocity.theta) - l.acc_lim_theta * dt;
  vth = std::min(std::max(vth, min_acc_vel), max_acc_vel);
  vth = std::min(vth, std::sqrt(2.0 * l.acc_lim_theta * std::fabs(angle)));
  vth = std::min(l.max_vel_theta, std::max(l.min_vel_theta, vth));
  if (angle < 0.0) vth = -vth;
  const Velocity2D turn{0.0, 0.0, vth};
  return checkedCommand(planner_, pose, velocity, turn, "rotation towards the goal yaw in collision");
}

ControlResult LocalController::computeVelocityCommands(const CostGrid& costmap, const Polygon& footprint,
                                                       const Pose2D& pose, const Velocity2D& velocity,
                                                       const Transform2D& global_to_local) {
  ControlResult result;
  if (global_plan_.empty()) {
    result.message = "no global plan";
    return result;
  }
  const Pose2D goal = global_to_local.apply(global_plan_.back());
  result.transformed_plan = transformAndPrunePlan(costmap, pose, global_to_local);
  if (result.transformed_plan.empty()) {
    result.message = "the global plan does not pass near the robot";
    return result;
  }
  planner_.updatePlanAndLocalCosts(costmap, pose, result.transformed_plan, footprint);
  if (isPositionReached(pose, global_to_local)) {
    ControlResult turn = stopAndRotate(pose, velocity, goal);
    turn.transformed_plan = std::move(result.transformed_plan);
    return turn;
  }
  if (record_trajectories_) result.explored = planner_.exploreSamples(pose, velocity);
  if (record_cell_costs_) result.cell_costs = planner_.cellCosts();
  const Trajectory best = planner_.findBestPath(pose, velocity);
  if (best.cost < 0.0) {
    result.message = "every velocity sample was discarded" + discardReasons(planner_.lastSampleCount(), planner_.lastDiscards());
    return result;
  }
  result.ok = true;
  result.command = {best.xv, best.yv, best.thetav};
  result.local_plan = best.points;
  return result;
}

}  // namespace nav
}  // namespace marl_mrta
