// The built-in map_server's ROS side, shared by the node and the nodelet: publishes the map of
// a map_server YAML latched on `map` and `map_metadata` and answers `static_map`
// (nav_msgs/GetMap). Param ~frame_id (default map).
#pragma once

#include <nav_msgs/GetMap.h>
#include <ros/ros.h>

#include <string>

namespace marl_mrta {
namespace nav {

class MapServerRos {
 public:
  // Throws map::MapError (naming the file and the problem) when the map cannot be loaded.
  MapServerRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh, const std::string& map_file);

 private:
  nav_msgs::GetMap::Response response_;
  ros::Publisher map_pub_, metadata_pub_;
  ros::ServiceServer service_;
};

}  // namespace nav
}  // namespace marl_mrta
