#include "map_server_ros.h"

#include <nav_msgs/MapMetaData.h>
#include <nav_msgs/OccupancyGrid.h>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/ros_conversions.h"

namespace marl_mrta {
namespace nav {

MapServerRos::MapServerRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh, const std::string& map_file) {
  const std::string frame_id = private_nh.param<std::string>("frame_id", "map");
  const map::OccupancyMap occupancy = map::loadMap(map_file);
  response_.map = ros_conversions::toOccupancyGrid(occupancy, frame_id, ros::Time::now());
  map_pub_ = nh.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
  metadata_pub_ = nh.advertise<nav_msgs::MapMetaData>("map_metadata", 1, true);
  map_pub_.publish(response_.map);
  metadata_pub_.publish(response_.map.info);
  service_ = nh.advertiseService<nav_msgs::GetMap::Request, nav_msgs::GetMap::Response>(
      "static_map", [this](nav_msgs::GetMap::Request&, nav_msgs::GetMap::Response& out) {
        out = response_;
        return true;
      });
  ROS_INFO("map_server: %s, %d x %d cells at %.3f m, frame %s", map_file.c_str(), occupancy.width, occupancy.height,
           occupancy.resolution, frame_id.c_str());
}

}  // namespace nav
}  // namespace marl_mrta
