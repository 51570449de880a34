// The simulator node's settings: the files sim.launch loads give today's parameters, every
// parameter is read typed and known, and one check per bad value names the setting.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "marl_mrta/sim/sim_config.h"

namespace marl_mrta {
namespace sim {
namespace {

const std::string kConfigDir = std::string(MARL_MRTA_SOURCE_DIR) + "/config/";

// The simulator's private namespace as sim.launch loads it.
YAML::Node launchParameters() {
  YAML::Node tree(YAML::NodeType::Map);
  nav::loadYamlFileInto(tree, kConfigDir + "robot_burger.yaml", "");
  nav::loadYamlFileInto(tree, kConfigDir + "sim.yaml", "");
  nav::loadYamlFileInto(tree, kConfigDir + "noise_profiles.yaml", "noise_profiles");
  nav::setParam(tree, "map_file", YAML::Node(MARL_MRTA_SOURCE_DIR "/maps/lab.yaml"));
  return tree;
}

// The ParamError of readSimConfig with `key` set to the YAML `value`, or "accepted".
std::string readErrorWith(const std::string& key, const std::string& value) {
  YAML::Node tree = launchParameters();
  nav::setParam(tree, key, YAML::Load(value));
  try {
    readSimConfig(nav::ParamNode(tree, "/simulator"));
  } catch (const nav::ParamError& e) {
    return e.what();
  }
  return "accepted";
}

SimConfig validConfig() { return readSimConfig(nav::ParamNode(launchParameters(), "/simulator")); }

// The ParamError of makeWorldConfig after `change`, or "accepted".
std::string errorAfter(const std::function<void(SimConfig&)>& change) {
  SimConfig config = validConfig();
  change(config);
  try {
    makeWorldConfig(config);
  } catch (const nav::ParamError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(SimConfig, TheLaunchFilesGiveTheBurgerAndItsNoise) {
  const SimConfig config = validConfig();
  const RobotSpec& robot = config.robot;
  EXPECT_EQ(robot.radius, 0.105);
  EXPECT_EQ(robot.limits.max_linear_velocity, 0.22);
  EXPECT_EQ(robot.limits.max_angular_velocity, 2.84);
  EXPECT_EQ(robot.limits.max_linear_acceleration, 2.5);
  EXPECT_EQ(robot.limits.max_angular_acceleration, 3.2);
  EXPECT_EQ(robot.lidar.beams, 360);
  EXPECT_EQ(robot.lidar.range_min, 0.12);
  EXPECT_EQ(robot.lidar.range_max, 3.5);
  EXPECT_EQ(robot.lidar.mount_x, -0.032);
  EXPECT_EQ(robot.lidar.mount_y, 0.0);
  EXPECT_EQ(config.scan_rate, 5.0);
  // The defaults of the core are the same robot.
  const RobotSpec defaults;
  EXPECT_EQ(robot.radius, defaults.radius);
  EXPECT_EQ(robot.limits.max_linear_velocity, defaults.limits.max_linear_velocity);
  EXPECT_EQ(robot.limits.max_angular_velocity, defaults.limits.max_angular_velocity);
  EXPECT_EQ(robot.limits.max_linear_acceleration, defaults.limits.max_linear_acceleration);
  EXPECT_EQ(robot.limits.max_angular_acceleration, defaults.limits.max_angular_acceleration);
  EXPECT_EQ(robot.lidar.beams, defaults.lidar.beams);
  EXPECT_EQ(robot.lidar.range_min, defaults.lidar.range_min);
  EXPECT_EQ(robot.lidar.range_max, defaults.lidar.range_max);
  EXPECT_EQ(robot.lidar.mount_x, defaults.lidar.mount_x);
  EXPECT_EQ(robot.lidar.mount_y, defaults.lidar.mount_y);
  EXPECT_EQ(config.scan_rate, SimConfig{}.scan_rate);

  // measured_tb3, to the bit: the constants the simulator was written with.
  ASSERT_EQ(config.noise_profiles.count("measured_tb3"), 1u);
  const NoiseModel& noise = config.noise_profiles.at("measured_tb3");
  EXPECT_EQ(noise.linear_speed_scale, 0.19 / 0.22);
  EXPECT_EQ(noise.command_latency_min, 0.040);
  EXPECT_EQ(noise.command_latency_max, 0.070);
  EXPECT_EQ(noise.pause_rate, 4.5 / 120.0);
  EXPECT_EQ(noise.pause_duration_min, 0.5);
  EXPECT_EQ(noise.pause_duration_max, 1.2);
  EXPECT_EQ(noise.lidar_range_stddev, 0.01);
  EXPECT_EQ(noise.lidar_dropout_min, 0.02);
  EXPECT_EQ(noise.lidar_dropout_max, 0.04);
  EXPECT_EQ(noise.odom_translation_stddev, 0.02);
  EXPECT_EQ(noise.odom_rotation_stddev, 0.05);
  // ideal: every noise absent, also from the file itself.
  for (const auto& profiles : {config.noise_profiles, loadNoiseProfiles(kConfigDir + "noise_profiles.yaml")}) {
    ASSERT_EQ(profiles.count("ideal"), 1u);
    const NoiseModel& ideal = profiles.at("ideal");
    EXPECT_EQ(ideal.linear_speed_scale, 1.0);
    EXPECT_EQ(ideal.command_latency_max, 0.0);
    EXPECT_EQ(ideal.pause_rate, 0.0);
    EXPECT_EQ(ideal.lidar_dropout_max, 0.0);
    EXPECT_EQ(ideal.odom_rotation_stddev, 0.0);
  }
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
  EXPECT_EQ(world.noise.linear_speed_scale, 0.19 / 0.22);
  EXPECT_TRUE(world.robot.lidar.invalid_as_inf);
  EXPECT_EQ(world.seed, 9u);
  const std::vector<std::string> names = robotNamespaces(config);
  ASSERT_EQ(names.size(), 12u);
  EXPECT_EQ(names[0], "arena_0/tb3_0");
  EXPECT_EQ(names[11], "arena_2/tb3_3");
}

TEST(SimConfig, WithoutNoiseProfilesOnlyIdealIsKnown) {
  const SimConfig config = readSimConfig(nav::ParamNode(YAML::Node(YAML::NodeType::Map), "/simulator"));
  ASSERT_EQ(config.noise_profiles.size(), 1u);
  EXPECT_EQ(config.noise_profiles.begin()->first, "ideal");
}

TEST(SimConfig, EachBadParameterNamesIt) {
  EXPECT_EQ(readErrorWith("robts", "3"), "/simulator/robts: unknown parameter (see docs/reference/nodes_sim_nav.md for the list)");
  EXPECT_EQ(readErrorWith("rtf", "fast"), "/simulator/rtf: expected a number, got 'fast'");
  EXPECT_EQ(readErrorWith("rtf", ".inf"), "/simulator/rtf: must be finite");
  EXPECT_EQ(readErrorWith("robots", "2.5"), "/simulator/robots: expected an integer, got '2.5'");
  EXPECT_EQ(readErrorWith("lockstep", "sometimes"), "/simulator/lockstep: expected true or false, got 'sometimes'");
  EXPECT_EQ(readErrorWith("start_poses", "[[0.5, 0.5, 0.0], [1.0, 2.0]]"),
            "/simulator/start_poses[1]: must be [x, y, yaw] (3 numbers, m and rad)");
  EXPECT_EQ(readErrorWith("lockstep_robots", "[tb3_0, [tb3_1]]"), "/simulator/lockstep_robots[1]: must be a robot name");
  EXPECT_EQ(readErrorWith("footprint", "[[0.1, 0.1], [0.1, -0.1]]"),
            "/simulator/footprint: must be a list of at least 3 points [x, y] (m)");
  EXPECT_EQ(readErrorWith("footprint", "[[0.1, 0.1], [0.1, -0.1], [-0.1]]"),
            "/simulator/footprint[2]: must be [x, y] (2 numbers, m)");
  EXPECT_EQ(readErrorWith("wheel_radius", "0.0"), "/simulator/wheel_radius: must be positive");
  EXPECT_EQ(readErrorWith("noise_profiles/measured_tb3/pause_rat", "0.1"),
            "/simulator/noise_profiles/measured_tb3/pause_rat: unknown parameter (see docs/reference/nodes_sim_nav.md for the list)");
  EXPECT_EQ(readErrorWith("noise_profiles/measured_tb3/lidar_dropout", "[0.04, 0.02]"),
            "/simulator/noise_profiles/measured_tb3/lidar_dropout: must satisfy 0 <= min <= max <= 1, got [0.04, 0.02]");
  EXPECT_EQ(readErrorWith("noise_profiles/measured_tb3/command_latency", "0.05"),
            "/simulator/noise_profiles/measured_tb3/command_latency: must be [min, max] (2 numbers)");
  EXPECT_EQ(readErrorWith("noise_profiles/measured_tb3/linear_speed_scale", "0"),
            "/simulator/noise_profiles/measured_tb3/linear_speed_scale: must be positive");
  EXPECT_EQ(readErrorWith("noise_profiles/noisy", "0.5"),
            "/simulator/noise_profiles/noisy: expected a namespace of parameters, got '0.5'");
  // Used by the description's other readers only, and accepted as such.
  EXPECT_EQ(readErrorWith("lidar_offset_z", "0.2"), "accepted");
  EXPECT_EQ(readErrorWith("noise_profiles/measured_tb3/proximity_collisions", "false"), "accepted");
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
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.robot_names = {"burger_a"}; }),
            "robot_names: 1 names for robots: 2 (give one name per robot of an arena)");
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.robot_names = {"burger_a", "/burger_b"}; }),
            "robot_names[1]: '/burger_b' is not a relative namespace (letters, digits, _ and /, no leading slash)");
  EXPECT_EQ(errorAfter([](SimConfig& c) { c.robot_names = {"burger_a", "burger_a"}; }),
            "robot_names: 'burger_a' is given twice");
  EXPECT_EQ(errorAfter([](SimConfig& c) {
              c.robot_names = {"burger_a", "burger_b"};
              c.lockstep_robots = {"tb3_1"};
            }),
            "lockstep_robots: unknown robot 'tb3_1' (robots: burger_a, burger_b)");
}

// A scenario's robot ids are the simulated robots' namespaces (tasks.launch passes them).
TEST(SimConfig, RobotNamesAreTheNamespaces) {
  EXPECT_EQ(readErrorWith("robot_names", "burger_a burger_b"), "accepted");
  SimConfig config = validConfig();
  config.robot_names = {"burger_a", "burger_b"};
  config.arenas = 2;
  const std::vector<std::string> names = robotNamespaces(config);
  ASSERT_EQ(names.size(), 4u);
  EXPECT_EQ(names[0], "arena_0/burger_a");
  EXPECT_EQ(names[3], "arena_1/burger_b");
  EXPECT_EQ(makeWorldConfig(config).robot_names, config.robot_names);
  config.robot_names.clear();
  EXPECT_EQ(robotNamespaces(config)[1], "arena_0/tb3_1");
}

}  // namespace
}  // namespace sim
}  // namespace marl_mrta
