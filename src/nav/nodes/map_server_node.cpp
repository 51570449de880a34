// map_server drop-in: `map_server <map.yaml>` (map_server_ros.h).
#include <ros/ros.h>

#include "map_server_ros.h"
#include "marl_mrta/map/occupancy_map.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "map_server");
  if (argc < 2) {
    ROS_FATAL("usage: map_server <map.yaml>");
    return 1;
  }
  ros::NodeHandle nh, private_nh("~");
  try {
    marl_mrta::nav::MapServerRos server(nh, private_nh, argv[1]);
    ros::spin();
  } catch (const marl_mrta::map::MapError& error) {
    ROS_FATAL("%s", error.what());
    return 1;
  }
  return 0;
}
