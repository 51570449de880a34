// config/robot_burger.yaml, the one description of the robot, agrees with the navigation
// parameter files move_base gets: the same footprint, DWA's speeds within the robot's limits,
// DWA's accelerations the robot's.
#include <gtest/gtest.h>

#include <string>

#include "marl_mrta/nav/move_base_config.h"

using namespace marl_mrta::nav;

namespace {

const std::string kSourceDir = MARL_MRTA_SOURCE_DIR;

double number(const YAML::Node& robot, const std::string& key) {
  if (!robot[key]) throw ParamError("robot_burger.yaml/" + key, "missing");
  return robot[key].as<double>();
}

}  // namespace

TEST(RobotDescription, AgreesWithTheNavigationParameterFiles) {
  const YAML::Node robot = YAML::LoadFile(kSourceDir + "/config/robot_burger.yaml");
  const MoveBaseConfig nav = readMoveBaseConfig(ParamNode(loadMoveBaseParams(kSourceDir + "/config/nav"), "move_base"));

  const YAML::Node footprint = robot["footprint"];
  ASSERT_TRUE(footprint.IsSequence());
  for (const CostmapConfig* costmap : {&nav.global_costmap, &nav.local_costmap}) {
    ASSERT_EQ(footprint.size(), costmap->footprint.size());
    for (size_t i = 0; i < footprint.size(); ++i) {
      EXPECT_EQ(footprint[i][0].as<double>(), costmap->footprint[i].x) << "footprint point " << i;
      EXPECT_EQ(footprint[i][1].as<double>(), costmap->footprint[i].y) << "footprint point " << i;
    }
  }

  const LocalPlannerLimits& dwa = nav.dwa.limits;
  EXPECT_LE(dwa.max_vel_x, number(robot, "max_linear_velocity"));
  EXPECT_LE(dwa.max_vel_trans, number(robot, "max_linear_velocity"));
  EXPECT_LE(dwa.max_vel_theta, number(robot, "max_angular_velocity"));
  EXPECT_EQ(dwa.acc_lim_x, number(robot, "max_linear_acceleration"));
  EXPECT_EQ(dwa.acc_lim_theta, number(robot, "max_angular_acceleration"));
}
