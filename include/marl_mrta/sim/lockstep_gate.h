// When the simulator may advance: the lock-step bookkeeping and the real-time pacing of the
// node's loop, ROS-free (wall time is passed in) so that both are unit-tested.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace marl_mrta {
namespace sim {

// Lock-step: tick T is answered once every participating robot has an ack for T (or for an
// earlier tick whose ack said that the robot's controller needs no tick before a later one)
// and the simulator has received at least as many cmd_vel messages for it as the ack counts.
class LockstepGate {
 public:
  // participating[g]: robot g (global index) must be answered.
  explicit LockstepGate(std::vector<bool> participating);

  void commandReceived(int robot) { ++commands_received_[robot]; }
  // Records an ack made for `tick` while the simulator is at `current_tick` (acks for other
  // ticks are stale and ignored); the controller needs no answer from itself before
  // `next_tick` (tick + 1 or less: the next tick). Returns false when the robot does not
  // participate.
  bool ackReceived(int robot, uint64_t tick, uint64_t cmd_vel_count, uint64_t next_tick, uint64_t current_tick);
  bool answered(uint64_t tick) const;
  // Participating robots still missing for `tick` (for messages).
  std::vector<int> missing(uint64_t tick) const;

 private:
  std::vector<bool> participating_;
  std::vector<uint64_t> commands_received_;
  std::vector<int64_t> acked_tick_;
  std::vector<uint64_t> acked_commands_;
  std::vector<uint64_t> next_tick_;  // first tick the robot's controller answers again
};

// ~run_until's early stop when goals end: the tick to pause on once every watched robot's
// controller has reported a goal ended on a tick after the watch started (the first multiple of
// `align` at or after the last such tick), or with `first` once any of them has (the first
// multiple of `align` at or after the earliest such tick: event mode's next decision).
class GoalEndWatch {
 public:
  explicit GoalEndWatch(std::size_t robots) : end_tick_(robots, 0) {}

  // From every ack: the tick on which the robot's controller last ended a goal (0: none).
  void goalEnded(int robot, uint64_t tick) { end_tick_[robot] = std::max(end_tick_[robot], tick); }
  void start(std::vector<int> robots, uint64_t start_tick, uint64_t align, bool first = false);
  void clear() { robots_.clear(); }
  bool active() const { return !robots_.empty(); }
  // 0 while a watched robot has not ended a goal since the start (or nothing is watched).
  uint64_t pauseTick() const;

 private:
  std::vector<uint64_t> end_tick_;
  std::vector<int> robots_;
  uint64_t start_tick_ = 0, align_ = 1;
  bool first_ = false;
};

// Real-time pacing: with rtf > 0, the step to tick T+1 is due rtf times faster than sim time
// runs, counted from an anchor (so short delays are caught up rather than summed); a lag of
// more than max_lag wall seconds (a loaded machine, a pause) starts afresh instead of racing.
class RealTimePacer {
 public:
  RealTimePacer(double physics_rate, double rtf, double max_lag);

  void restart() { anchored_ = false; }
  // Wall seconds to wait before stepping from `tick` (0: step now).
  double waitBeforeStep(double wall_now, uint64_t tick);

 private:
  double wall_per_tick_;  // 0: as fast as possible
  double max_lag_;
  bool anchored_ = false;
  double anchor_wall_ = 0.0;
  uint64_t anchor_tick_ = 0;
};

}  // namespace sim
}  // namespace marl_mrta
