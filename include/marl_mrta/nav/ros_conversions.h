// Conversions between ROS messages / parameters and the navigation cores' plain types.
#pragma once

#include <xmlrpcpp/XmlRpcValue.h>
#include <yaml-cpp/yaml.h>

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Quaternion.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <sensor_msgs/PointCloud2.h>
#include <ros/node_handle.h>
#include <ros/time.h>

#include <string>
#include <vector>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/costmap_grid.h"
#include "marl_mrta/nav/footprint.h"

namespace marl_mrta {
namespace nav {
namespace ros_conversions {

// A parameter subtree (ros::NodeHandle::getParam("~", value)) as the YAML tree the cores read.
YAML::Node toYaml(const XmlRpc::XmlRpcValue& value);
// Every parameter in the namespace of `nh` (a node's private one) as one YAML tree: an empty
// mapping when none is set.
YAML::Node parameterTree(const ros::NodeHandle& nh);

double yawOf(const geometry_msgs::Quaternion& q);
geometry_msgs::Quaternion quaternionFromYaw(double yaw);
Pose2D toPose2D(const geometry_msgs::Pose& pose);
Pose2D toPose2D(const geometry_msgs::TransformStamped& transform);
// move_base's check: finite, not of zero length, z axis (nearly) vertical. Empty when valid.
std::string quaternionProblem(const geometry_msgs::Quaternion& q);

map::OccupancyMap toOccupancyMap(const nav_msgs::OccupancyGrid& grid);
nav_msgs::OccupancyGrid toOccupancyGrid(const map::OccupancyMap& occupancy, const std::string& frame_id,
                                        const ros::Time& stamp);
// A costmap as an OccupancyGrid with costmap_2d's cost translation (254 -> 100, 255 -> -1, ...).
nav_msgs::OccupancyGrid costmapToOccupancyGrid(const CostGrid& grid, const std::string& frame_id,
                                               const ros::Time& stamp);
nav_msgs::Path toPath(const std::vector<Pose2D>& poses, const std::string& frame_id, const ros::Time& stamp);
// An unorganised cloud of float32 fields, `values` row by row (fields.size() values a point).
sensor_msgs::PointCloud2 toPointCloud2(const std::vector<std::string>& fields, const std::vector<float>& values,
                                       const std::string& frame_id, const ros::Time& stamp);

}  // namespace ros_conversions
}  // namespace nav
}  // namespace marl_mrta
