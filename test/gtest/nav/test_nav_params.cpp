// Parameter conformance: TurtleBot3's navigation files load unchanged (every parameter read,
// none unknown), unknown and renamed parameters are reported, bad input gives one line.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>

#include "marl_mrta/nav/move_base_config.h"

using namespace marl_mrta::nav;

namespace {

const std::string kSourceDir = MARL_MRTA_SOURCE_DIR;
const std::string kTb3Params = kSourceDir + "/../shared/external/turtlebot3_noetic/turtlebot3_navigation/param/";

bool exists(const std::string& path) {
  struct stat info;
  return stat(path.c_str(), &info) == 0;
}

// The move_base namespace as turtlebot3_navigation/launch/move_base.launch loads it.
YAML::Node moveBaseTree(const std::string& dir) {
  YAML::Node tree(YAML::NodeType::Map);
  setParam(tree, "base_local_planner", YAML::Node("dwa_local_planner/DWAPlannerROS"));
  loadYamlFileInto(tree, dir + "costmap_common_params_burger.yaml", "global_costmap");
  loadYamlFileInto(tree, dir + "costmap_common_params_burger.yaml", "local_costmap");
  loadYamlFileInto(tree, dir + "local_costmap_params.yaml", "");
  loadYamlFileInto(tree, dir + "global_costmap_params.yaml", "");
  loadYamlFileInto(tree, dir + "move_base_params.yaml", "");
  loadYamlFileInto(tree, dir + "dwa_local_planner_params_burger.yaml", "");
  return tree;
}

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& item : items) out += item + " ";
  return out;
}

}  // namespace

TEST(NavParams, Turtlebot3FilesLoadUnchangedWithEveryParameterRead) {
  if (!exists(kTb3Params)) GTEST_SKIP() << "TurtleBot3 parameter files not found at " << kTb3Params;
  const YAML::Node tree = moveBaseTree(kTb3Params);
  const ParamNode ns(tree, "move_base");
  const MoveBaseConfig config = readMoveBaseConfig(ns);
  EXPECT_TRUE(ns.unreadKeys().empty()) << "not read: " << joined(ns.unreadKeys());
  EXPECT_TRUE(config.renamed_parameters_used.empty());

  // move_base_params.yaml
  EXPECT_DOUBLE_EQ(10.0, config.controller_frequency);
  EXPECT_DOUBLE_EQ(5.0, config.planner_frequency);
  EXPECT_DOUBLE_EQ(5.0, config.planner_patience);
  EXPECT_DOUBLE_EQ(15.0, config.controller_patience);
  EXPECT_DOUBLE_EQ(10.0, config.oscillation_timeout);
  EXPECT_DOUBLE_EQ(0.2, config.oscillation_distance);
  // dwa_local_planner_params_burger.yaml
  const DwaConfig& dwa = config.dwa;
  EXPECT_DOUBLE_EQ(0.22, dwa.limits.max_vel_x);
  EXPECT_DOUBLE_EQ(-0.22, dwa.limits.min_vel_x);
  EXPECT_DOUBLE_EQ(0.22, dwa.limits.max_vel_trans);
  EXPECT_DOUBLE_EQ(0.11, dwa.limits.min_vel_trans);
  EXPECT_DOUBLE_EQ(2.75, dwa.limits.max_vel_theta);
  EXPECT_DOUBLE_EQ(1.37, dwa.limits.min_vel_theta);
  EXPECT_DOUBLE_EQ(3.2, dwa.limits.acc_lim_theta);
  EXPECT_DOUBLE_EQ(0.05, dwa.limits.xy_goal_tolerance);
  EXPECT_DOUBLE_EQ(0.17, dwa.limits.yaw_goal_tolerance);
  EXPECT_DOUBLE_EQ(1.5, dwa.sim_time);
  EXPECT_EQ(20, dwa.vx_samples);
  EXPECT_EQ(40, dwa.vth_samples);
  EXPECT_DOUBLE_EQ(0.1, dwa.sim_period);
  EXPECT_DOUBLE_EQ(32.0, dwa.path_distance_bias);
  EXPECT_DOUBLE_EQ(20.0, dwa.goal_distance_bias);
  EXPECT_DOUBLE_EQ(0.02, dwa.occdist_scale);
  // costmaps: pre-Hydro style converted to static + obstacle + inflation (global), obstacle + inflation (local)
  const CostmapConfig& global = config.global_costmap;
  EXPECT_TRUE(global.pre_hydro_style);
  EXPECT_EQ("map", global.global_frame);
  EXPECT_EQ("base_footprint", global.robot_base_frame);
  ASSERT_EQ(3u, global.layers.size());
  EXPECT_EQ(LayerSpec::Kind::kStatic, global.layers[0].kind);
  EXPECT_EQ(LayerSpec::Kind::kObstacle, global.layers[1].kind);
  EXPECT_EQ(LayerSpec::Kind::kInflation, global.layers[2].kind);
  EXPECT_DOUBLE_EQ(1.0, global.layers[2].inflation_layer.inflation_radius);
  EXPECT_DOUBLE_EQ(3.0, global.layers[2].inflation_layer.cost_scaling_factor);
  const ObstacleLayerConfig& obstacles = global.layers[1].obstacle_layer;
  ASSERT_EQ(1u, obstacles.sources.size());
  EXPECT_EQ("scan", obstacles.sources[0].topic);
  EXPECT_EQ("base_scan", obstacles.sources[0].sensor_frame);
  EXPECT_EQ("LaserScan", obstacles.sources[0].data_type);
  EXPECT_TRUE(obstacles.sources[0].marking);
  EXPECT_TRUE(obstacles.sources[0].clearing);
  EXPECT_FALSE(obstacles.sources[0].inf_is_valid);
  EXPECT_DOUBLE_EQ(3.0, obstacles.sources[0].obstacle_range);
  EXPECT_DOUBLE_EQ(3.5, obstacles.sources[0].raytrace_range);
  const CostmapConfig& local = config.local_costmap;
  EXPECT_EQ("odom", local.global_frame);
  EXPECT_TRUE(local.rolling_window);
  EXPECT_DOUBLE_EQ(3.0, local.width);
  EXPECT_DOUBLE_EQ(0.05, local.resolution);
  ASSERT_EQ(2u, local.layers.size());
  ASSERT_EQ(4u, local.footprint.size());
  EXPECT_NEAR(0.041, inscribedRadius(local.footprint), 1e-9);
  // default recoveries: conservative reset, rotate, aggressive reset, rotate
  ASSERT_EQ(4u, config.recovery_behaviors.size());
  EXPECT_DOUBLE_EQ(3.0, config.recovery_behaviors[0].reset_distance);
  EXPECT_EQ(RecoveryBehaviorConfig::Kind::kRotate, config.recovery_behaviors[1].kind);
}

TEST(NavParams, ProjectConfigFilesLoadWithEveryParameterRead) {
  const YAML::Node tree = loadMoveBaseParams(kSourceDir + "/config/nav");
  const ParamNode ns(tree, "move_base");
  const MoveBaseConfig config = readMoveBaseConfig(ns);
  EXPECT_TRUE(ns.unreadKeys().empty()) << "not read: " << joined(ns.unreadKeys());
  EXPECT_DOUBLE_EQ(2.75, config.dwa.limits.max_vel_theta);
  EXPECT_DOUBLE_EQ(0.0, config.navfn.path_variability) << "path variability must be off by default";
}

TEST(NavParams, RobotNavLaunchLoadsTheMoveBaseParamFiles) {
  std::ifstream file(kSourceDir + "/launch/include/robot_nav.launch");
  std::stringstream text;
  text << file.rdbuf();
  // The move_base node's element: from its name to the end of the node.
  const std::string launch = text.str();
  const size_t begin = launch.find("name=\"move_base\"");
  ASSERT_NE(std::string::npos, begin);
  const std::string move_base = launch.substr(begin, launch.find("</node>", begin) - begin);
  const std::regex load(R"re(<rosparam file="\$\(arg config_dir\)/([^"]+)" command="load"(?: ns="([^"]*)")?\s*/>)re");
  std::vector<std::string> launched, listed;
  for (auto it = std::sregex_iterator(move_base.begin(), move_base.end(), load); it != std::sregex_iterator(); ++it) {
    launched.push_back((*it)[1].str() + " -> " + (*it)[2].str());
  }
  for (const ParamFileLoad& entry : moveBaseParamFiles()) listed.push_back(entry.file + " -> " + entry.ns);
  EXPECT_EQ(listed, launched);
}

TEST(NavParams, OldDwaNamesAreReadWhenTheNewOnesAreAbsent) {
  YAML::Node tree(YAML::NodeType::Map);
  setParam(tree, "DWAPlannerROS/max_trans_vel", YAML::Node(0.3));
  setParam(tree, "DWAPlannerROS/max_rot_vel", YAML::Node(1.5));
  setParam(tree, "DWAPlannerROS/min_rot_vel", YAML::Node(0.5));
  setParam(tree, "DWAPlannerROS/min_vel_trans", YAML::Node(0.05));
  setParam(tree, "DWAPlannerROS/min_trans_vel", YAML::Node(0.9));  // the new name wins
  const ParamNode ns(tree, "move_base");
  const MoveBaseConfig config = readMoveBaseConfig(ns);
  EXPECT_DOUBLE_EQ(0.3, config.dwa.limits.max_vel_trans);
  EXPECT_DOUBLE_EQ(1.5, config.dwa.limits.max_vel_theta);
  EXPECT_DOUBLE_EQ(0.5, config.dwa.limits.min_vel_theta);
  EXPECT_DOUBLE_EQ(0.05, config.dwa.limits.min_vel_trans);
  EXPECT_EQ(3u, config.renamed_parameters_used.size());
  EXPECT_TRUE(ns.unreadKeys().empty()) << joined(ns.unreadKeys());
}

// The keys Costmap2DROS copies from a costmap into its layers (track_unknown_space, the
// inflation and range parameters) take the costmap's value over the layer's own, in either style.
// Unset, the static layer keeps the map's unknown cells unknown (its default) and the obstacle
// layer does not track unknown space (the costmap's default), as in costmap_2d.
TEST(NavParams, TheCostmapsOwnValuesReachItsLayers) {
  YAML::Node tb3(YAML::NodeType::Map);
  loadYamlFileInto(tb3, kSourceDir + "/config/nav/costmap_common_params_burger.yaml", "global_costmap");
  loadYamlFileInto(tb3, kSourceDir + "/config/nav/global_costmap_params.yaml", "");
  const CostmapConfig unset = readMoveBaseConfig(ParamNode(tb3, "move_base")).global_costmap;
  ASSERT_EQ(3u, unset.layers.size());
  EXPECT_FALSE(unset.track_unknown_space);
  EXPECT_TRUE(unset.layers[0].static_layer.track_unknown_space);
  EXPECT_FALSE(unset.layers[1].obstacle_layer.track_unknown_space);

  setParam(tb3, "global_costmap/track_unknown_space", YAML::Node(true));
  setParam(tb3, "global_costmap/static_layer/track_unknown_space", YAML::Node(false));  // the costmap's wins
  const ParamNode pre_hydro_ns(tb3, "move_base");
  const CostmapConfig pre_hydro = readMoveBaseConfig(pre_hydro_ns).global_costmap;
  EXPECT_TRUE(pre_hydro.track_unknown_space);
  EXPECT_TRUE(pre_hydro.layers[0].static_layer.track_unknown_space);
  EXPECT_TRUE(pre_hydro.layers[1].obstacle_layer.track_unknown_space);
  EXPECT_TRUE(pre_hydro_ns.unreadKeys().empty()) << joined(pre_hydro_ns.unreadKeys());

  YAML::Node plugins(YAML::NodeType::Map);
  setParam(plugins, "global_costmap/plugins",
           YAML::Load("[{name: map, type: 'costmap_2d::StaticLayer'}, {name: obstacles, type: 'costmap_2d::ObstacleLayer'},"
                      " {name: inflation, type: 'costmap_2d::InflationLayer'}]"));
  setParam(plugins, "global_costmap/obstacles/observation_sources", YAML::Node("scan"));
  setParam(plugins, "global_costmap/obstacles/scan/data_type", YAML::Node("LaserScan"));
  const CostmapConfig plugins_unset = readMoveBaseConfig(ParamNode(plugins, "move_base")).global_costmap;
  EXPECT_TRUE(plugins_unset.layers[0].static_layer.track_unknown_space);
  EXPECT_FALSE(plugins_unset.layers[1].obstacle_layer.track_unknown_space);

  setParam(plugins, "global_costmap/track_unknown_space", YAML::Node(true));
  setParam(plugins, "global_costmap/obstacles/track_unknown_space", YAML::Node(false));
  setParam(plugins, "global_costmap/inflation_radius", YAML::Node(0.3));
  setParam(plugins, "global_costmap/inflation/inflation_radius", YAML::Node(0.9));
  setParam(plugins, "global_costmap/obstacle_range", YAML::Node(2.0));
  setParam(plugins, "global_costmap/obstacles/obstacle_range", YAML::Node(4.0));
  const ParamNode plugins_ns(plugins, "move_base");
  const CostmapConfig copied = readMoveBaseConfig(plugins_ns).global_costmap;
  EXPECT_TRUE(copied.layers[0].static_layer.track_unknown_space);
  EXPECT_TRUE(copied.layers[1].obstacle_layer.track_unknown_space);
  EXPECT_DOUBLE_EQ(0.3, copied.layers[2].inflation_layer.inflation_radius);
  ASSERT_EQ(1u, copied.layers[1].obstacle_layer.sources.size());
  EXPECT_DOUBLE_EQ(2.0, copied.layers[1].obstacle_layer.sources[0].obstacle_range);
  EXPECT_TRUE(plugins_ns.unreadKeys().empty()) << joined(plugins_ns.unreadKeys());
}

TEST(NavParams, UnknownParametersAreReported) {
  YAML::Node tree(YAML::NodeType::Map);
  setParam(tree, "DWAPlannerROS/max_vel_xx", YAML::Node(0.3));
  setParam(tree, "local_costmap/widht", YAML::Node(3));
  setParam(tree, "controller_frequency", YAML::Node(10.0));
  setParam(tree, "TebLocalPlannerROS/max_vel_x", YAML::Node(0.3));
  const ParamNode ns(tree, "move_base");
  readMoveBaseConfig(ns);
  const std::vector<std::string> unread = ns.unreadKeys();
  ASSERT_EQ(3u, unread.size()) << joined(unread);
  EXPECT_EQ("move_base/DWAPlannerROS/max_vel_xx", unread[0]);
  EXPECT_EQ("move_base/TebLocalPlannerROS", unread[1]);
  EXPECT_EQ("move_base/local_costmap/widht", unread[2]);
}

namespace {

std::string errorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const ParamError& error) {
    return error.what();
  }
  return "";
}

}  // namespace

TEST(NavParams, MalformedFileGivesOneLineNamingIt) {
  YAML::Node tree(YAML::NodeType::Map);
  const std::string file = kSourceDir + "/test/data/nav/bad_syntax.yaml";
  const std::string message = errorOf([&] { loadYamlFileInto(tree, file, "global_costmap"); });
  ASSERT_FALSE(message.empty());
  EXPECT_EQ(0u, message.find(file)) << message;
  EXPECT_EQ(std::string::npos, message.find('\n')) << message;
  const std::string missing = errorOf([&] { loadYamlFileInto(tree, kSourceDir + "/test/data/nav/none.yaml", ""); });
  EXPECT_NE(std::string::npos, missing.find("none.yaml: cannot be read")) << missing;
}

TEST(NavParams, MalformedFootprintGivesOneLineNamingIt) {
  YAML::Node tree(YAML::NodeType::Map);
  loadYamlFileInto(tree, kSourceDir + "/test/data/nav/bad_footprint.yaml", "local_costmap");
  const ParamNode ns(tree, "move_base");
  const std::string message = errorOf([&] { readMoveBaseConfig(ns); });
  EXPECT_EQ(0u, message.find("move_base/local_costmap/footprint: ")) << message;
  EXPECT_EQ(std::string::npos, message.find('\n'));
  YAML::Node as_string(YAML::NodeType::Map);
  setParam(as_string, "global_costmap/footprint", YAML::Node("[[0.1, 0.1], [0.1 -0.1]]"));
  const std::string string_message = errorOf([&] { readMoveBaseConfig(ParamNode(as_string, "move_base")); });
  EXPECT_EQ(0u, string_message.find("move_base/global_costmap/footprint: expected ','")) << string_message;
}

TEST(NavParams, WrongTypesAndRangesNameTheParameter) {
  YAML::Node tree(YAML::NodeType::Map);
  setParam(tree, "controller_frequency", YAML::Node("fast"));
  EXPECT_EQ("move_base/controller_frequency: expected a number, got 'fast'",
            errorOf([&] { readMoveBaseConfig(ParamNode(tree, "move_base")); }));
  YAML::Node negative(YAML::NodeType::Map);
  setParam(negative, "DWAPlannerROS/sim_time", YAML::Node(-1.0));
  EXPECT_EQ(0u, errorOf([&] { readMoveBaseConfig(ParamNode(negative, "move_base")); })
                    .find("move_base/DWAPlannerROS/sim_time: must be in"));
  YAML::Node voxel(YAML::NodeType::Map);
  setParam(voxel, "local_costmap/map_type", YAML::Node("voxel"));
  EXPECT_EQ(0u, errorOf([&] { readMoveBaseConfig(ParamNode(voxel, "move_base")); })
                    .find("move_base/local_costmap/map_type: 'voxel' is not supported"));
  YAML::Node planner(YAML::NodeType::Map);
  setParam(planner, "base_local_planner", YAML::Node("teb_local_planner/TebLocalPlannerROS"));
  EXPECT_EQ(0u, errorOf([&] { readMoveBaseConfig(ParamNode(planner, "move_base")); })
                    .find("move_base/base_local_planner: "));
}
