// The local controller around the DWA planner (dwa_local_planner::DWAPlannerROS with the
// latched stop-and-rotate controller): keeps the global plan, transforms the part near the
// robot into the controller's frame each cycle, prunes what is behind, runs DWA until the
// goal position is within xy_goal_tolerance, then stops (within the acceleration limits) and
// turns in place to the goal yaw. The goal is reached when position and yaw are within
// tolerance and the robot has stopped.
#pragma once

#include <string>
#include <vector>

#include "marl_mrta/nav/dwa_planner.h"

namespace marl_mrta {
namespace nav {

using ::marl_mrta::normalizeAngle;

// A rigid 2D transform: p_target = rotate(yaw)·p_source + (x, y).
struct Transform2D {
  double x = 0.0, y = 0.0, yaw = 0.0;
  Pose2D apply(const Pose2D& p) const;
  // The transform taking `from` poses to `to` poses of the same physical pose.
  static Transform2D between(const Pose2D& pose_in_source, const Pose2D& pose_in_target);
};

struct ControlResult {
  bool ok = false;
  Velocity2D command;
  std::vector<Pose2D> local_plan;        // the chosen rollout (controller frame)
  std::vector<Pose2D> transformed_plan;  // the global plan near the robot (controller frame)
  std::string message;                   // why no command could be found
  // When recorded (recordDwaClouds), while DWA runs: every scored sample and the cells'
  // critic costs, dwa_local_planner's trajectory_cloud and cost_cloud.
  std::vector<Trajectory> explored;
  std::vector<DwaPlanner::CellCosts> cell_costs;
};

class LocalController {
 public:
  explicit LocalController(const DwaConfig& config);
  const DwaConfig& config() const { return planner_.config(); }
  DwaPlanner& planner() { return planner_; }

  // Where a global plan comes from: the first plan after a goal or a recovery behavior
  // (kNewRoute), or move_base's periodic re-planning while it follows one (kReplan).
  enum class PlanUpdate { kNewRoute, kReplan };
  // A new global plan (global frame). Resets the goal latch; a new route also resets DWA's
  // oscillation flags. dwa_local_planner resets them with every plan. Here a re-plan keeps them:
  // this move_base re-plans in step with its control cycles (every second cycle at TurtleBot3's
  // 5 Hz planner and 10 Hz controller), so a forward/backward dither of two cycles had its flags
  // cleared every time and never ended (docs/guide/navigation.md).
  void setPlan(const std::vector<Pose2D>& global_plan, PlanUpdate update);
  // A new goal: forget the stop-and-rotate phase of the previous one.
  void startGoal();
  bool hasPlan() const { return !global_plan_.empty(); }
  // Whether computeVelocityCommands() fills ControlResult::explored and ::cell_costs.
  void recordDwaClouds(bool trajectories, bool cell_costs) {
    record_trajectories_ = trajectories;
    record_cell_costs_ = cell_costs;
  }

  // pose: robot in the controller (costmap) frame; velocity: robot frame (odometry twist);
  // global_to_local: global (plan) frame -> controller frame.
  ControlResult computeVelocityCommands(const CostGrid& costmap, const Polygon& footprint, const Pose2D& pose,
                                        const Velocity2D& velocity, const Transform2D& global_to_local);
  bool isGoalReached(const Pose2D& pose, const Velocity2D& velocity, const Transform2D& global_to_local);
  bool isPositionReached(const Pose2D& pose, const Transform2D& global_to_local) const;

 private:
  std::vector<Pose2D> transformAndPrunePlan(const CostGrid& costmap, const Pose2D& pose,
                                            const Transform2D& global_to_local);
  bool stopped(const Velocity2D& velocity) const;
  ControlResult stopAndRotate(const Pose2D& pose, const Velocity2D& velocity, const Pose2D& goal);

  DwaPlanner planner_;
  std::vector<Pose2D> global_plan_;
  bool xy_tolerance_latch_ = false;
  bool rotating_to_goal_ = false;
  bool record_trajectories_ = false, record_cell_costs_ = false;
};

}  // namespace nav
}  // namespace marl_mrta
