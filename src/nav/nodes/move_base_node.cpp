// move_base drop-in (navfn global planner + DWA local planner), see move_base_ros.h.
#include <ros/ros.h>

#include "marl_mrta/nav/param_tree.h"
#include "move_base_ros.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "move_base");
  ros::NodeHandle nh, private_nh("~");
  std::unique_ptr<marl_mrta::nav::MoveBaseRos> node;
  try {
    node = std::make_unique<marl_mrta::nav::MoveBaseRos>(nh, private_nh);
  } catch (const marl_mrta::nav::ParamError& error) {
    ROS_FATAL("move_base: %s", error.what());
    return 1;
  }
  ros::spin();
  return 0;
}
