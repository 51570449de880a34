#include "marl_mrta/sim/sim_config.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace marl_mrta {
namespace sim {

namespace {

std::string join(const std::vector<std::string>& words) {
  std::string out;
  for (size_t i = 0; i < words.size(); ++i) out += (i ? ", " : "") + words[i];
  return out;
}

}  // namespace

std::vector<std::string> robotNamespaces(const SimConfig& config) {
  std::vector<std::string> names;
  for (int arena = 0; arena < config.arenas; ++arena) {
    for (int i = 0; i < config.robots; ++i) names.push_back(robotNamespace(config.arenas, arena, i));
  }
  return names;
}

WorldConfig makeWorldConfig(const SimConfig& config) {
  if (config.map_file.empty()) throw ConfigError("map_file", "missing: give the map_server YAML of the world");
  if (config.robots < 1) throw ConfigError("robots", "must be at least 1, got " + std::to_string(config.robots));
  if (config.robots > static_cast<int>(config.start_poses.size())) {
    throw ConfigError("start_poses", std::to_string(config.start_poses.size()) + " poses for robots: " +
                                         std::to_string(config.robots) + " (give one [x, y, yaw] per robot)");
  }
  if (!(config.physics_rate >= kMinPhysicsRate)) {
    std::ostringstream problem;
    problem << "must be at least " << kMinPhysicsRate << " Hz, got " << config.physics_rate;
    throw ConfigError("physics_rate", problem.str());
  }
  if (!(config.rtf >= 0.0) || !std::isfinite(config.rtf)) {
    throw ConfigError("rtf", "must be 0 (as fast as possible) or a positive factor, got " + std::to_string(config.rtf));
  }
  if (!(config.stop_after >= 0.0)) throw ConfigError("stop_after", "must be >= 0 s");
  if (config.seed < 0) throw ConfigError("seed", "must be >= 0, got " + std::to_string(config.seed));
  const std::vector<std::string> names = robotNamespaces(config);
  for (const std::string& name : config.lockstep_robots) {
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      throw ConfigError("lockstep_robots", "unknown robot '" + name + "' (robots: " + join(names) + ")");
    }
  }

  WorldConfig world;
  world.arenas = config.arenas;
  world.start_poses.assign(config.start_poses.begin(), config.start_poses.begin() + config.robots);
  world.physics_rate = config.physics_rate;
  world.scan_rate = config.scan_rate;
  world.odom_rate = config.odom_rate;
  world.cmd_vel_timeout = config.cmd_vel_timeout;
  world.robot = config.robot;
  world.robot.lidar.invalid_as_inf = config.scan_invalid_as_inf;
  try {
    world.noise = noiseProfile(config.noise_profile);
  } catch (const std::invalid_argument&) {
    throw ConfigError("noise_profile",
                      "unknown value '" + config.noise_profile + "' (expected " + join(noiseProfileNames()) + ")");
  }
  world.seed = static_cast<uint64_t>(config.seed);
  return world;
}

}  // namespace sim
}  // namespace marl_mrta
