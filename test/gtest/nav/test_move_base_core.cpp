// move_base's executive without ROS: a kinematic robot driven cycle by cycle.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "marl_mrta/nav/move_base_core.h"
#include "marl_mrta/nav/static_layer.h"
#include "nav_test_helpers.h"

using namespace marl_mrta::nav;
using namespace marl_mrta::nav::testing;

namespace {

const std::string kConfigDir = std::string(MARL_MRTA_SOURCE_DIR) + "/config/nav/";

MoveBaseConfig projectConfig() { return readMoveBaseConfig(ParamNode(loadMoveBaseParams(kConfigDir), "move_base")); }

// A unicycle following commands within the acceleration limits; odom = map (ideal localisation).
struct Harness {
  explicit Harness(const marl_mrta::map::OccupancyMap& m, const Pose2D& start) : core(projectConfig()), pose(start) {
    core.globalCostmap().layersOfType<StaticLayer>().front()->setMap(m);
  }
  CycleOutput cycle() {
    core.updateCostmaps(now, pose, pose);
    CycleInput in{now, pose, pose, velocity};
    CycleOutput out = core.runCycle(in);
    if (out.publish_command) command = out.command;
    const double dt = 1.0 / core.config().controller_frequency;
    const LocalPlannerLimits& l = core.config().dwa.limits;
    auto approach = [dt](double v, double target, double acc) {
      return v + std::max(-acc * dt, std::min(acc * dt, target - v));
    };
    velocity.x = approach(velocity.x, command.x, l.acc_lim_x);
    velocity.theta = approach(velocity.theta, command.theta, l.acc_lim_theta);
    pose.x += velocity.x * std::cos(pose.yaw) * dt;
    pose.y += velocity.x * std::sin(pose.yaw) * dt;
    pose.yaw = normalizeAngle(pose.yaw + velocity.theta * dt);
    now += dt;
    return out;
  }
  // Runs until the goal ends (or max_cycles); returns the final output.
  CycleOutput runUntilDone(int max_cycles) {
    for (int i = 0; i < max_cycles; ++i) {
      CycleOutput out = cycle();
      if (out.outcome != CycleOutput::Outcome::kNone) return out;
    }
    return CycleOutput{};
  }
  MoveBaseCore core;
  Pose2D pose;
  Velocity2D velocity, command;
  double now = 0.0;
};

// 4 m x 3 m room, a wall with a 1 m door in the middle, a column in the right half.
marl_mrta::map::OccupancyMap doorRoom() {
  return roomMap(80, 60, {{39, 0, 42, 25}, {39, 45, 42, 60}, {58, 38, 66, 46}});
}

}  // namespace

TEST(MoveBaseCore, ReachesAGoalThroughTheDoorWithinTolerance) {
  Harness h(doorRoom(), {0.5, 0.5, 0.0});
  const Pose2D goal{3.4, 0.6, M_PI};
  h.core.setGoal(goal, h.now);
  EXPECT_EQ(MoveBaseState::kPlanning, h.core.state());
  const CycleOutput out = h.runUntilDone(1500);
  ASSERT_EQ(CycleOutput::Outcome::kSucceeded, out.outcome) << out.message << " at t = " << h.now;
  EXPECT_EQ("Goal reached.", out.message);
  EXPECT_LE(std::hypot(h.pose.x - goal.x, h.pose.y - goal.y), 0.05);
  EXPECT_LE(std::fabs(normalizeAngle(h.pose.yaw - goal.yaw)), 0.17);
  EXPECT_FALSE(h.core.active());
  EXPECT_GT(h.core.timings().plans, 1u) << "planner_frequency 5 Hz replans while controlling";
}

TEST(MoveBaseCore, GoalInsideAColumnAbortsAfterPlannerPatience) {
  Harness h(doorRoom(), {0.5, 0.5, 0.0});
  h.core.setGoal({3.1, 2.1, 0.0}, h.now);  // centre of the column
  const CycleOutput out = h.runUntilDone(200);
  ASSERT_EQ(CycleOutput::Outcome::kAborted, out.outcome);
  EXPECT_EQ(0u, out.message.find("Failed to find a valid plan")) << out.message;
  EXPECT_NE(std::string::npos, out.message.find("inside an obstacle of the static map")) << out.message;
  const double patience = h.core.config().planner_patience;
  const double abort_time = h.now - 1.0 / h.core.config().controller_frequency;  // cycle() advanced the clock
  EXPECT_GT(abort_time, patience);
  EXPECT_LE(abort_time, patience + 1.0 / h.core.config().planner_frequency + 1e-9)
      << "abort at the first planning attempt after the patience";
  EXPECT_NEAR(0.0, h.command.x, 1e-12);
}

TEST(MoveBaseCore, UnreachableGoalAbortsAfterRecoveries) {
  // The right half is closed off: the goal there is free but cannot be reached.
  Harness h(roomMap(80, 60, {{39, 0, 42, 60}}), {0.5, 0.5, 0.0});
  h.core.setGoal({3.0, 1.5, 0.0}, h.now);
  std::vector<std::string> recoveries;
  CycleOutput out;
  for (int i = 0; i < 2000 && out.outcome == CycleOutput::Outcome::kNone; ++i) {
    out = h.cycle();
    if (!out.recovery_started.empty()) recoveries.push_back(out.recovery_started);
  }
  ASSERT_EQ(CycleOutput::Outcome::kAborted, out.outcome);
  EXPECT_EQ(0u, out.message.find("Failed to find a valid plan. Even after executing recovery behaviors."))
      << out.message;
  EXPECT_EQ((std::vector<std::string>{"conservative_reset", "rotate_recovery", "aggressive_reset", "rotate_recovery"}),
            recoveries);
}

TEST(MoveBaseCore, PatiencesEndOnTheSameTickWhateverTheStartTime) {
  // The unreachable goal's planner patience (5 s) ends exactly on a planning tick. The node's
  // clock is the simulator's tick stamps in whole nanoseconds, as ros::Time::toSec() gives them,
  // so the same run started at another tick must see the patience end on the same tick. With
  // 50 Hz physics the sums of seconds in doubles round such ties differently at these start
  // ticks (at the default 20 Hz they happen to agree).
  const int64_t ticks_per_cycle = 5;  // 50 Hz physics, 10 Hz control
  auto stamp = [](int64_t tick) {
    const int64_t nsec = tick * 20000000;
    return static_cast<double>(nsec / 1000000000) + 1e-9 * static_cast<double>(nsec % 1000000000);
  };
  std::vector<std::vector<std::string>> runs;
  for (const int64_t offset : {0, 72, 97, 118, 122, 147}) {
    Harness h(roomMap(80, 60, {{39, 0, 42, 60}}), {0.5, 0.5, 0.0});
    h.now = stamp(offset);
    h.core.setGoal({3.0, 1.5, 0.0}, h.now);
    std::vector<std::string> events;
    CycleOutput out;
    int cycle = 0;
    for (; cycle < 2000 && out.outcome == CycleOutput::Outcome::kNone; ++cycle) {
      h.now = stamp(offset + ticks_per_cycle * cycle);
      out = h.cycle();
      if (!out.recovery_started.empty()) events.push_back(std::to_string(cycle) + " " + out.recovery_started);
    }
    ASSERT_EQ(CycleOutput::Outcome::kAborted, out.outcome) << "start tick " << offset;
    events.push_back(std::to_string(cycle) + " aborted");
    runs.push_back(events);
  }
  for (size_t r = 1; r < runs.size(); ++r) EXPECT_EQ(runs[0], runs[r]) << "run " << r;
}

TEST(MoveBaseCore, CancelStopsCommanding) {
  Harness h(doorRoom(), {0.5, 0.5, 0.0});
  h.core.setGoal({3.4, 0.6, 0.0}, h.now);
  for (int i = 0; i < 30; ++i) h.cycle();
  EXPECT_EQ(MoveBaseState::kControlling, h.core.state());
  EXPECT_GT(std::fabs(h.velocity.x), 0.05);
  h.core.cancel();
  EXPECT_FALSE(h.core.active());
  const CycleOutput out = h.core.runCycle(CycleInput{h.now, h.pose, h.pose, h.velocity});
  EXPECT_FALSE(out.publish_command);
  EXPECT_EQ(CycleOutput::Outcome::kNone, out.outcome);
}

TEST(MoveBaseCore, APlanReachesTheControllerAtTheNextCycle) {
  // move_base's planner thread hands a plan over to the control loop, whose cycle that woke the
  // thread has already read the controller's plan: the first command follows the plan's cycle.
  Harness h(doorRoom(), {0.5, 0.5, 0.0});
  h.core.setGoal({3.4, 0.6, 0.0}, h.now);
  const CycleOutput planned = h.cycle();
  EXPECT_TRUE(planned.new_plan);
  EXPECT_FALSE(planned.publish_command);
  EXPECT_EQ(MoveBaseState::kPlanning, h.core.state());
  const CycleOutput first_control = h.cycle();
  EXPECT_FALSE(first_control.new_plan);
  EXPECT_TRUE(first_control.publish_command);
  EXPECT_FALSE(first_control.local_plan.empty()) << "the controller follows the plan of the cycle before";
  EXPECT_EQ(MoveBaseState::kControlling, h.core.state());
  // A re-plan while controlling (5 Hz, every second cycle) is followed from the cycle after it.
  const CycleOutput replanned = h.cycle();
  EXPECT_TRUE(replanned.new_plan);
  EXPECT_TRUE(replanned.publish_command);
}
