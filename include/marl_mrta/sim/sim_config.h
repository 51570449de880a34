// Everything the `simulator` node is configured with (config/sim.yaml, config/robot_burger.yaml,
// config/noise_profiles.yaml + launch overrides), and its checks. ROS-free: the node converts
// its private namespace into a parameter tree, tests load the files as rosparam would.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "marl_mrta/nav/param_tree.h"
#include "marl_mrta/sim/geometry.h"
#include "marl_mrta/sim/robot_model.h"
#include "marl_mrta/sim/world.h"

namespace marl_mrta {
namespace sim {

struct SimConfig {
  std::string map_file;                 // map_server YAML
  int robots = 2;                       // robots per arena
  int arenas = 1;
  // The robots' names (namespaces within an arena), as many as `robots`; empty: tb3_0 ...
  std::vector<std::string> robot_names;
  std::vector<Pose2D> start_poses = {   // docs/design.md; the first `robots` are used
      {0.5, 0.5, 0.0}, {0.5, 4.5, 0.0}, {6.5, 0.5, M_PI}, {6.5, 4.5, M_PI}};
  double physics_rate = 20.0;           // [Hz] >= 20
  double scan_rate = 5.0;               // [Hz] LDS-01
  double odom_rate = 20.0;              // [Hz]
  double rtf = 1.0;                     // real-time factor; 0: as fast as possible
  bool lockstep = false;
  std::vector<std::string> lockstep_robots;  // empty: every robot
  double cmd_vel_timeout = 0.5;         // [s] watchdog; 0: off
  std::string noise_profile = "ideal";
  // The profiles noise_profile may name (~noise_profiles). "ideal", every noise absent, is
  // always among them: roslaunch sets no parameter for an empty mapping such as the file's
  // `ideal: {}`.
  std::map<std::string, NoiseModel> noise_profiles = {{"ideal", NoiseModel{}}};
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

// Reads the simulator's parameters from its private namespace (`params.path()` names it in
// messages, e.g. "/simulator"): every value typed, every key known; the noise profiles are
// range-checked here, the rest by makeWorldConfig and World. Throws nav::ParamError naming the parameter
// ("/simulator/rtf: expected a number, got 'fast'").
SimConfig readSimConfig(const nav::ParamNode& params);

// The profiles of a noise_profiles namespace (config/noise_profiles.yaml), by name; every key
// of a profile is optional (absent: the ideal value). Throws nav::ParamError.
std::map<std::string, NoiseModel> readNoiseProfiles(const nav::ParamNode& profiles);
// The same from the file itself (tests, tools). Throws nav::ParamError naming the file.
std::map<std::string, NoiseModel> loadNoiseProfiles(const std::string& yaml_file);

// Checks what the world does not check itself and builds the world's configuration.
// Throws nav::ParamError naming the setting (e.g. "noise_profile").
WorldConfig makeWorldConfig(const SimConfig& config);

// The names of an arena's robots: robot_names, or tb3_0 ... for `robots` robots. Throws
// nav::ParamError when robot_names has another count, repeats a name or holds one that is not a
// relative namespace.
std::vector<std::string> arenaRobotNames(const SimConfig& config);

// Namespaces of every robot, arena by arena (global index order).
std::vector<std::string> robotNamespaces(const SimConfig& config);

}  // namespace sim
}  // namespace marl_mrta
