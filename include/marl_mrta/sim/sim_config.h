// Everything the `simulator` node is configured with (config/sim.yaml + launch overrides),
// and its checks. ROS-free: the node fills it from the parameter server, tests by hand.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "marl_mrta/sim/geometry.h"
#include "marl_mrta/sim/robot_model.h"
#include "marl_mrta/sim/world.h"

namespace marl_mrta {
namespace sim {

// A bad setting; what() is one line "<field>: <problem>".
class ConfigError : public std::runtime_error {
 public:
  ConfigError(const std::string& field, const std::string& problem)
      : std::runtime_error(field + ": " + problem), field_(field), problem_(problem) {}
  const std::string& field() const { return field_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string field_, problem_;
};

struct SimConfig {
  std::string map_file;                 // map_server YAML
  int robots = 2;                       // robots per arena
  int arenas = 1;
  std::vector<Pose2D> start_poses = {   // docs/architecture.md; the first `robots` are used
      {0.5, 0.5, 0.0}, {0.5, 4.5, 0.0}, {6.5, 0.5, M_PI}, {6.5, 4.5, M_PI}};
  double physics_rate = 20.0;           // [Hz] >= 20
  double scan_rate = 5.0;               // [Hz] LDS-01
  double odom_rate = 20.0;              // [Hz]
  double rtf = 1.0;                     // real-time factor; 0: as fast as possible
  bool lockstep = false;
  std::vector<std::string> lockstep_robots;  // empty: every robot
  double cmd_vel_timeout = 0.5;         // [s] watchdog; 0: off
  std::string noise_profile = "ideal";
  int seed = 0;
  bool scan_invalid_as_inf = false;
  // Also publish map -> <ns>/odom from ground truth, in the same /tf message as odom -> base
  // (what fake_localization does, without a node per robot and its messages).
  bool publish_localization = false;
  RobotSpec robot;
  bool start_paused = false;            // wait for /simulator/pause false before the first tick
  double stop_after = 0.0;              // [s] sim time after which the node exits; 0: never
  std::string stats_file;               // JSON timing summary written at exit ("": none)
};

// The lowest physics rate accepted: the lidar and controllers (10-20 Hz) need at least this.
constexpr double kMinPhysicsRate = 20.0;

// Checks what the world does not check itself and builds the world's configuration.
// Throws ConfigError naming the setting (e.g. "noise_profile").
WorldConfig makeWorldConfig(const SimConfig& config);

// Namespaces of every robot, arena by arena (global index order).
std::vector<std::string> robotNamespaces(const SimConfig& config);

}  // namespace sim
}  // namespace marl_mrta
