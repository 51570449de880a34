// map_server drop-in: `map_server <map.yaml>` publishes the map latched on `map` and
// `map_metadata` and answers `static_map` (nav_msgs/GetMap). Param ~frame_id (default map).
#include <nav_msgs/GetMap.h>
#include <nav_msgs/MapMetaData.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/ros_conversions.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "map_server");
  if (argc < 2) {
    ROS_FATAL("usage: map_server <map.yaml>");
    return 1;
  }
  ros::NodeHandle nh, private_nh("~");
  const std::string frame_id = private_nh.param<std::string>("frame_id", "map");
  marl_mrta::map::OccupancyMap occupancy;
  try {
    occupancy = marl_mrta::map::loadMap(argv[1]);
  } catch (const marl_mrta::map::MapError& error) {
    ROS_FATAL("%s", error.what());
    return 1;
  }
  nav_msgs::GetMap::Response response;
  response.map = marl_mrta::nav::ros_conversions::toOccupancyGrid(occupancy, frame_id, ros::Time::now());
  ros::Publisher map_pub = nh.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
  ros::Publisher metadata_pub = nh.advertise<nav_msgs::MapMetaData>("map_metadata", 1, true);
  map_pub.publish(response.map);
  metadata_pub.publish(response.map.info);
  ros::ServiceServer service = nh.advertiseService<nav_msgs::GetMap::Request, nav_msgs::GetMap::Response>(
      "static_map", [&response](nav_msgs::GetMap::Request&, nav_msgs::GetMap::Response& out) {
        out = response;
        return true;
      });
  ROS_INFO("map_server: %s, %d x %d cells at %.3f m, frame %s", argv[1], occupancy.width, occupancy.height,
           occupancy.resolution, frame_id.c_str());
  ros::spin();
  return 0;
}
