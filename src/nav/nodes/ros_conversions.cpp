#include "marl_mrta/nav/ros_conversions.h"

#include <ros/param.h>

#include <cmath>
#include <cstring>
#include <sstream>

namespace marl_mrta {
namespace nav {
namespace ros_conversions {

YAML::Node toYaml(const XmlRpc::XmlRpcValue& value) {
  XmlRpc::XmlRpcValue& v = const_cast<XmlRpc::XmlRpcValue&>(value);  // XmlRpc's accessors are not const
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return YAML::Node(static_cast<bool>(v));
    case XmlRpc::XmlRpcValue::TypeInt:
      return YAML::Node(static_cast<int>(v));
    case XmlRpc::XmlRpcValue::TypeDouble: {
      std::ostringstream out;
      out.precision(17);
      out << static_cast<double>(v);
      return YAML::Node(out.str());
    }
    case XmlRpc::XmlRpcValue::TypeString:
      return YAML::Node(static_cast<std::string>(v));
    case XmlRpc::XmlRpcValue::TypeArray: {
      YAML::Node list(YAML::NodeType::Sequence);
      for (int i = 0; i < v.size(); ++i) list.push_back(toYaml(v[i]));
      return list;
    }
    case XmlRpc::XmlRpcValue::TypeStruct: {
      YAML::Node map(YAML::NodeType::Map);
      for (auto it = v.begin(); it != v.end(); ++it) map[it->first] = toYaml(it->second);
      return map;
    }
    default:
      return YAML::Node(v.toXml());
  }
}

YAML::Node parameterTree(const ros::NodeHandle& nh) {
  XmlRpc::XmlRpcValue params;
  if (!ros::param::get(nh.getNamespace(), params) || params.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
    return YAML::Node(YAML::NodeType::Map);
  }
  return toYaml(params);
}

double yawOf(const geometry_msgs::Quaternion& q) {
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

geometry_msgs::Quaternion quaternionFromYaw(double yaw) {
  geometry_msgs::Quaternion q;
  q.z = std::sin(yaw / 2.0);
  q.w = std::cos(yaw / 2.0);
  return q;
}

Pose2D toPose2D(const geometry_msgs::Pose& pose) { return {pose.position.x, pose.position.y, yawOf(pose.orientation)}; }

Pose2D toPose2D(const geometry_msgs::TransformStamped& t) {
  return {t.transform.translation.x, t.transform.translation.y, yawOf(t.transform.rotation)};
}

std::string quaternionProblem(const geometry_msgs::Quaternion& q) {
  if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) || !std::isfinite(q.w)) {
    return "Quaternion has nans or infs... discarding as a navigation goal";
  }
  const double length = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (length < 1e-6) return "Quaternion has length close to zero... discarding as navigation goal";
  // The rotated z axis must stay (nearly) vertical for a planar goal.
  const double x = q.x / length, y = q.y / length;
  const double z_of_rotated_z = 1.0 - 2.0 * (x * x + y * y);
  if (std::fabs(z_of_rotated_z - 1.0) > 1e-3) {
    return "Quaternion is invalid... for navigation the z-axis of the quaternion must be close to vertical.";
  }
  return "";
}

map::OccupancyMap toOccupancyMap(const nav_msgs::OccupancyGrid& grid) {
  map::OccupancyMap occupancy;
  occupancy.resolution = grid.info.resolution;
  occupancy.origin_x = grid.info.origin.position.x;
  occupancy.origin_y = grid.info.origin.position.y;
  occupancy.origin_yaw = yawOf(grid.info.origin.orientation);
  occupancy.width = static_cast<int>(grid.info.width);
  occupancy.height = static_cast<int>(grid.info.height);
  occupancy.data = grid.data;
  return occupancy;
}

nav_msgs::OccupancyGrid toOccupancyGrid(const map::OccupancyMap& occupancy, const std::string& frame_id,
                                        const ros::Time& stamp) {
  nav_msgs::OccupancyGrid grid;
  grid.header.frame_id = frame_id;
  grid.header.stamp = stamp;
  grid.info.map_load_time = stamp;
  grid.info.resolution = static_cast<float>(occupancy.resolution);
  grid.info.width = occupancy.width;
  grid.info.height = occupancy.height;
  grid.info.origin.position.x = occupancy.origin_x;
  grid.info.origin.position.y = occupancy.origin_y;
  grid.info.origin.orientation = quaternionFromYaw(occupancy.origin_yaw);
  grid.data = occupancy.data;
  return grid;
}

nav_msgs::OccupancyGrid costmapToOccupancyGrid(const CostGrid& costs, const std::string& frame_id,
                                               const ros::Time& stamp) {
  // costmap_2d's Costmap2DPublisher translation table.
  static const std::vector<int8_t> translation = [] {
    std::vector<int8_t> table(256);
    table[0] = 0;
    for (int i = 1; i < 253; ++i) table[i] = static_cast<int8_t>(1 + (97 * (i - 1)) / 251);
    table[253] = 99;
    table[254] = 100;
    table[255] = -1;
    return table;
  }();
  nav_msgs::OccupancyGrid grid;
  grid.header.frame_id = frame_id;
  grid.header.stamp = stamp;
  grid.info.resolution = static_cast<float>(costs.resolution());
  grid.info.width = costs.sizeX();
  grid.info.height = costs.sizeY();
  grid.info.origin.position.x = costs.originX();
  grid.info.origin.position.y = costs.originY();
  grid.info.origin.orientation.w = 1.0;
  grid.data.resize(costs.cells().size());
  for (size_t i = 0; i < costs.cells().size(); ++i) grid.data[i] = translation[costs.cells()[i]];
  return grid;
}

sensor_msgs::PointCloud2 toPointCloud2(const std::vector<std::string>& fields, const std::vector<float>& values,
                                       const std::string& frame_id, const ros::Time& stamp) {
  sensor_msgs::PointCloud2 cloud;
  cloud.header.frame_id = frame_id;
  cloud.header.stamp = stamp;
  for (size_t i = 0; i < fields.size(); ++i) {
    sensor_msgs::PointField field;
    field.name = fields[i];
    field.offset = static_cast<uint32_t>(i * sizeof(float));
    field.datatype = sensor_msgs::PointField::FLOAT32;
    field.count = 1;
    cloud.fields.push_back(field);
  }
  cloud.point_step = static_cast<uint32_t>(fields.size() * sizeof(float));
  cloud.height = 1;
  cloud.width = fields.empty() ? 0 : static_cast<uint32_t>(values.size() / fields.size());
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.is_dense = true;
  cloud.data.resize(values.size() * sizeof(float));
  if (!values.empty()) std::memcpy(cloud.data.data(), values.data(), cloud.data.size());
  return cloud;
}

nav_msgs::Path toPath(const std::vector<Pose2D>& poses, const std::string& frame_id, const ros::Time& stamp) {
  nav_msgs::Path path;
  path.header.frame_id = frame_id;
  path.header.stamp = stamp;
  path.poses.resize(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    path.poses[i].header = path.header;
    path.poses[i].pose.position.x = poses[i].x;
    path.poses[i].pose.position.y = poses[i].y;
    path.poses[i].pose.orientation = quaternionFromYaw(poses[i].yaw);
  }
  return path;
}

}  // namespace ros_conversions
}  // namespace nav
}  // namespace marl_mrta
