// The simulator node's settings: defaults, and one check per bad value naming the setting.
#include <gtest/gtest.h>

#include <functional>

#include "marl_mrta/sim/sim_config.h"

namespace marl_mrta {
namespace sim {
namespace {

SimConfig validConfig() {
  SimConfig config;
  config.map_file = "maps/lab.yaml";
  return config;
}

// The ConfigError of makeWorldConfig after `change`, or "accepted".
std::string errorAfter(const std::function<void(SimConfig&)>& change) {
  SimConfig config = validConfig();
  change(config);
  try {
    makeWorldConfig(config);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(SimConfig, DefaultsAreTheArchitectureOnes) {
  const WorldConfig world = makeWorldConfig(validConfig());
  ASSERT_EQ(world.start_poses.size(), 2u);  // robots: 2 of the four default start poses
  EXPECT_EQ(world.start_poses[1].x, 0.5);
  EXPECT_EQ(world.start_poses[1].y, 4.5);
  EXPECT_EQ(world.physics_rate, 20.0);
  EXPECT_EQ(world.scan_rate, 5.0);
  EXPECT_EQ(world.robot.limits.max_linear_velocity, 0.22);
  EXPECT_EQ(world.robot.limits.max_angular_velocity, 2.84);
  EXPECT_EQ(world.noise.linear_speed_scale, 1.0);
  EXPECT_FALSE(world.robot.lidar.invalid_as_inf);
}

TEST(SimConfig, SettingsReachTheWorld) {
  SimConfig config = validConfig();
  config.robots = 4;
  config.arenas = 3;
  config.noise_profile = "measured_tb3";
  config.scan_invalid_as_inf = true;
  config.seed = 9;
  const WorldConfig world = makeWorldConfig(config);
  EXPECT_EQ(world.start_poses.size(), 4u);
  EXPECT_EQ(world.arenas, 3);
  EXPECT_NEAR(world.noise.linear_speed_scale, 0.19 / 0.22, 1e-12);
  EXPECT_TRUE(world.robot.lidar.invalid_as_inf);
  EXPECT_EQ(world.seed, 9u);
  const std::vector<std::string> names = robotNamespaces(config);
  ASSERT_EQ(names.size(), 12u);
  EXPECT_EQ(names[0], "arena_0/tb3_0");
  EXPECT_EQ(names[11], "arena_2/tb3_3");
}

TEST(SimConfig, EachBadValueNamesItsSetting) {
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.noise_profile = "foo"; }),
            "noise_profile: unknown value 'foo' (expected ideal, measured_tb3)");
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.robots = 5; }),
            "start_poses: 4 poses for robots: 5 (give one [x, y, yaw] per robot)");
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.robots = 0; }), "robots: must be at least 1, got 0");
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.physics_rate = 10.0; }), "physics_rate: must be at least 20 Hz, got 10");
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.rtf = -1.0; }).substr(0, 5), "rtf: ");
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.map_file.clear(); }).substr(0, 10), "map_file: ");
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.lockstep_robots = {"tb3_0", "tb3_7"}; }),
            "lockstep_robots: unknown robot 'tb3_7' (robots: tb3_0, tb3_1)");
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.lockstep_robots = {"tb3_1"}; }), "accepted");
}

}  // namespace
}  // namespace sim
}  // namespace marl_mrta
