#include "marl_mrta/nav/move_base_config.h"

namespace marl_mrta {
namespace nav {
namespace {

// The value under the current name, else under the pre-Melodic one, else the default.
double renamedDouble(const ParamNode& ns, const std::string& name, const std::string& old_name, double default_value,
                     std::vector<std::string>* renamed_used, double min = -1e300) {
  if (ns.has(name)) {
    ns.accept(old_name);
    return ns.getDouble(name, default_value, min);
  }
  if (ns.has(old_name)) {
    if (renamed_used) renamed_used->push_back(ns.pathOf(old_name) + " -> " + name);
    return ns.getDouble(old_name, default_value, min);
  }
  return default_value;
}

RecoveryBehaviorConfig readRecovery(const ParamNode& move_base_ns, const std::string& name, const std::string& type,
                                    const std::string& where) {
  RecoveryBehaviorConfig config;
  config.name = name;
  const ParamNode ns = move_base_ns.child(name);
  if (type == "clear_costmap_recovery/ClearCostmapRecovery") {
    config.kind = RecoveryBehaviorConfig::Kind::kClearCostmap;
    config.reset_distance = ns.getDouble("reset_distance", 3.0, 0.0);
    config.affected_maps = ns.getString("affected_maps", "both");
    if (config.affected_maps != "local" && config.affected_maps != "global" && config.affected_maps != "both") {
      throw ParamError(ns.pathOf("affected_maps"), "must be local, global or both, got '" + config.affected_maps + "'");
    }
    config.invert_area_to_clear = ns.getBool("invert_area_to_clear", false);
    ns.accept("force_updating");
    const YAML::Node layers = ns.raw("layer_names");
    if (layers.IsDefined()) {
      if (!layers.IsSequence()) throw ParamError(ns.pathOf("layer_names"), "expected a list of layer names");
      config.layer_names.clear();
      for (const auto& layer : layers) config.layer_names.push_back(layer.as<std::string>());
    }
  } else if (type == "rotate_recovery/RotateRecovery") {
    config.kind = RecoveryBehaviorConfig::Kind::kRotate;
    config.sim_granularity = ns.getDouble("sim_granularity", 0.017, 1e-4);
    ns.accept("frequency");
    // Rotate recovery takes its limits from TrajectoryPlannerROS, as the stock one does.
    const ParamNode tpr = move_base_ns.child("TrajectoryPlannerROS");
    config.acc_lim_theta = tpr.getDouble("acc_lim_theta", 3.2, 0.0);
    config.max_rotational_vel = tpr.getDouble("max_rotational_vel", 1.0, 0.0);
    config.min_rotational_vel = tpr.getDouble("min_in_place_rotational_vel", 0.4, 0.0);
    config.yaw_tolerance = tpr.getDouble("yaw_goal_tolerance", 0.10, 0.0);
  } else {
    throw ParamError(where, "recovery behavior type '" + type + "' is not available in the built-in move_base");
  }
  return config;
}

std::vector<RecoveryBehaviorConfig> defaultRecoveries(const ParamNode& ns, const MoveBaseConfig& config) {
  // move_base's defaults: conservative reset, rotate, aggressive reset, rotate.
  std::vector<RecoveryBehaviorConfig> list;
  RecoveryBehaviorConfig conservative = readRecovery(ns, "conservative_reset", "clear_costmap_recovery/ClearCostmapRecovery", "");
  conservative.reset_distance = config.conservative_reset_dist;
  RecoveryBehaviorConfig rotate = readRecovery(ns, "rotate_recovery", "rotate_recovery/RotateRecovery", "");
  RecoveryBehaviorConfig aggressive = readRecovery(ns, "aggressive_reset", "clear_costmap_recovery/ClearCostmapRecovery", "");
  aggressive.reset_distance = 4.0 * circumscribedRadius(config.local_costmap.paddedFootprint());
  list.push_back(conservative);
  if (config.clearing_rotation_allowed) list.push_back(rotate);
  list.push_back(aggressive);
  if (config.clearing_rotation_allowed) list.push_back(rotate);
  return list;
}

}  // namespace

NavfnConfig readNavfnConfig(const ParamNode& ns) {
  NavfnConfig config;
  config.allow_unknown = ns.getBool("allow_unknown", true);
  config.default_tolerance = ns.getDouble("default_tolerance", 0.0, 0.0);
  config.planner_window_x = ns.getDouble("planner_window_x", 0.0, 0.0);
  config.planner_window_y = ns.getDouble("planner_window_y", 0.0, 0.0);
  config.visualize_potential = ns.getBool("visualize_potential", false);
  config.path_variability = ns.getDouble("path_variability", 0.0, 0.0, 100.0);
  config.path_variability_length = ns.getDouble("path_variability_length", 1.0, 1e-3);
  config.path_variability_seed = ns.getInt("path_variability_seed", 0);
  return config;
}

DwaConfig readDwaConfig(const ParamNode& ns, double outer_controller_frequency, std::vector<std::string>* renamed) {
  DwaConfig config;
  LocalPlannerLimits& l = config.limits;
  l.max_vel_trans = renamedDouble(ns, "max_vel_trans", "max_trans_vel", 0.55, renamed, 0.0);
  l.min_vel_trans = renamedDouble(ns, "min_vel_trans", "min_trans_vel", 0.1, renamed, 0.0);
  l.max_vel_theta = renamedDouble(ns, "max_vel_theta", "max_rot_vel", 1.0, renamed, 0.0);
  l.min_vel_theta = renamedDouble(ns, "min_vel_theta", "min_rot_vel", 0.4, renamed, 0.0);
  l.theta_stopped_vel = renamedDouble(ns, "theta_stopped_vel", "rot_stopped_vel", 0.1, renamed, 0.0);
  l.acc_lim_trans = renamedDouble(ns, "acc_lim_trans", "acc_limit_trans", 0.1, renamed, 0.0);
  l.max_vel_x = ns.getDouble("max_vel_x", 0.55);
  l.min_vel_x = ns.getDouble("min_vel_x", 0.0);
  l.max_vel_y = ns.getDouble("max_vel_y", 0.1);
  l.min_vel_y = ns.getDouble("min_vel_y", -0.1);
  l.acc_lim_x = ns.getDouble("acc_lim_x", 2.5, 0.0);
  l.acc_lim_y = ns.getDouble("acc_lim_y", 2.5, 0.0);
  l.acc_lim_theta = ns.getDouble("acc_lim_theta", 3.2, 0.0);
  l.prune_plan = ns.getBool("prune_plan", true);
  // Goal reached: within both tolerances and stopped (these and theta_stopped_vel above).
  l.trans_stopped_vel = ns.getDouble("trans_stopped_vel", 0.1, 0.0);
  l.xy_goal_tolerance = ns.getDouble("xy_goal_tolerance", 0.1, 0.0);
  l.yaw_goal_tolerance = ns.getDouble("yaw_goal_tolerance", 0.1, 0.0);
  if (l.min_vel_x > l.max_vel_x) throw ParamError(ns.pathOf("min_vel_x"), "is greater than max_vel_x");
  if (l.min_vel_y > l.max_vel_y) throw ParamError(ns.pathOf("min_vel_y"), "is greater than max_vel_y");
  config.sim_time = ns.getDouble("sim_time", 1.7, 1e-3);
  config.sim_granularity = ns.getDouble("sim_granularity", 0.025, 1e-4);
  config.angular_sim_granularity = ns.getDouble("angular_sim_granularity", 0.1, 1e-4);
  config.vx_samples = ns.getInt("vx_samples", 3, 0);
  config.vy_samples = ns.getInt("vy_samples", 10, 0);
  config.vth_samples = ns.getInt("vth_samples", 20, 0);
  // DWA searches upward for controller_frequency: its own namespace first, then move_base's.
  const double frequency = ns.getDouble("controller_frequency", outer_controller_frequency, 1e-3);
  config.sim_period = 1.0 / frequency;
  config.path_distance_bias = ns.getDouble("path_distance_bias", 32.0, 0.0);
  config.goal_distance_bias = ns.getDouble("goal_distance_bias", 24.0, 0.0);
  config.occdist_scale = ns.getDouble("occdist_scale", 0.01, 0.0);
  config.twirling_scale = ns.getDouble("twirling_scale", 0.0, 0.0);
  config.forward_point_distance = ns.getDouble("forward_point_distance", 0.325);
  config.stop_time_buffer = ns.getDouble("stop_time_buffer", 0.2, 0.0);
  config.scaling_speed = ns.getDouble("scaling_speed", 0.25, 0.0);
  config.max_scaling_factor = ns.getDouble("max_scaling_factor", 0.2, 0.0);
  config.oscillation_reset_dist = ns.getDouble("oscillation_reset_dist", 0.05, 0.0);
  config.oscillation_reset_angle = ns.getDouble("oscillation_reset_angle", 0.2, 0.0);
  config.latch_xy_goal_tolerance = ns.getBool("latch_xy_goal_tolerance", false);
  config.use_dwa = ns.getBool("use_dwa", true);
  if (!config.use_dwa) throw ParamError(ns.pathOf("use_dwa"), "only the dynamic window (true) is implemented");
  ns.accept("restore_defaults");
  ns.accept("global_frame_id");
  return config;
}

const std::vector<ParamFileLoad>& moveBaseParamFiles() {
  static const std::vector<ParamFileLoad> files = {
      {"costmap_common_params_burger.yaml", "global_costmap"},
      {"costmap_common_params_burger.yaml", "local_costmap"},
      {"local_costmap_params.yaml", ""},
      {"global_costmap_params.yaml", ""},
      {"move_base_params.yaml", ""},
      {"dwa_local_planner_params_burger.yaml", ""},
      {"navfn_params.yaml", ""},
  };
  return files;
}

YAML::Node loadMoveBaseParams(const std::string& config_dir) {
  const std::string dir = config_dir.empty() || config_dir.back() == '/' ? config_dir : config_dir + "/";
  YAML::Node tree(YAML::NodeType::Map);
  for (const ParamFileLoad& load : moveBaseParamFiles()) loadYamlFileInto(tree, dir + load.file, load.ns);
  return tree;
}

MoveBaseConfig readMoveBaseConfig(const ParamNode& ns) {
  MoveBaseConfig config;
  config.base_global_planner = ns.getString("base_global_planner", "navfn/NavfnROS");
  if (config.base_global_planner != "navfn/NavfnROS") {
    throw ParamError(ns.pathOf("base_global_planner"),
                     "'" + config.base_global_planner + "' is not available in the built-in move_base (navfn/NavfnROS)");
  }
  config.base_local_planner = ns.getString("base_local_planner", "dwa_local_planner/DWAPlannerROS");
  if (config.base_local_planner != "dwa_local_planner/DWAPlannerROS") {
    throw ParamError(ns.pathOf("base_local_planner"), "'" + config.base_local_planner +
                                                          "' is not available in the built-in move_base "
                                                          "(dwa_local_planner/DWAPlannerROS)");
  }
  config.controller_frequency = ns.getDouble("controller_frequency", 20.0, 1e-3);
  config.planner_frequency = ns.getDouble("planner_frequency", 0.0, 0.0);
  config.planner_patience = ns.getDouble("planner_patience", 5.0, 0.0);
  config.controller_patience = ns.getDouble("controller_patience", 15.0, 0.0);
  config.max_planning_retries = ns.getInt("max_planning_retries", -1, -1);
  config.oscillation_timeout = ns.getDouble("oscillation_timeout", 0.0, 0.0);
  config.oscillation_distance = ns.getDouble("oscillation_distance", 0.5, 0.0);
  // The make_plan service's, then the recovery behaviours' (stock move_base's order).
  config.make_plan_clear_costmap = ns.getBool("make_plan_clear_costmap", true);
  config.make_plan_add_unreachable_goal = ns.getBool("make_plan_add_unreachable_goal", true);
  config.conservative_reset_dist = ns.getDouble("conservative_reset_dist", 3.0, 0.0);
  config.shutdown_costmaps = ns.getBool("shutdown_costmaps", false);
  config.clearing_rotation_allowed = ns.getBool("clearing_rotation_allowed", true);
  config.recovery_behavior_enabled = ns.getBool("recovery_behavior_enabled", true);
  ns.accept("restore_defaults");

  config.navfn = readNavfnConfig(ns.child("NavfnROS"));
  const ParamNode dwa_ns = ns.child("DWAPlannerROS");
  config.dwa = readDwaConfig(dwa_ns, config.controller_frequency, &config.renamed_parameters_used);
  config.dwa_odom_topic = dwa_ns.getString("odom_topic", "odom");
  config.dwa_publish_traj_pc = dwa_ns.getBool("publish_traj_pc", false);
  config.dwa_publish_cost_grid_pc = dwa_ns.getBool("publish_cost_grid_pc", false);
  config.global_costmap = readCostmapConfig(ns.child("global_costmap"));
  config.local_costmap = readCostmapConfig(ns.child("local_costmap"));

  const YAML::Node list = ns.raw("recovery_behaviors");
  if (list.IsDefined()) {
    if (!list.IsSequence()) throw ParamError(ns.pathOf("recovery_behaviors"), "expected a list of {name, type}");
    for (size_t i = 0; i < list.size(); ++i) {
      const std::string where = ns.pathOf("recovery_behaviors") + "[" + std::to_string(i) + "]";
      if (!list[i].IsMap() || !list[i]["name"] || !list[i]["type"]) throw ParamError(where, "expected {name, type}");
      config.recovery_behaviors.push_back(
          readRecovery(ns, list[i]["name"].as<std::string>(), list[i]["type"].as<std::string>(), where));
    }
  } else {
    config.recovery_behaviors = defaultRecoveries(ns, config);
  }
  return config;
}

}  // namespace nav
}  // namespace marl_mrta
