// Everything move_base reads from its private namespace: its own parameters, NavfnROS,
// DWAPlannerROS, global_costmap, local_costmap and the recovery behaviours. Same names and
// defaults as the noetic stack; DWA's pre-Melodic names (max_trans_vel, max_rot_vel, ...) are
// accepted when the new name is absent.
#pragma once

#include <string>
#include <vector>

#include "marl_mrta/nav/costmap_config.h"
#include "marl_mrta/nav/dwa_planner.h"
#include "marl_mrta/nav/navfn_planner.h"
#include "marl_mrta/nav/param_tree.h"

namespace marl_mrta {
namespace nav {

struct RecoveryBehaviorConfig {
  enum class Kind { kClearCostmap, kRotate };
  Kind kind = Kind::kClearCostmap;
  std::string name;
  // clear_costmap_recovery: obstacle data farther than reset_distance/2 (square) is forgotten.
  double reset_distance = 3.0;  // [m]
  std::vector<std::string> layer_names{"obstacle_layer"};
  std::string affected_maps = "both";  // local, global or both
  bool invert_area_to_clear = false;
  // rotate_recovery: one full turn in place.
  double sim_granularity = 0.017;     // [rad] collision check step
  double acc_lim_theta = 3.2;         // [rad/s^2]
  double max_rotational_vel = 1.0;    // [rad/s]
  double min_rotational_vel = 0.4;    // [rad/s]
  double yaw_tolerance = 0.10;        // [rad]
};

struct MoveBaseConfig {
  std::string base_global_planner = "navfn/NavfnROS";
  std::string base_local_planner = "dwa_local_planner/DWAPlannerROS";
  double controller_frequency = 20.0;  // [Hz]
  double planner_frequency = 0.0;      // [Hz] 0 = plan once per goal (and after failures)
  double planner_patience = 5.0;       // [s]
  double controller_patience = 15.0;   // [s]
  int max_planning_retries = -1;       // -1 = only planner_patience limits
  double oscillation_timeout = 0.0;    // [s] 0 = off
  double oscillation_distance = 0.5;   // [m]
  double conservative_reset_dist = 3.0;  // [m]
  bool shutdown_costmaps = false;
  bool clearing_rotation_allowed = true;
  bool recovery_behavior_enabled = true;
  bool make_plan_clear_costmap = true;
  bool make_plan_add_unreachable_goal = true;

  NavfnConfig navfn;
  DwaConfig dwa;
  std::string dwa_odom_topic = "odom";
  bool dwa_publish_traj_pc = false;
  bool dwa_publish_cost_grid_pc = false;
  CostmapConfig global_costmap;
  CostmapConfig local_costmap;
  std::vector<RecoveryBehaviorConfig> recovery_behaviors;
  // Old parameter names that were read in place of the new ones ("old -> new").
  std::vector<std::string> renamed_parameters_used;
};

// One `rosparam load` of a parameter file into a namespace of move_base ("" = its own).
struct ParamFileLoad {
  std::string file;  // in the navigation configuration directory (config/nav/)
  std::string ns;
};
// The files launch/include/robot_nav.launch loads into move_base, in its order (gtest
// NavParams.RobotNavLaunchLoadsTheMoveBaseParamFiles keeps the two equal).
const std::vector<ParamFileLoad>& moveBaseParamFiles();
// The move_base namespace those files give, from `config_dir` (e.g. config/nav), as rosparam
// loads them. Throws ParamError naming a file that cannot be read.
YAML::Node loadMoveBaseParams(const std::string& config_dir);

// Reads the move_base namespace. Throws ParamError (one line, naming the parameter).
MoveBaseConfig readMoveBaseConfig(const ParamNode& move_base_ns);
// DWAPlannerROS alone; `outer_controller_frequency` is move_base's (DWA searches upward for it).
DwaConfig readDwaConfig(const ParamNode& dwa_ns, double outer_controller_frequency,
                        std::vector<std::string>* renamed_used = nullptr);
NavfnConfig readNavfnConfig(const ParamNode& navfn_ns);

}  // namespace nav
}  // namespace marl_mrta
