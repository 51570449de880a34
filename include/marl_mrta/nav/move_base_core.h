// move_base without ROS: the two costmaps, the global planner, the local controller and the
// recovery behaviours, driven one control cycle at a time with an injected clock.
//
// States as move_base: PLANNING (waiting for a plan) -> CONTROLLING (following it) ->
// CLEARING (running the next recovery behaviour, then PLANNING again). The planner runs
// inside the cycle (at planner_frequency while controlling; on every cycle, or at
// planner_frequency, while planning), so a cycle is deterministic given its inputs. A plan
// reaches the controller at the next cycle, as move_base's planner thread hands its plan over:
// the cycle that woke the thread has already read the controller's plan.
// A goal ends with "Goal reached." or one of move_base's abort messages.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "marl_mrta/nav/local_controller.h"
#include "marl_mrta/nav/move_base_config.h"

namespace marl_mrta {
namespace nav {

enum class MoveBaseState { kIdle, kPlanning, kControlling, kClearing };
const char* stateName(MoveBaseState state);

struct CycleInput {
  double now = 0.0;       // [s] time of this cycle (simulation time)
  Pose2D pose_global;     // robot in the global costmap's frame (map)
  Pose2D pose_local;      // robot in the local costmap's frame (odom)
  Velocity2D velocity;    // robot frame, from odometry
};

struct CycleOutput {
  enum class Outcome { kNone, kSucceeded, kAborted };
  bool publish_command = false;
  Velocity2D command;
  Outcome outcome = Outcome::kNone;
  std::string message;             // outcome text, or a warning worth logging
  bool new_plan = false;           // `plan` holds a new global plan
  std::vector<Pose2D> plan;
  std::vector<Pose2D> local_plan;  // chosen DWA rollout (local frame)
  std::vector<Trajectory> explored;                // when recorded: LocalController::recordDwaClouds
  std::vector<DwaPlanner::CellCosts> cell_costs;   // (local frame)
  std::string recovery_started;    // name of a recovery behaviour started this cycle
};

// Time spent in each part of a cycle [s], accumulated (benchmarks).
struct MoveBaseTimings {
  double global_costmap = 0.0, local_costmap = 0.0, planning = 0.0, control = 0.0;
  size_t plans = 0, control_cycles = 0, global_updates = 0, local_updates = 0;
};

class RecoveryBehavior;

class MoveBaseCore {
 public:
  explicit MoveBaseCore(const MoveBaseConfig& config);
  ~MoveBaseCore();
  const MoveBaseConfig& config() const { return config_; }
  LayeredCostmap& globalCostmap() { return *global_costmap_; }
  LayeredCostmap& localCostmap() { return *local_costmap_; }
  NavfnPlanner& planner() { return planner_; }
  LocalController& controller() { return controller_; }

  // A new goal (global frame); replaces any active goal.
  void setGoal(const Pose2D& goal, double now);
  // Drops the active goal (the caller publishes the zero command).
  void cancel();
  bool active() const { return state_ != MoveBaseState::kIdle; }
  MoveBaseState state() const { return state_; }
  const Pose2D& goal() const { return goal_; }

  // Updates each costmap whose update period has passed (or all with force).
  void updateCostmaps(double now, const Pose2D& pose_global, const Pose2D& pose_local, bool force = false);
  CycleOutput runCycle(const CycleInput& input);

  // The ~make_plan service: a plan without executing it (global costmap, default tolerance).
  PlanResult makePlan(const Pose2D& start, const Pose2D& goal, double tolerance);
  // The ~clear_costmaps service: every layer of both costmaps reset.
  void clearCostmaps();
  const MoveBaseTimings& timings() const { return timings_; }

 private:
  void resetState();
  void runPlanner(const CycleInput& input, CycleOutput& out);
  void handOverPendingPlan();
  bool goalInStaticObstacle() const;
  std::unique_ptr<RecoveryBehavior> makeRecovery(const RecoveryBehaviorConfig& config);

  MoveBaseConfig config_;
  std::unique_ptr<LayeredCostmap> global_costmap_, local_costmap_;
  NavfnPlanner planner_;
  LocalController controller_;
  std::vector<std::unique_ptr<RecoveryBehavior>> recoveries_;

  enum class Trigger { kPlanning, kControlling, kOscillation };
  MoveBaseState state_ = MoveBaseState::kIdle;
  Trigger trigger_ = Trigger::kPlanning;
  size_t recovery_index_ = 0;
  bool recovery_running_ = false;
  Pose2D goal_;
  std::vector<Pose2D> pending_plan_;  // made in the previous cycle, not yet the controller's
  bool plan_pending_ = false;
  LocalController::PlanUpdate pending_update_ = LocalController::PlanUpdate::kNewRoute;
  PlanResult last_failure_;
  double last_valid_plan_ = 0.0, last_valid_control_ = 0.0, last_oscillation_reset_ = 0.0;
  double next_plan_time_ = 0.0;
  unsigned planning_retries_ = 0;
  Pose2D oscillation_pose_;
  double next_global_update_ = -1e9, next_local_update_ = -1e9;
  MoveBaseTimings timings_;
};

// A recovery behaviour run one control cycle at a time.
class RecoveryBehavior {
 public:
  virtual ~RecoveryBehavior() = default;
  virtual void start(const CycleInput& input) = 0;
  // One cycle; returns true when finished (a command may be set in `out`).
  virtual bool step(const CycleInput& input, CycleOutput& out) = 0;
};

}  // namespace nav
}  // namespace marl_mrta
