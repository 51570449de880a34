// Differential drive: velocity and acceleration limits, watchdog, odometry, noise profiles,
// determinism of the fixed-step world.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>

#include "marl_mrta/sim/diff_drive.h"
#include "marl_mrta/sim/world.h"
#include "sim_test_maps.h"

namespace marl_mrta {
namespace sim {
namespace {

using testing::idealConfig;
using testing::room;

constexpr double kEps = 1e-9;

TEST(DiffDrive, LimitVelocityClampsAndRejectsNonFinite) {
  const DriveLimits limits;
  const Twist2D fast = limitVelocity({1.0, -10.0}, limits);
  EXPECT_DOUBLE_EQ(fast.linear, 0.22);
  EXPECT_DOUBLE_EQ(fast.angular, -2.84);
  const Twist2D bad = limitVelocity({std::nan(""), INFINITY}, limits);
  EXPECT_EQ(bad.linear, 0.0);
  EXPECT_EQ(bad.angular, 0.0);
}

TEST(DiffDrive, IntegrateFollowsArcsAndLines) {
  const Pose2D straight = integrate({1.0, 2.0, M_PI / 2}, {0.2, 0.0}, 0.5);
  EXPECT_NEAR(straight.x, 1.0, 1e-12);
  EXPECT_NEAR(straight.y, 2.1, 1e-12);
  // A quarter circle of radius 1 from the origin heading +x ends at (1, 1) heading +y.
  const Pose2D arc = integrate({0.0, 0.0, 0.0}, {M_PI / 2, M_PI / 2}, 1.0);
  EXPECT_NEAR(arc.x, 1.0, 1e-12);
  EXPECT_NEAR(arc.y, 1.0, 1e-12);
  EXPECT_NEAR(arc.yaw, M_PI / 2, 1e-12);
}

// Every tick: |v| and |w| within the Burger's limits, and their changes within the
// acceleration limits, for commands far beyond both (and sudden reversals).
TEST(DiffDrive, LimitsAndAccelerationsAreNeverExceeded) {
  const map::OccupancyMap map = room(20.0, 20.0);
  WorldConfig config = idealConfig({{10.0, 10.0, 0.0}});
  World world(map, config);
  const DriveLimits& limits = config.robot.limits;
  const double dt = world.timeStep();
  const Twist2D commands[] = {{5.0, 20.0}, {-5.0, -20.0}, {0.3, -3.0}, {0.0, 0.0}, {-1.0, 1.0}};
  Twist2D previous = world.robot(0).velocity;
  Pose2D previous_pose = world.robot(0).pose;
  double top_linear = 0.0, top_angular = 0.0;
  for (const Twist2D& command : commands) {
    for (int t = 0; t < 40; ++t) {
      world.setCommand(0, command);
      world.step();
      const Twist2D v = world.robot(0).velocity;
      ASSERT_LE(std::abs(v.linear), limits.max_linear_velocity + kEps);
      ASSERT_LE(std::abs(v.angular), limits.max_angular_velocity + kEps);
      ASSERT_LE(std::abs(v.linear - previous.linear), limits.max_linear_acceleration * dt + kEps);
      ASSERT_LE(std::abs(v.angular - previous.angular), limits.max_angular_acceleration * dt + kEps);
      // The ground truth moves no faster than the limit either.
      const Pose2D pose = world.robot(0).pose;
      ASSERT_LE(std::hypot(pose.x - previous_pose.x, pose.y - previous_pose.y),
                limits.max_linear_velocity * dt + kEps);
      top_linear = std::max(top_linear, std::abs(v.linear));
      top_angular = std::max(top_angular, std::abs(v.angular));
      previous = v;
      previous_pose = pose;
    }
  }
  // The limits are reached, so the checks above were not vacuous.
  EXPECT_NEAR(top_linear, limits.max_linear_velocity, kEps);
  EXPECT_NEAR(top_angular, limits.max_angular_velocity, kEps);
}

TEST(DiffDrive, WatchdogStopsTheRobotWhenCommandsStop) {
  const map::OccupancyMap map = room(20.0, 20.0);
  WorldConfig config = idealConfig({{5.0, 10.0, 0.0}});
  config.cmd_vel_timeout = 0.5;
  World world(map, config);
  world.setCommand(0, {0.2, 0.0});
  for (int t = 0; t < 9; ++t) world.step();  // 0.45 s: still driving
  EXPECT_NEAR(world.robot(0).velocity.linear, 0.2, kEps);
  for (int t = 0; t < 11; ++t) world.step();  // past 0.5 s, plus the deceleration
  EXPECT_EQ(world.robot(0).velocity.linear, 0.0);
  const Pose2D stopped = world.robot(0).pose;
  for (int t = 0; t < 20; ++t) world.step();
  EXPECT_EQ(world.robot(0).pose.x, stopped.x);
  // A new command revives it.
  world.setCommand(0, {0.2, 0.0});
  world.step();
  EXPECT_GT(world.robot(0).velocity.linear, 0.0);
}

TEST(DiffDrive, IdealOdometryEqualsGroundTruthMotion) {
  const map::OccupancyMap map = room(20.0, 20.0);
  const Pose2D start{8.0, 9.0, 0.7};
  World world(map, idealConfig({start}));
  for (int t = 0; t < 200; ++t) {
    world.setCommand(0, {0.2, 1.5 * std::sin(t * 0.05)});
    world.step();
  }
  const Pose2D truth = world.robot(0).pose;
  const Pose2D odom = world.robot(0).odom_pose;
  // Odometry starts at zero at the start pose: the truth expressed in the start frame.
  const double dx = truth.x - start.x, dy = truth.y - start.y;
  EXPECT_NEAR(odom.x, std::cos(start.yaw) * dx + std::sin(start.yaw) * dy, 1e-9);
  EXPECT_NEAR(odom.y, -std::sin(start.yaw) * dx + std::cos(start.yaw) * dy, 1e-9);
  EXPECT_NEAR(normalizeAngle(odom.yaw - (truth.yaw - start.yaw)), 0.0, 1e-9);
  EXPECT_GT(std::hypot(dx, dy), 0.5);
}

TEST(DiffDrive, MeasuredProfileIsSlowerDriftsAndIsReproducible) {
  const map::OccupancyMap map = room(40.0, 20.0);
  WorldConfig config = idealConfig({{2.0, 10.0, 0.0}});
  config.noise = testing::noiseProfile("measured_tb3");
  config.noise.pause_rate = 0.0;  // pauses are tested below; here the steady speed
  config.seed = 3;
  auto run = [&](uint64_t seed) {
    WorldConfig c = config;
    c.seed = seed;
    World world(map, c);
    testing::driveAll(world, {0.22, 0.0}, 400);  // 20 s
    return world.robot(0);
  };
  const RobotState a = run(3), b = run(3), c = run(4);
  EXPECT_NEAR(a.velocity.linear, 0.19, 1e-9);  // 0.19 m/s achieved for 0.22 commanded
  EXPECT_EQ(a.pose.x, b.pose.x);
  EXPECT_EQ(a.odom_pose.x, b.odom_pose.x);
  EXPECT_EQ(a.odom_pose.y, b.odom_pose.y);
  EXPECT_NE(a.odom_pose.y, c.odom_pose.y);
  // Odometry drifts from the truth (the truth drives straight along y = 10).
  EXPECT_NEAR(a.pose.y, 10.0, 1e-9);
  EXPECT_GT(std::abs(a.odom_pose.y) + std::abs(a.odom_pose.x - (a.pose.x - 2.0)), 1e-3);
}

TEST(DiffDrive, CommandLatencyDelaysTheResponse) {
  const map::OccupancyMap map = room(20.0, 20.0);
  WorldConfig config = idealConfig({{5.0, 10.0, 0.0}});
  config.noise.command_latency_min = 0.12;  // 2.4 ticks -> applied 3 ticks later
  config.noise.command_latency_max = 0.12;
  World world(map, config);
  world.setCommand(0, {0.2, 0.0});
  for (int t = 0; t < 3; ++t) {
    world.step();
    EXPECT_EQ(world.robot(0).velocity.linear, 0.0) << "tick " << world.tick();
  }
  world.step();
  EXPECT_GT(world.robot(0).velocity.linear, 0.0);
}

TEST(DiffDrive, PausesStopADrivingRobotForAWhile) {
  const map::OccupancyMap map = room(40.0, 20.0);
  WorldConfig config = idealConfig({{2.0, 10.0, 0.0}});
  config.noise.pause_rate = 0.5;  // often, to see several in a short run
  config.noise.pause_duration_min = 0.5;
  config.noise.pause_duration_max = 1.2;
  World world(map, config);
  int stopped_ticks = 0;
  for (int t = 0; t < 1200; ++t) {
    world.setCommand(0, {0.2, 0.0});
    world.step();
    stopped_ticks += world.robot(0).velocity.linear < 0.1;
  }
  // About 0.5 pauses/s of ~0.85 s while driving: a sizeable share of a minute, never all of it.
  EXPECT_GT(stopped_ticks, 100);
  EXPECT_LT(stopped_ticks, 900);
}

TEST(World, SameCommandsGiveBitIdenticalResults) {
  map::OccupancyMap map = room(7.0, 5.0);
  testing::addBox(map, 3.0, 1.0, 3.4, 1.4);
  WorldConfig config = idealConfig({{1.0, 1.0, 0.0}, {1.0, 4.0, 0.0}, {6.0, 2.5, M_PI}});
  config.noise = testing::noiseProfile("measured_tb3");
  config.seed = 11;
  auto run = [&] {
    World world(map, config);
    for (int t = 0; t < 600; ++t) {
      for (int g = 0; g < world.robotCount(); ++g) {
        world.setCommand(g, {0.22 * std::cos(t * 0.01 * (g + 1)), 2.0 * std::sin(t * 0.013 * (g + 2))});
      }
      world.step();
    }
    return world;
  };
  const World a = run(), b = run();
  for (int g = 0; g < a.robotCount(); ++g) {
    EXPECT_EQ(a.robot(g).pose.x, b.robot(g).pose.x);
    EXPECT_EQ(a.robot(g).pose.y, b.robot(g).pose.y);
    EXPECT_EQ(a.robot(g).pose.yaw, b.robot(g).pose.yaw);
    EXPECT_EQ(a.robot(g).scan, b.robot(g).scan);
  }
}

// An episode reset with a seed draws the same noise whatever ran before it: a launch that
// ticked longer before its first episode (start-up) gives the same episode.
TEST(World, AnEpisodeSeedMakesTheEpisodeIndependentOfEarlierTicks) {
  map::OccupancyMap map = room(7.0, 5.0);
  testing::addBox(map, 3.0, 1.0, 3.4, 1.4);
  WorldConfig config = idealConfig({{1.0, 1.0, 0.0}, {1.0, 4.0, 0.0}});
  config.noise = testing::noiseProfile("measured_tb3");
  config.seed = 3;
  // `earlier` ticks of driving (a multiple of the scan period, so sensors keep their phase),
  // then an episode reset with `episode_seed` and 600 ticks of the same commands.
  auto episode = [&](int earlier, std::optional<uint64_t> episode_seed) {
    World world(map, config);
    for (int t = 0; t < earlier; ++t) {
      for (int g = 0; g < world.robotCount(); ++g) world.setCommand(g, {0.2, 0.5});
      world.step();
    }
    EXPECT_EQ(world.reset(-1, {}, episode_seed), "");
    for (int t = 0; t < 600; ++t) {
      for (int g = 0; g < world.robotCount(); ++g) {
        world.setCommand(g, {0.22 * std::cos(t * 0.01 * (g + 1)), 2.0 * std::sin(t * 0.013 * (g + 2))});
      }
      world.step();
    }
    return world;
  };
  auto same = [](const World& a, const World& b) {
    for (int g = 0; g < a.robotCount(); ++g) {
      if (a.robot(g).pose.x != b.robot(g).pose.x || a.robot(g).pose.y != b.robot(g).pose.y ||
          a.robot(g).pose.yaw != b.robot(g).pose.yaw || a.robot(g).scan != b.robot(g).scan) {
        return false;
      }
    }
    return true;
  };
  EXPECT_TRUE(same(episode(40, 7), episode(200, 7)));
  EXPECT_FALSE(same(episode(40, 7), episode(40, 8)));                        // the seed matters
  EXPECT_FALSE(same(episode(40, std::nullopt), episode(200, std::nullopt)));  // streams ran on
}

TEST(World, SensorsAreDueAtTheirRates) {
  const map::OccupancyMap map = room(5.0, 4.0);
  WorldConfig config = idealConfig({{2.5, 2.0, 0.0}});
  config.physics_rate = 40.0;
  config.scan_rate = 5.0;
  config.odom_rate = 10.0;
  World world(map, config);
  int scans = 0, odoms = 0;
  for (int t = 0; t < 400; ++t) {  // 10 s
    const StepReport& report = world.step();
    scans += report.scan_updated;
    odoms += report.odom_due;
    if (report.scan_updated) {
      EXPECT_EQ(world.robot(0).scan_tick, world.tick());
    }
  }
  EXPECT_EQ(scans, 50);
  EXPECT_EQ(odoms, 100);
  EXPECT_DOUBLE_EQ(world.time(), 10.0);
}

TEST(World, BadConfigurationNamesTheField) {
  const map::OccupancyMap map = room(5.0, 4.0);
  WorldConfig config = idealConfig({{2.5, 2.0, 0.0}});
  config.scan_rate = 50.0;
  try {
    World world(map, config);
    FAIL() << "accepted scan_rate above physics_rate";
  } catch (const nav::ParamError& e) {
    EXPECT_EQ(e.where(), "scan_rate");
  }
}

}  // namespace
}  // namespace sim
}  // namespace marl_mrta
