// DWA local planner: velocity and acceleration limits, obstacles ahead, reaching a goal.
#include <gtest/gtest.h>

#include <cmath>

#include "marl_mrta/nav/inflation_layer.h"
#include "marl_mrta/nav/local_controller.h"
#include "marl_mrta/nav/static_layer.h"
#include "nav_test_helpers.h"

using namespace marl_mrta::nav;
using namespace marl_mrta::nav::testing;

namespace {

// TurtleBot3 Burger's dwa_local_planner_params_burger.yaml.
DwaConfig burgerDwa() {
  DwaConfig c;
  c.limits.max_vel_x = 0.22;
  c.limits.min_vel_x = -0.22;
  c.limits.max_vel_y = c.limits.min_vel_y = 0.0;
  c.limits.max_vel_trans = 0.22;
  c.limits.min_vel_trans = 0.11;
  c.limits.max_vel_theta = 2.75;
  c.limits.min_vel_theta = 1.37;
  c.limits.acc_lim_x = 2.5;
  c.limits.acc_lim_y = 0.0;
  c.limits.acc_lim_theta = 3.2;
  c.limits.xy_goal_tolerance = 0.05;
  c.limits.yaw_goal_tolerance = 0.17;
  c.sim_time = 1.5;
  c.vx_samples = 20;
  c.vy_samples = 1;
  c.vth_samples = 40;
  c.sim_period = 0.1;
  c.path_distance_bias = 32.0;
  c.goal_distance_bias = 20.0;
  c.occdist_scale = 0.02;
  c.forward_point_distance = 0.325;
  c.oscillation_reset_dist = 0.05;
  return c;
}

std::unique_ptr<LayeredCostmap> costmapOf(const marl_mrta::map::OccupancyMap& m) {
  auto costmap = std::make_unique<LayeredCostmap>(false, false);
  costmap->setFootprint(padFootprint(burgerFootprint(), 0.01));
  auto layer = std::make_unique<StaticLayer>("static_layer", StaticLayerConfig{}, *costmap);
  layer->setMap(m);
  costmap->addLayer(std::move(layer));
  costmap->addLayer(std::make_unique<InflationLayer>("inflation_layer", InflationLayerConfig{1.0, 3.0, false}));
  costmap->updateMap(Pose2D{});
  return costmap;
}

std::vector<Pose2D> straightPlan(const Pose2D& from, const Pose2D& to, double step = 0.025) {
  std::vector<Pose2D> plan;
  const double length = std::hypot(to.x - from.x, to.y - from.y);
  const int n = static_cast<int>(std::ceil(length / step));
  for (int i = 0; i < n; ++i) plan.push_back({from.x + (to.x - from.x) * i / n, from.y + (to.y - from.y) * i / n, 0.0});
  plan.push_back(to);
  return plan;
}

// A unicycle that follows commands within the acceleration limits (as the simulator does).
struct Robot {
  Pose2D pose;
  Velocity2D velocity;
  void step(const Velocity2D& command, const LocalPlannerLimits& l, double dt) {
    auto approach = [dt](double current, double target, double acc) {
      return current + std::max(-acc * dt, std::min(acc * dt, target - current));
    };
    velocity.x = approach(velocity.x, command.x, l.acc_lim_x);
    velocity.theta = approach(velocity.theta, command.theta, l.acc_lim_theta);
    pose.x += velocity.x * std::cos(pose.yaw) * dt;
    pose.y += velocity.x * std::sin(pose.yaw) * dt;
    pose.yaw = normalizeAngle(pose.yaw + velocity.theta * dt);
  }
};

bool inCollision(const CostGrid& g, const Pose2D& pose) {
  std::vector<double> xs, ys;
  transformFootprint(burgerFootprint(), pose, xs, ys);
  for (unsigned index : g.convexFillCells(xs, ys)) {
    if (g.cells()[index] == kLethalObstacle) return true;
  }
  return false;
}

}  // namespace

TEST(Dwa, SamplesStayInsideVelocityLimitsAndAccelerationWindow) {
  const DwaConfig config = burgerDwa();
  DwaPlanner planner(config);
  const LocalPlannerLimits& l = config.limits;
  for (double vx = -0.22; vx <= 0.2201; vx += 0.055) {
    for (double vth = -2.75; vth <= 2.7501; vth += 0.55) {
      const std::vector<Velocity2D> samples = planner.velocitySamples({vx, 0.0, vth});
      ASSERT_FALSE(samples.empty());
      for (const Velocity2D& s : samples) {
        EXPECT_GE(s.x, l.min_vel_x - 1e-9);
        EXPECT_LE(s.x, l.max_vel_x + 1e-9);
        EXPECT_LE(std::fabs(s.theta), l.max_vel_theta + 1e-9);
        EXPECT_LE(std::fabs(s.x - vx), l.acc_lim_x * config.sim_period + 1e-9);
        EXPECT_LE(std::fabs(s.theta - vth), l.acc_lim_theta * config.sim_period + 1e-9);
        EXPECT_EQ(0.0, s.y);
      }
    }
  }
}

TEST(Dwa, CommandsRespectLimitsWhileDriving) {
  // Closed loop along an L-shaped route: every command within limits and the window.
  const auto m = roomMap(80, 80, {{20, 0, 24, 50}});
  auto costmap = costmapOf(m);
  const DwaConfig config = burgerDwa();
  LocalController controller(config);
  std::vector<Pose2D> plan = straightPlan({0.5, 0.5, 0}, {0.5, 3.0, 0});
  const std::vector<Pose2D> second = straightPlan({0.5, 3.0, 0}, {3.0, 3.0, 0});
  plan.insert(plan.end(), second.begin() + 1, second.end());
  controller.setPlan(plan, LocalController::PlanUpdate::kNewRoute);
  Robot robot{{0.5, 0.5, M_PI / 2}, {}};
  const LocalPlannerLimits& l = config.limits;
  int commands = 0;
  for (int step = 0; step < 400 && !controller.isGoalReached(robot.pose, robot.velocity, {}); ++step) {
    const ControlResult r =
        controller.computeVelocityCommands(costmap->costmap(), costmap->footprint(), robot.pose, robot.velocity, {});
    ASSERT_TRUE(r.ok) << r.message << " at step " << step;
    ++commands;
    EXPECT_LE(r.command.x, l.max_vel_x + 1e-9);
    EXPECT_GE(r.command.x, l.min_vel_x - 1e-9);
    EXPECT_LE(std::hypot(r.command.x, r.command.y), l.max_vel_trans + 1e-4);
    EXPECT_LE(std::fabs(r.command.theta), l.max_vel_theta + 1e-9);
    if (!controller.isPositionReached(robot.pose, {})) {
      // The sampling planner (not the final in-place turn) stays inside the dynamic window.
      EXPECT_LE(std::fabs(r.command.x - robot.velocity.x), l.acc_lim_x * config.sim_period + 1e-9);
      EXPECT_LE(std::fabs(r.command.theta - robot.velocity.theta), l.acc_lim_theta * config.sim_period + 1e-9);
    }
    robot.step(r.command, l, config.sim_period);
    ASSERT_FALSE(inCollision(costmap->costmap(), robot.pose)) << "collision at step " << step;
  }
  EXPECT_TRUE(controller.isGoalReached(robot.pose, robot.velocity, {}));
  EXPECT_GT(commands, 50);
}

TEST(Dwa, StopsBeforeAWallStraightAhead) {
  // The plan runs straight through a wall across the whole room (e.g. a closed door).
  const auto m = roomMap(100, 60, {{50, 0, 52, 60}});
  auto costmap = costmapOf(m);
  const DwaConfig config = burgerDwa();
  LocalController controller(config);
  controller.setPlan(straightPlan({0.5, 1.5, 0}, {4.5, 1.5, 0}), LocalController::PlanUpdate::kNewRoute);
  Robot robot{{1.2, 1.5, 0.0}, {0.22, 0.0, 0.0}};  // at full speed, 1.3 m from the wall
  double max_x = robot.pose.x;
  for (int step = 0; step < 200; ++step) {
    const ControlResult r =
        controller.computeVelocityCommands(costmap->costmap(), costmap->footprint(), robot.pose, robot.velocity, {});
    robot.step(r.ok ? r.command : Velocity2D{}, config.limits, config.sim_period);
    max_x = std::max(max_x, robot.pose.x);
    ASSERT_FALSE(inCollision(costmap->costmap(), robot.pose)) << "collision at step " << step;
  }
  EXPECT_LT(max_x + 0.041, 2.5) << "front of the robot must stay before the wall at x = 2.5 m";
  EXPECT_LT(std::fabs(robot.velocity.x), 1e-6) << "the robot must have stopped";
}

TEST(Dwa, NeverDrivesIntoAnObstacleOnThePath) {
  // An obstacle appeared on the plan (the plan is stale): DWA goes around it or stops, never into it.
  const auto m = roomMap(100, 60, {{48, 24, 56, 36}});
  auto costmap = costmapOf(m);
  const DwaConfig config = burgerDwa();
  LocalController controller(config);
  controller.setPlan(straightPlan({0.5, 1.5, 0}, {4.5, 1.5, 0}), LocalController::PlanUpdate::kNewRoute);
  Robot robot{{0.5, 1.5, 0.0}, {}};
  for (int step = 0; step < 300; ++step) {
    const ControlResult r =
        controller.computeVelocityCommands(costmap->costmap(), costmap->footprint(), robot.pose, robot.velocity, {});
    robot.step(r.ok ? r.command : Velocity2D{}, config.limits, config.sim_period);
    ASSERT_FALSE(inCollision(costmap->costmap(), robot.pose)) << "collision at step " << step;
  }
  EXPECT_GT(robot.pose.x, 1.0) << "the robot should at least have driven towards the obstacle";
}

TEST(Dwa, FindBestPathPicksWhatScoringEverySampleWouldPick) {
  // findBestPath() skips footprint checks that cannot change the winner; scoring every sample
  // whole, in sample order, must pick the same one (the first of the lowest cost), near and
  // far from obstacles, with the obstacle critic weak (TurtleBot3) and strong.
  const auto m = roomMap(100, 60, {{40, 20, 46, 34}, {60, 0, 62, 26}, {70, 36, 78, 44}});
  auto costmap = costmapOf(m);
  const std::vector<Pose2D> plan = straightPlan({0.3, 1.5, 0}, {4.7, 1.5, 0});
  int compared = 0, differs_from_weak = 0;
  for (const double occdist_scale : {0.02, 2.0}) {
    DwaConfig config = burgerDwa();
    config.occdist_scale = occdist_scale;
    DwaPlanner planner(config);
    for (double x = 0.6; x < 4.5; x += 0.23) {
      for (const double yaw : {-0.9, -0.3, 0.0, 0.4, 1.1}) {
        for (const Velocity2D velocity : {Velocity2D{0.0, 0.0, 0.0}, Velocity2D{0.2, 0.0, 0.5}, Velocity2D{0.1, 0.0, -1.2}}) {
          const Pose2D pose{x, 1.5 + 0.3 * std::sin(3.0 * x), yaw};
          planner.updatePlanAndLocalCosts(costmap->costmap(), pose, plan, costmap->footprint());
          // Every sample scored whole: what trajectory_cloud shows (exploreSamples).
          double best_cost = -1.0;
          Velocity2D best;
          for (const Trajectory& t : planner.exploreSamples(pose, velocity)) {
            if (t.cost >= 0.0 && (best_cost < 0.0 || t.cost < best_cost)) {
              best_cost = t.cost;
              best = {t.xv, t.yv, t.thetav};
            }
          }
          const Trajectory chosen = planner.findBestPath(pose, velocity);
          planner.resetOscillationFlags();
          if (best_cost < 0.0) {
            EXPECT_LT(chosen.cost, 0.0) << "x " << x << " yaw " << yaw;
            continue;
          }
          ASSERT_EQ(best_cost, chosen.cost) << "x " << x << " yaw " << yaw << " occdist " << occdist_scale;
          ++compared;
          EXPECT_EQ(best.x, chosen.xv);
          EXPECT_EQ(best.theta, chosen.thetav);
          ASSERT_FALSE(chosen.points.empty());
          EXPECT_EQ(pose.x, chosen.points.front().x);
          if (occdist_scale > 1.0) {
            DwaConfig weak_config = burgerDwa();
            DwaPlanner weak(weak_config);
            weak.updatePlanAndLocalCosts(costmap->costmap(), pose, plan, costmap->footprint());
            const Trajectory w = weak.findBestPath(pose, velocity);
            differs_from_weak += w.xv != chosen.xv || w.thetav != chosen.thetav;
          }
        }
      }
    }
  }
  EXPECT_GT(compared, 150);
  // The strong obstacle critic must change some choices, or the check above proves little.
  EXPECT_GT(differs_from_weak, 5);
}

TEST(Dwa, ExploredSamplesAreTheDynamicWindowsRollouts) {
  const auto m = roomMap(100, 60, {{60, 0, 62, 26}});
  auto costmap = costmapOf(m);
  DwaPlanner planner(burgerDwa());
  const Pose2D pose{2.75, 0.8, 0.0};
  const Velocity2D velocity{0.2, 0.0, 0.0};
  planner.updatePlanAndLocalCosts(costmap->costmap(), pose, straightPlan({2.0, 1.0, 0}, {4.5, 1.0, 0}),
                                  costmap->footprint());
  const std::vector<Trajectory> explored = planner.exploreSamples(pose, velocity);
  size_t rolled_out = 0, valid = 0, discarded = 0;
  for (const Velocity2D& sample : planner.velocitySamples(velocity)) {
    Trajectory t;
    rolled_out += planner.generateTrajectory(pose, sample, t);
  }
  ASSERT_EQ(rolled_out, explored.size());
  for (const Trajectory& t : explored) {
    ASSERT_FALSE(t.points.empty());
    EXPECT_EQ(pose.x, t.points.front().x);
    (t.cost >= 0.0 ? valid : discarded) += 1;
  }
  EXPECT_GT(valid, 0u);
  EXPECT_GT(discarded, 0u) << "the wall 0.25 m ahead must discard the fast straight rollouts";
}

TEST(Dwa, CellCostsAreTheDistanceCriticsGrids) {
  // dwa_local_planner's cost_cloud: path and goal distance in cells, the cell cost, and the
  // critics' weighted sum; no cell on or next to an obstacle.
  const auto m = roomMap(100, 60, {{60, 0, 62, 26}});
  auto costmap = costmapOf(m);
  const DwaConfig config = burgerDwa();
  DwaPlanner planner(config);
  const Pose2D pose{1.5, 1.5, 0.0};
  planner.updatePlanAndLocalCosts(costmap->costmap(), pose, straightPlan({1.0, 1.5, 0}, {4.0, 1.5, 0}),
                                  costmap->footprint());
  const std::vector<DwaPlanner::CellCosts> cells = planner.cellCosts();
  const CostGrid& grid = costmap->costmap();
  ASSERT_GT(cells.size(), grid.sizeX() * grid.sizeY() / 2);
  EXPECT_LT(cells.size(), grid.sizeX() * grid.sizeY()) << "the wall's cells must be left out";
  size_t on_path = 0, at_goal = 0;
  for (const DwaPlanner::CellCosts& c : cells) {
    unsigned mx = 0, my = 0;
    ASSERT_TRUE(grid.worldToMap(c.x, c.y, mx, my));
    EXPECT_EQ(static_cast<double>(grid.cost(mx, my)), c.occupancy);
    EXPECT_LT(c.occupancy, 253.0);
    const double res = grid.resolution();
    EXPECT_NEAR(res * config.path_distance_bias * c.path + res * config.goal_distance_bias * c.goal +
                    config.occdist_scale * c.occupancy, c.total, 1e-9);
    on_path += c.path == 0.0 && std::fabs(c.y - 1.5) < res;
    at_goal += c.goal == 0.0;
  }
  EXPECT_GT(on_path, 20u) << "the plan's cells are at path distance 0";
  EXPECT_EQ(1u, at_goal) << "one local goal cell";
}

TEST(Dwa, ReachesGoalPositionAndYawWithinTolerance) {
  const auto m = roomMap(80, 80, {});
  auto costmap = costmapOf(m);
  const DwaConfig config = burgerDwa();
  LocalController controller(config);
  const Pose2D goal{2.5, 1.8, M_PI / 2};
  controller.setPlan(straightPlan({1.0, 1.0, 0}, goal), LocalController::PlanUpdate::kNewRoute);
  Robot robot{{1.0, 1.0, 0.0}, {}};
  // Odometry frame shifted against the map frame: the controller works in "odom".
  const Transform2D map_to_odom{0.3, -0.2, 0.1};
  bool reached = false;
  for (int step = 0; step < 600 && !reached; ++step) {
    const Pose2D pose_odom = map_to_odom.apply(robot.pose);
    reached = controller.isGoalReached(pose_odom, robot.velocity, map_to_odom);
    if (reached) break;
    const ControlResult r = controller.computeVelocityCommands(costmap->costmap(), costmap->footprint(), pose_odom,
                                                               robot.velocity, map_to_odom);
    robot.step(r.ok ? r.command : Velocity2D{}, config.limits, config.sim_period);
  }
  ASSERT_TRUE(reached);
  EXPECT_LE(std::hypot(robot.pose.x - goal.x, robot.pose.y - goal.y), 0.05);
  EXPECT_LE(std::fabs(normalizeAngle(robot.pose.yaw - goal.yaw)), 0.17);
}

TEST(Dwa, FinalTurnIsNotInterruptedByReplanning) {
  // At the goal position facing the opposite way, with the plan re-sent every cycle (as
  // move_base re-plans at planner_frequency): the turn must keep going, not brake each time.
  const auto m = roomMap(80, 80, {});
  auto costmap = costmapOf(m);
  const DwaConfig config = burgerDwa();
  LocalController controller(config);
  const Pose2D goal{2.0, 2.0, M_PI};
  const auto plan = straightPlan({1.5, 2.0, 0}, goal);
  controller.startGoal();
  Robot robot{{2.0, 2.0, 0.0}, {}};
  const Transform2D identity{};
  int cycles = 0;
  for (; cycles < 100; ++cycles) {
    controller.setPlan(plan, LocalController::PlanUpdate::kReplan);
    if (controller.isGoalReached(robot.pose, robot.velocity, identity)) break;
    const ControlResult r = controller.computeVelocityCommands(costmap->costmap(), costmap->footprint(), robot.pose,
                                                               robot.velocity, identity);
    ASSERT_TRUE(r.ok) << r.message;
    robot.step(r.command, config.limits, config.sim_period);
  }
  // pi rad at up to 2.75 rad/s with 3.2 rad/s^2: about 2 s; braking at every re-plan takes 3x longer.
  EXPECT_LE(cycles * config.sim_period, 3.0);
  EXPECT_LE(std::fabs(normalizeAngle(robot.pose.yaw - goal.yaw)), 0.17);
}

TEST(Dwa, ReplanningKeepsTheOscillationRestrictionANewRouteClearsIt) {
  // Forward, then backward (the plan turned round): forward is forbidden until the robot has
  // moved oscillation_reset_dist. move_base's periodic re-plans must keep that restriction, or
  // a forward/backward dither in step with them never ends (the doors map's pocket exit).
  const auto m = roomMap(80, 60, {});
  auto costmap = costmapOf(m);
  LocalController controller(burgerDwa());
  const Pose2D pose{2.0, 1.5, 0.0};
  const auto ahead = straightPlan(pose, {3.0, 1.5, 0.0});
  const auto behind = straightPlan(pose, {1.0, 1.5, 0.0});
  const Transform2D identity{};
  auto command = [&](const std::vector<Pose2D>& plan, LocalController::PlanUpdate update) {
    controller.setPlan(plan, update);
    const ControlResult r =
        controller.computeVelocityCommands(costmap->costmap(), costmap->footprint(), pose, Velocity2D{}, identity);
    EXPECT_TRUE(r.ok) << r.message;
    return r.command;
  };
  using PlanUpdate = LocalController::PlanUpdate;
  EXPECT_GT(command(ahead, PlanUpdate::kNewRoute).x, 0.0);
  EXPECT_LT(command(behind, PlanUpdate::kReplan).x, 0.0);
  EXPECT_LE(command(ahead, PlanUpdate::kReplan).x, 0.0) << "a re-plan cleared the restriction";
  EXPECT_GT(command(ahead, PlanUpdate::kNewRoute).x, 0.0) << "a new route keeps an old restriction";
}

TEST(Dwa, ARestrictionThatLeavesNoValidSampleIsDropped) {
  // Forward, then backward: only backward is allowed. With a wall right behind the robot no
  // allowed sample is valid; dwa_local_planner's next re-plan would reset the flags, so the
  // planner drops the restriction itself and the next cycle drives forward (before, the robot
  // stood still until move_base aborted the goal: turtlebot3_world, docs/guide/navigation.md).
  const Pose2D pose{2.0, 1.5, 0.0};
  auto free_room = costmapOf(roomMap(80, 60, {}));
  auto wall_behind = costmapOf(roomMap(80, 60, {{34, 0, 36, 60}}));  // x 1.70-1.80 m
  LocalController controller(burgerDwa());
  const auto ahead = straightPlan(pose, {3.0, 1.5, 0.0});
  const auto behind = straightPlan(pose, {1.0, 1.5, 0.0});
  const Transform2D identity{};
  using PlanUpdate = LocalController::PlanUpdate;
  auto control = [&](const LayeredCostmap& costmap, const std::vector<Pose2D>& plan, PlanUpdate update) {
    controller.setPlan(plan, update);
    return controller.computeVelocityCommands(costmap.costmap(), costmap.footprint(), pose, Velocity2D{}, identity);
  };
  ASSERT_GT(control(*free_room, ahead, PlanUpdate::kNewRoute).command.x, 0.0);
  ASSERT_LT(control(*free_room, behind, PlanUpdate::kReplan).command.x, 0.0);
  EXPECT_FALSE(control(*wall_behind, ahead, PlanUpdate::kReplan).ok) << "forward should still be forbidden here";
  const ControlResult next = control(*wall_behind, ahead, PlanUpdate::kReplan);
  ASSERT_TRUE(next.ok) << next.message;
  EXPECT_GT(next.command.x, 0.0);
}

TEST(Transform2D, BetweenMapsOnePoseOntoTheOther) {
  const Pose2D in_map{1.0, 2.0, 0.5}, in_odom{-0.3, 0.7, 2.0};
  const Transform2D t = Transform2D::between(in_map, in_odom);
  const Pose2D mapped = t.apply(in_map);
  EXPECT_NEAR(in_odom.x, mapped.x, 1e-12);
  EXPECT_NEAR(in_odom.y, mapped.y, 1e-12);
  EXPECT_NEAR(in_odom.yaw, mapped.yaw, 1e-12);
}
