#include "marl_mrta/nav/move_base_core.h"

#include <chrono>
#include <cmath>
#include <sstream>

#include "marl_mrta/nav/cpu_clock.h"
#include "marl_mrta/nav/static_layer.h"
#include "marl_mrta/nav/time_compare.h"

namespace marl_mrta {
namespace nav {
namespace {

double elapsedSince(ThreadCpuClock::time_point start) {
  return std::chrono::duration<double>(ThreadCpuClock::now() - start).count();
}

// Forgets obstacle data away from the robot in the named layers (clear_costmap_recovery).
class ClearCostmapRecovery : public RecoveryBehavior {
 public:
  ClearCostmapRecovery(const RecoveryBehaviorConfig& config, LayeredCostmap& global, LayeredCostmap& local)
      : config_(config), global_(global), local_(local) {}
  void start(const CycleInput&) override {}
  bool step(const CycleInput& input, CycleOutput&) override {
    if (config_.affected_maps != "local") clear(global_, input.pose_global);
    if (config_.affected_maps != "global") clear(local_, input.pose_local);
    return true;
  }

 private:
  void clear(LayeredCostmap& costmap, const Pose2D& pose) {
    for (const auto& layer : costmap.layers()) {
      auto* obstacles = dynamic_cast<ObstacleLayer*>(layer.get());
      if (!obstacles) continue;
      for (const std::string& name : config_.layer_names) {
        if (layer->name() == name) obstacles->clearArea(pose.x, pose.y, config_.reset_distance, config_.invert_area_to_clear);
      }
    }
  }
  RecoveryBehaviorConfig config_;
  LayeredCostmap& global_;
  LayeredCostmap& local_;
};

// One full turn in place, checked against the local costmap (rotate_recovery).
class RotateRecovery : public RecoveryBehavior {
 public:
  RotateRecovery(const RecoveryBehaviorConfig& config, LayeredCostmap& local) : config_(config), local_(local) {}
  void start(const CycleInput& input) override {
    start_angle_ = input.pose_local.yaw;
    got_180_ = false;
  }
  bool step(const CycleInput& input, CycleOutput& out) override {
    const double current = input.pose_local.yaw;
    double dist_left;
    if (!got_180_) {
      // Half a turn plus the way to the half-turn point, until that point is passed.
      const double to_180 = std::fabs(normalizeAngleByFmod(start_angle_ + M_PI - current));
      dist_left = M_PI + to_180;
      if (to_180 < config_.yaw_tolerance) got_180_ = true;
    } else {
      dist_left = std::fabs(normalizeAngleByFmod(start_angle_ - current));
      if (dist_left <= config_.yaw_tolerance) return true;
    }
    for (double sim_angle = 0.0; sim_angle < dist_left; sim_angle += config_.sim_granularity) {
      const Pose2D p{input.pose_local.x, input.pose_local.y, current + sim_angle};
      if (footprintCostAt(local_.costmap(), local_.footprint(), p) < 0.0) {
        out.message = "Rotate recovery can't rotate in place because there is a potential collision.";
        return true;
      }
    }
    double vel = std::sqrt(2.0 * config_.acc_lim_theta * dist_left);
    vel = std::min(std::max(vel, config_.min_rotational_vel), config_.max_rotational_vel);
    out.publish_command = true;
    out.command = {0.0, 0.0, vel};
    return false;
  }

 private:
  RecoveryBehaviorConfig config_;
  LayeredCostmap& local_;
  double start_angle_ = 0.0;
  bool got_180_ = false;
};

}  // namespace

const char* stateName(MoveBaseState state) {
  switch (state) {
    case MoveBaseState::kIdle: return "IDLE";
    case MoveBaseState::kPlanning: return "PLANNING";
    case MoveBaseState::kControlling: return "CONTROLLING";
    case MoveBaseState::kClearing: return "CLEARING";
  }
  return "?";
}

MoveBaseCore::MoveBaseCore(const MoveBaseConfig& config)
    : config_(config),
      global_costmap_(buildCostmap(config.global_costmap)),
      local_costmap_(buildCostmap(config.local_costmap)),
      planner_(config.navfn),
      controller_(config.dwa) {
  for (const RecoveryBehaviorConfig& recovery : config_.recovery_behaviors) recoveries_.push_back(makeRecovery(recovery));
}

MoveBaseCore::~MoveBaseCore() = default;

std::unique_ptr<RecoveryBehavior> MoveBaseCore::makeRecovery(const RecoveryBehaviorConfig& config) {
  if (config.kind == RecoveryBehaviorConfig::Kind::kRotate) return std::make_unique<RotateRecovery>(config, *local_costmap_);
  return std::make_unique<ClearCostmapRecovery>(config, *global_costmap_, *local_costmap_);
}

void MoveBaseCore::setGoal(const Pose2D& goal, double now) {
  goal_ = goal;
  state_ = MoveBaseState::kPlanning;
  trigger_ = Trigger::kPlanning;
  recovery_index_ = 0;
  recovery_running_ = false;
  plan_pending_ = false;
  last_valid_control_ = last_valid_plan_ = last_oscillation_reset_ = now;
  next_plan_time_ = now;
  planning_retries_ = 0;
  last_failure_ = PlanResult{};
  controller_.startGoal();
  planner_.drawVariation();
}

void MoveBaseCore::cancel() { resetState(); }

void MoveBaseCore::resetState() {
  state_ = MoveBaseState::kIdle;
  recovery_index_ = 0;
  recovery_running_ = false;
  trigger_ = Trigger::kPlanning;
  plan_pending_ = false;
}

void MoveBaseCore::updateCostmaps(double now, const Pose2D& pose_global, const Pose2D& pose_local, bool force) {
  const auto t0 = ThreadCpuClock::now();
  if (force || now >= next_global_update_) {
    global_costmap_->updateMap(pose_global);
    const double f = config_.global_costmap.update_frequency;
    next_global_update_ = f > 0.0 ? now + 1.0 / f - 1e-9 : 1e300;
    ++timings_.global_updates;
  }
  const auto t1 = ThreadCpuClock::now();
  timings_.global_costmap += elapsedSince(t0);
  if (force || now >= next_local_update_) {
    local_costmap_->updateMap(pose_local);
    const double f = config_.local_costmap.update_frequency;
    next_local_update_ = f > 0.0 ? now + 1.0 / f - 1e-9 : 1e300;
    ++timings_.local_updates;
  }
  timings_.local_costmap += elapsedSince(t1);
}

bool MoveBaseCore::goalInStaticObstacle() const {
  const double radius = global_costmap_->inscribedRadius();
  for (StaticLayer* layer : global_costmap_->layersOfType<StaticLayer>()) {
    if (layer->lethalWithin(goal_.x, goal_.y, radius)) return true;
  }
  return false;
}

void MoveBaseCore::runPlanner(const CycleInput& in, CycleOutput& out) {
  const auto t0 = ThreadCpuClock::now();
  PlanResult result = planner_.makePlan(global_costmap_->costmap(), in.pose_global, goal_);
  timings_.planning += elapsedSince(t0);
  ++timings_.plans;
  const double period = config_.planner_frequency > 0.0 ? 1.0 / config_.planner_frequency : 0.0;
  next_plan_time_ = in.now + period - 1e-9;
  if (result.ok()) {
    last_valid_plan_ = in.now;
    planning_retries_ = 0;
    out.new_plan = true;
    out.plan = result.path;
    pending_plan_ = std::move(result.path);
    plan_pending_ = true;
    // Planning state: after a goal or a recovery behavior; controlling: periodic re-planning.
    pending_update_ = state_ == MoveBaseState::kPlanning ? LocalController::PlanUpdate::kNewRoute
                                                         : LocalController::PlanUpdate::kReplan;
    return;
  }
  last_failure_ = result;
  if (state_ != MoveBaseState::kPlanning) return;  // keep following the previous plan
  ++planning_retries_;
  const bool out_of_patience = isPast(in.now, last_valid_plan_, config_.planner_patience);
  const bool out_of_retries = config_.max_planning_retries >= 0 &&
                              planning_retries_ > static_cast<unsigned>(config_.max_planning_retries);
  if ((out_of_patience || out_of_retries) && result.status == PlanResult::Status::kGoalInObstacle &&
      goalInStaticObstacle()) {
    // No recovery behaviour clears the static map: say so now instead of running them all.
    std::ostringstream message;
    message.precision(2);
    message << std::fixed << "Failed to find a valid plan: the goal (" << goal_.x << ", " << goal_.y
            << ") is inside an obstacle of the static map, which no recovery behavior can clear.";
    resetState();
    out.publish_command = true;
    out.command = {};
    out.outcome = CycleOutput::Outcome::kAborted;
    out.message = message.str();
    return;
  }
  if (out_of_patience || out_of_retries) {
    state_ = MoveBaseState::kClearing;
    trigger_ = Trigger::kPlanning;
    out.publish_command = true;
    out.command = {};
  }
}

void MoveBaseCore::handOverPendingPlan() {
  controller_.setPlan(pending_plan_, pending_update_);
  plan_pending_ = false;
  if (trigger_ == Trigger::kPlanning) recovery_index_ = 0;
  if (state_ == MoveBaseState::kPlanning) state_ = MoveBaseState::kControlling;
}

CycleOutput MoveBaseCore::runCycle(const CycleInput& in) {
  CycleOutput out;
  if (state_ == MoveBaseState::kIdle) return out;
  const Transform2D global_to_local = Transform2D::between(in.pose_global, in.pose_local);

  // Moving oscillation_distance restarts the oscillation clock.
  if (std::hypot(in.pose_global.x - oscillation_pose_.x, in.pose_global.y - oscillation_pose_.y) >=
      config_.oscillation_distance) {
    last_oscillation_reset_ = in.now;
    oscillation_pose_ = in.pose_global;
    if (trigger_ == Trigger::kOscillation) recovery_index_ = 0;
  }
  if (!local_costmap_->isCurrent(in.now)) {
    out.publish_command = true;
    out.message = "Sensor data is out of date, we're not going to allow commanding of the base for safety";
    return out;
  }
  if (plan_pending_) handOverPendingPlan();
  const bool plan_due = (state_ == MoveBaseState::kPlanning && in.now >= next_plan_time_) ||
                        (state_ == MoveBaseState::kControlling && config_.planner_frequency > 0.0 &&
                         in.now >= next_plan_time_);
  if (plan_due && !recovery_running_) runPlanner(in, out);

  switch (state_) {
    case MoveBaseState::kIdle:
      break;
    case MoveBaseState::kPlanning:
      break;
    case MoveBaseState::kControlling: {
      const auto t0 = ThreadCpuClock::now();
      if (controller_.isGoalReached(in.pose_local, in.velocity, global_to_local)) {
        resetState();
        out.publish_command = true;
        out.command = {};
        out.outcome = CycleOutput::Outcome::kSucceeded;
        out.message = "Goal reached.";
        break;
      }
      if (config_.oscillation_timeout > 0.0 && isPast(in.now, last_oscillation_reset_, config_.oscillation_timeout)) {
        out.publish_command = true;
        out.command = {};
        state_ = MoveBaseState::kClearing;
        trigger_ = Trigger::kOscillation;
      }
      ControlResult control = controller_.computeVelocityCommands(
          local_costmap_->costmap(), local_costmap_->footprint(), in.pose_local, in.velocity, global_to_local);
      timings_.control += elapsedSince(t0);
      ++timings_.control_cycles;
      out.explored = std::move(control.explored);
      out.cell_costs = std::move(control.cell_costs);
      if (control.ok) {
        last_valid_control_ = in.now;
        out.publish_command = true;
        out.command = control.command;
        out.local_plan = control.local_plan;
        if (trigger_ == Trigger::kControlling) recovery_index_ = 0;
      } else if (isPast(in.now, last_valid_control_, config_.controller_patience)) {
        out.publish_command = true;
        out.command = {};
        state_ = MoveBaseState::kClearing;
        trigger_ = Trigger::kControlling;
      } else {
        // No valid command now: stop and plan again, at once (move_base wakes its planner
        // thread here), for the next cycle.
        last_valid_plan_ = in.now;
        planning_retries_ = 0;
        state_ = MoveBaseState::kPlanning;
        out.publish_command = true;
        out.command = {};
        out.message = "DWA planner failed to produce path: " + control.message;
        runPlanner(in, out);
      }
      break;
    }
    case MoveBaseState::kClearing:
      if (config_.recovery_behavior_enabled && recovery_index_ < recoveries_.size()) {
        if (!recovery_running_) {
          recoveries_[recovery_index_]->start(in);
          recovery_running_ = true;
          out.recovery_started = config_.recovery_behaviors[recovery_index_].name;
        }
        if (recoveries_[recovery_index_]->step(in, out)) {
          recovery_running_ = false;
          last_oscillation_reset_ = in.now;
          last_valid_plan_ = in.now;
          planning_retries_ = 0;
          next_plan_time_ = in.now;
          state_ = MoveBaseState::kPlanning;
          ++recovery_index_;
        }
        break;
      }
      out.publish_command = true;
      out.command = {};
      out.outcome = CycleOutput::Outcome::kAborted;
      if (trigger_ == Trigger::kControlling) {
        out.message = "Failed to find a valid control. Even after executing recovery behaviors.";
      } else if (trigger_ == Trigger::kPlanning) {
        out.message = "Failed to find a valid plan. Even after executing recovery behaviors.";
        if (!last_failure_.message.empty()) out.message += " Last planner error: " + last_failure_.message + ".";
      } else {
        out.message = "Robot is oscillating. Even after executing recovery behaviors.";
      }
      resetState();
      break;
  }
  return out;
}

PlanResult MoveBaseCore::makePlan(const Pose2D& start, const Pose2D& goal, double tolerance) {
  const auto t0 = ThreadCpuClock::now();
  PlanResult result = planner_.makePlan(global_costmap_->costmap(), start, goal, tolerance);
  timings_.planning += elapsedSince(t0);
  ++timings_.plans;
  return result;
}

void MoveBaseCore::clearCostmaps() {
  global_costmap_->resetLayers();
  local_costmap_->resetLayers();
  next_global_update_ = next_local_update_ = -1e9;
}

}  // namespace nav
}  // namespace marl_mrta
