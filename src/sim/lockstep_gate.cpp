#include "marl_mrta/sim/lockstep_gate.h"

#include <algorithm>
#include <cstddef>

namespace marl_mrta {
namespace sim {

LockstepGate::LockstepGate(std::vector<bool> participating)
    : participating_(std::move(participating)),
      commands_received_(participating_.size(), 0),
      acked_tick_(participating_.size(), -1),
      acked_commands_(participating_.size(), 0),
      next_tick_(participating_.size(), 0) {}

bool LockstepGate::ackReceived(int robot, uint64_t tick, uint64_t cmd_vel_count, uint64_t next_tick,
                               uint64_t current_tick) {
  if (!participating_[robot]) return false;
  if (tick == current_tick) {
    acked_tick_[robot] = static_cast<int64_t>(tick);
    acked_commands_[robot] = cmd_vel_count;
    next_tick_[robot] = std::max(next_tick, tick + 1);
  }
  return true;
}

void GoalEndWatch::start(std::vector<int> robots, uint64_t start_tick, uint64_t align, bool first) {
  robots_ = std::move(robots);
  start_tick_ = start_tick;
  align_ = std::max<uint64_t>(align, 1);
  first_ = first;
}

uint64_t GoalEndWatch::pauseTick() const {
  if (robots_.empty()) return 0;
  uint64_t chosen = 0;
  for (int robot : robots_) {
    const uint64_t end = end_tick_[robot];
    if (end <= start_tick_) {
      if (first_) continue;
      return 0;
    }
    chosen = first_ ? (chosen == 0 ? end : std::min(chosen, end)) : std::max(chosen, end);
  }
  if (chosen == 0) return 0;
  return (chosen + align_ - 1) / align_ * align_;
}

bool LockstepGate::answered(uint64_t tick) const { return missing(tick).empty(); }

std::vector<int> LockstepGate::missing(uint64_t tick) const {
  std::vector<int> robots;
  for (std::size_t g = 0; g < participating_.size(); ++g) {
    const bool acked = acked_tick_[g] == static_cast<int64_t>(tick) ||
                       (acked_tick_[g] >= 0 && acked_tick_[g] < static_cast<int64_t>(tick) && tick < next_tick_[g]);
    if (participating_[g] && (!acked || commands_received_[g] < acked_commands_[g])) {
      robots.push_back(static_cast<int>(g));
    }
  }
  return robots;
}

RealTimePacer::RealTimePacer(double physics_rate, double rtf, double max_lag)
    : wall_per_tick_(rtf > 0.0 ? 1.0 / (physics_rate * rtf) : 0.0), max_lag_(max_lag) {}

double RealTimePacer::waitBeforeStep(double wall_now, uint64_t tick) {
  if (wall_per_tick_ <= 0.0) return 0.0;
  if (!anchored_) {
    anchored_ = true;
    anchor_wall_ = wall_now;
    anchor_tick_ = tick;
  }
  const double due = anchor_wall_ + (tick + 1 - anchor_tick_) * wall_per_tick_;
  if (wall_now < due) return due - wall_now;
  if (wall_now - due > max_lag_) anchored_ = false;
  return 0.0;
}

}  // namespace sim
}  // namespace marl_mrta
