#include "marl_mrta/sim/sim_config.h"

#include "marl_mrta/sim/stand_in_config.h"  // readNameList

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

namespace marl_mrta {
namespace sim {

namespace {

// A relative ROS namespace: what a robot's name may be.
bool validName(const std::string& name) {
  if (name.empty() || name.front() == '/' || name.back() == '/') return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/'; });
}

using nav::ParamError;
using nav::ParamNode;

std::string join(const std::vector<std::string>& words) {
  std::string out;
  for (size_t i = 0; i < words.size(); ++i) out += (i ? ", " : "") + words[i];
  return out;
}

bool isFiniteNumber(const YAML::Node& node, double& value) {
  return node.IsScalar() && YAML::convert<double>::decode(node, value) && std::isfinite(value);
}

// The getters accept infinities; none of the simulator's numbers may be one.
double finiteNumber(const ParamNode& params, const std::string& key, double default_value) {
  const double value = params.getDouble(key, default_value);
  if (!std::isfinite(value)) throw ParamError(params.pathOf(key), "must be finite");
  return value;
}

std::vector<Pose2D> readPoses(const ParamNode& params, const std::string& key, const std::vector<Pose2D>& default_value) {
  const YAML::Node value = params.raw(key);
  if (!value.IsDefined()) return default_value;
  if (!value.IsSequence()) throw ParamError(params.pathOf(key), "must be a list of [x, y, yaw]");
  std::vector<Pose2D> poses;
  for (size_t i = 0; i < value.size(); ++i) {
    const YAML::Node pose = value[i];
    Pose2D p;
    if (!pose.IsSequence() || pose.size() != 3 || !isFiniteNumber(pose[0], p.x) || !isFiniteNumber(pose[1], p.y) ||
        !isFiniteNumber(pose[2], p.yaw)) {
      throw ParamError(params.pathOf(key) + "[" + std::to_string(i) + "]", "must be [x, y, yaw] (3 numbers, m and rad)");
    }
    poses.push_back(p);
  }
  return poses;
}

// A value of the robot description that the simulator does not use (its collision shape is
// the circle of robot_radius), checked so that the file stays sound for its other readers.
void checkPositive(const ParamNode& params, const std::string& key) {
  if (params.has(key) && !(finiteNumber(params, key, 0.0) > 0.0)) {
    throw ParamError(params.pathOf(key), "must be positive");
  }
}

void checkFootprint(const ParamNode& params, const std::string& key) {
  const YAML::Node value = params.raw(key);
  if (!value.IsDefined()) return;
  if (!value.IsSequence() || value.size() < 3) {
    throw ParamError(params.pathOf(key), "must be a list of at least 3 points [x, y] (m)");
  }
  for (size_t i = 0; i < value.size(); ++i) {
    double x, y;
    if (!value[i].IsSequence() || value[i].size() != 2 || !isFiniteNumber(value[i][0], x) ||
        !isFiniteNumber(value[i][1], y)) {
      throw ParamError(params.pathOf(key) + "[" + std::to_string(i) + "]", "must be [x, y] (2 numbers, m)");
    }
  }
}

// [min, max] with low <= min <= max <= high; unchanged when absent.
void readInterval(const ParamNode& profile, const std::string& key, double low, double high, double& min,
                  double& max) {
  const YAML::Node value = profile.raw(key);
  if (!value.IsDefined()) return;
  double a, b;
  if (!value.IsSequence() || value.size() != 2 || !isFiniteNumber(value[0], a) || !isFiniteNumber(value[1], b)) {
    throw ParamError(profile.pathOf(key), "must be [min, max] (2 numbers)");
  }
  if (!(low <= a && a <= b && b <= high)) {
    std::ostringstream problem;
    problem << "must satisfy " << low << " <= min <= max <= " << high << ", got [" << a << ", " << b << "]";
    throw ParamError(profile.pathOf(key), problem.str());
  }
  min = a;
  max = b;
}

NoiseModel readNoiseProfile(const ParamNode& profile) {
  NoiseModel noise;
  noise.linear_speed_scale = finiteNumber(profile, "linear_speed_scale", noise.linear_speed_scale);
  if (!(noise.linear_speed_scale > 0.0)) throw ParamError(profile.pathOf("linear_speed_scale"), "must be positive");
  readInterval(profile, "command_latency", 0.0, 10.0, noise.command_latency_min, noise.command_latency_max);
  noise.pause_rate = profile.getDouble("pause_rate", noise.pause_rate, 0.0, 1e3);
  readInterval(profile, "pause_duration", 0.0, 1e3, noise.pause_duration_min, noise.pause_duration_max);
  noise.lidar_range_stddev = profile.getDouble("lidar_range_stddev", noise.lidar_range_stddev, 0.0, 10.0);
  readInterval(profile, "lidar_dropout", 0.0, 1.0, noise.lidar_dropout_min, noise.lidar_dropout_max);
  noise.odom_translation_stddev = profile.getDouble("odom_translation_stddev", noise.odom_translation_stddev, 0.0, 10.0);
  noise.odom_rotation_stddev = profile.getDouble("odom_rotation_stddev", noise.odom_rotation_stddev, 0.0, 10.0);
  // The embedded executor's (travel times along stretched paths, collisions by proximity).
  profile.accept("path_stretch_sd");
  profile.accept("proximity_collisions");
  return noise;
}

}  // namespace

std::map<std::string, NoiseModel> readNoiseProfiles(const ParamNode& profiles) {
  std::map<std::string, NoiseModel> models;
  for (const std::string& name : profiles.keys()) models[name] = readNoiseProfile(profiles.child(name));
  return models;
}

std::map<std::string, NoiseModel> loadNoiseProfiles(const std::string& yaml_file) {
  YAML::Node tree(YAML::NodeType::Map);
  nav::loadYamlFileInto(tree, yaml_file, "");
  const ParamNode profiles(tree, yaml_file);
  std::map<std::string, NoiseModel> models = readNoiseProfiles(profiles);
  const std::vector<std::string> unknown = profiles.unreadKeys();
  if (!unknown.empty()) throw ParamError(unknown.front(), "unknown key");
  return models;
}

SimConfig readSimConfig(const ParamNode& params) {
  SimConfig config;
  config.map_file = params.getString("map_file", config.map_file);
  config.robots = params.getInt("robots", config.robots);
  config.arenas = params.getInt("arenas", config.arenas);
  config.robot_names = readNameList(params, "robot_names", config.robot_names);
  config.start_poses = readPoses(params, "start_poses", config.start_poses);
  config.physics_rate = finiteNumber(params, "physics_rate", config.physics_rate);
  config.odom_rate = finiteNumber(params, "odom_rate", config.odom_rate);
  config.rtf = finiteNumber(params, "rtf", config.rtf);
  config.lockstep = params.getBool("lockstep", config.lockstep);
  config.lockstep_robots = readNameList(params, "lockstep_robots", config.lockstep_robots);
  config.start_paused = params.getBool("start_paused", config.start_paused);
  config.stop_after = finiteNumber(params, "stop_after", config.stop_after);
  config.stats_file = params.getString("stats_file", config.stats_file);
  config.publish_localization = params.getBool("publish_localization", config.publish_localization);
  config.cmd_vel_timeout = finiteNumber(params, "cmd_vel_timeout", config.cmd_vel_timeout);
  config.scan_invalid_as_inf = params.getBool("scan_invalid_as_inf", config.scan_invalid_as_inf);
  config.seed = params.getInt("seed", config.seed);
  params.getBool("stand_in", false);  // the hardware stand-in's switch (simulator_node.cpp, stand_in_config.h)

  // The robot (config/robot_burger.yaml).
  RobotSpec& robot = config.robot;
  robot.radius = finiteNumber(params, "robot_radius", robot.radius);
  checkFootprint(params, "footprint");
  checkPositive(params, "wheel_radius");
  checkPositive(params, "wheel_separation");
  DriveLimits& limits = robot.limits;
  limits.max_linear_velocity = finiteNumber(params, "max_linear_velocity", limits.max_linear_velocity);
  limits.max_angular_velocity = finiteNumber(params, "max_angular_velocity", limits.max_angular_velocity);
  limits.max_linear_acceleration = finiteNumber(params, "max_linear_acceleration", limits.max_linear_acceleration);
  limits.max_angular_acceleration = finiteNumber(params, "max_angular_acceleration", limits.max_angular_acceleration);
  LidarSpec& lidar = robot.lidar;
  lidar.beams = params.getInt("lidar_beams", lidar.beams);
  lidar.range_min = finiteNumber(params, "lidar_range_min", lidar.range_min);
  lidar.range_max = finiteNumber(params, "lidar_range_max", lidar.range_max);
  lidar.mount_x = finiteNumber(params, "lidar_offset_x", lidar.mount_x);
  lidar.mount_y = finiteNumber(params, "lidar_offset_y", lidar.mount_y);
  finiteNumber(params, "lidar_offset_z", 0.0);  // the scan plane's height: the simulator is flat
  config.scan_rate = finiteNumber(params, "scan_rate", config.scan_rate);

  // Noise (config/noise_profiles.yaml under noise_profiles).
  config.noise_profile = params.getString("noise_profile", config.noise_profile);
  for (auto& [name, noise] : readNoiseProfiles(params.child("noise_profiles"))) config.noise_profiles[name] = noise;

  const std::vector<std::string> unknown = params.unreadKeys();
  if (!unknown.empty()) throw ParamError(unknown.front(), "unknown parameter (see docs/reference/nodes_sim_nav.md for the list)");
  return config;
}

std::vector<std::string> arenaRobotNames(const SimConfig& config) {
  if (config.robot_names.empty()) {
    std::vector<std::string> names;
    for (int i = 0; i < config.robots; ++i) names.push_back(defaultRobotName(i));
    return names;
  }
  if (static_cast<int>(config.robot_names.size()) != config.robots) {
    throw ParamError("robot_names", std::to_string(config.robot_names.size()) + " names for robots: " +
                                        std::to_string(config.robots) + " (give one name per robot of an arena)");
  }
  for (size_t i = 0; i < config.robot_names.size(); ++i) {
    const std::string& name = config.robot_names[i];
    if (!validName(name)) {
      throw ParamError("robot_names[" + std::to_string(i) + "]",
                       "'" + name + "' is not a relative namespace (letters, digits, _ and /, no leading slash)");
    }
    if (std::count(config.robot_names.begin(), config.robot_names.end(), name) > 1) {
      throw ParamError("robot_names", "'" + name + "' is given twice");
    }
  }
  return config.robot_names;
}

std::vector<std::string> robotNamespaces(const SimConfig& config) {
  const std::vector<std::string> arena_names = arenaRobotNames(config);
  std::vector<std::string> names;
  for (int arena = 0; arena < config.arenas; ++arena) {
    for (int i = 0; i < config.robots; ++i) names.push_back(robotNamespace(arena_names, config.arenas, arena, i));
  }
  return names;
}

WorldConfig makeWorldConfig(const SimConfig& config) {
  if (config.map_file.empty()) throw ParamError("map_file", "missing: give the map_server YAML of the world");
  if (config.robots < 1) throw ParamError("robots", "must be at least 1, got " + std::to_string(config.robots));
  if (config.robots > static_cast<int>(config.start_poses.size())) {
    throw ParamError("start_poses", std::to_string(config.start_poses.size()) + " poses for robots: " +
                                        std::to_string(config.robots) + " (give one [x, y, yaw] per robot)");
  }
  if (!(config.physics_rate >= kMinPhysicsRate)) {
    std::ostringstream problem;
    problem << "must be at least " << kMinPhysicsRate << " Hz, got " << config.physics_rate;
    throw ParamError("physics_rate", problem.str());
  }
  if (!(config.rtf >= 0.0) || !std::isfinite(config.rtf)) {
    throw ParamError("rtf", "must be 0 (as fast as possible) or a positive factor, got " + std::to_string(config.rtf));
  }
  if (!(config.stop_after >= 0.0)) throw ParamError("stop_after", "must be >= 0 s");
  if (config.seed < 0) throw ParamError("seed", "must be >= 0, got " + std::to_string(config.seed));
  const std::vector<std::string> names = robotNamespaces(config);
  for (const std::string& name : config.lockstep_robots) {
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      throw ParamError("lockstep_robots", "unknown robot '" + name + "' (robots: " + join(names) + ")");
    }
  }

  WorldConfig world;
  world.arenas = config.arenas;
  world.start_poses.assign(config.start_poses.begin(), config.start_poses.begin() + config.robots);
  world.robot_names = arenaRobotNames(config);
  world.physics_rate = config.physics_rate;
  world.scan_rate = config.scan_rate;
  world.odom_rate = config.odom_rate;
  world.cmd_vel_timeout = config.cmd_vel_timeout;
  world.robot = config.robot;
  world.robot.lidar.invalid_as_inf = config.scan_invalid_as_inf;
  const auto noise = config.noise_profiles.find(config.noise_profile);
  if (noise == config.noise_profiles.end()) {
    std::vector<std::string> profiles;
    for (const auto& profile : config.noise_profiles) profiles.push_back(profile.first);
    throw ParamError("noise_profile", "unknown value '" + config.noise_profile + "' (expected " + join(profiles) + ")");
  }
  world.noise = noise->second;
  world.seed = static_cast<uint64_t>(config.seed);
  return world;
}

}  // namespace sim
}  // namespace marl_mrta
