#include "marl_mrta/sim/sim_params_ros.h"

#include <XmlRpcValue.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <sstream>

namespace marl_mrta {
namespace sim {

namespace {

using XmlRpc::XmlRpcValue;

std::string typeName(const XmlRpcValue& value) {
  switch (value.getType()) {
    case XmlRpcValue::TypeBoolean: return "a boolean";
    case XmlRpcValue::TypeInt: return "an integer";
    case XmlRpcValue::TypeDouble: return "a number";
    case XmlRpcValue::TypeString: return "a string '" + static_cast<std::string>(const_cast<XmlRpcValue&>(value)) + "'";
    case XmlRpcValue::TypeArray: return "a list";
    case XmlRpcValue::TypeStruct: return "a dictionary";
    default: return "an unsupported value";
  }
}

bool isNumber(const XmlRpcValue& value) {
  return value.getType() == XmlRpcValue::TypeInt || value.getType() == XmlRpcValue::TypeDouble;
}

double asNumber(XmlRpcValue& value) {
  return value.getType() == XmlRpcValue::TypeInt ? static_cast<int>(value) : static_cast<double>(value);
}

// Each reader converts one parameter or throws ConfigError(name, problem).
using Reader = std::function<void(const std::string& name, XmlRpcValue& value)>;

Reader number(double& target) {
  return [&target](const std::string& name, XmlRpcValue& value) {
    if (!isNumber(value)) throw ConfigError(name, "must be a number, got " + typeName(value));
    target = asNumber(value);
    if (!std::isfinite(target)) throw ConfigError(name, "must be finite");
  };
}

Reader integer(int& target) {
  return [&target](const std::string& name, XmlRpcValue& value) {
    if (value.getType() != XmlRpcValue::TypeInt) throw ConfigError(name, "must be an integer, got " + typeName(value));
    target = static_cast<int>(value);
  };
}

Reader boolean(bool& target) {
  return [&target](const std::string& name, XmlRpcValue& value) {
    if (value.getType() != XmlRpcValue::TypeBoolean) {
      throw ConfigError(name, "must be true or false, got " + typeName(value));
    }
    target = static_cast<bool>(value);
  };
}

Reader text(std::string& target) {
  return [&target](const std::string& name, XmlRpcValue& value) {
    if (value.getType() != XmlRpcValue::TypeString) throw ConfigError(name, "must be a string, got " + typeName(value));
    target = static_cast<std::string>(value);
  };
}

// A list of names, or one string of names separated by spaces or commas (handy in launch files).
Reader names(std::vector<std::string>& target) {
  return [&target](const std::string& name, XmlRpcValue& value) {
    target.clear();
    if (value.getType() == XmlRpcValue::TypeString) {
      std::string words = static_cast<std::string>(value);
      std::replace(words.begin(), words.end(), ',', ' ');
      std::istringstream in(words);
      for (std::string word; in >> word;) target.push_back(word);
      return;
    }
    if (value.getType() != XmlRpcValue::TypeArray) throw ConfigError(name, "must be a list of robot names");
    for (int i = 0; i < value.size(); ++i) {
      if (value[i].getType() != XmlRpcValue::TypeString) {
        throw ConfigError(name + "[" + std::to_string(i) + "]", "must be a robot name, got " + typeName(value[i]));
      }
      target.push_back(static_cast<std::string>(value[i]));
    }
  };
}

Reader poses(std::vector<Pose2D>& target) {
  return [&target](const std::string& name, XmlRpcValue& value) {
    if (value.getType() != XmlRpcValue::TypeArray) throw ConfigError(name, "must be a list of [x, y, yaw]");
    target.clear();
    for (int i = 0; i < value.size(); ++i) {
      XmlRpcValue& pose = value[i];
      const std::string field = name + "[" + std::to_string(i) + "]";
      if (pose.getType() != XmlRpcValue::TypeArray || pose.size() != 3 || !isNumber(pose[0]) || !isNumber(pose[1]) ||
          !isNumber(pose[2])) {
        throw ConfigError(field, "must be [x, y, yaw] (3 numbers, m and rad)");
      }
      target.push_back({asNumber(pose[0]), asNumber(pose[1]), asNumber(pose[2])});
    }
  };
}

}  // namespace

SimConfig readSimConfig(const ros::NodeHandle& private_nh) {
  SimConfig config;
  RobotSpec& robot = config.robot;
  int lidar_beams = robot.lidar.beams;
  const std::map<std::string, Reader> readers = {
      {"map_file", text(config.map_file)},
      {"robots", integer(config.robots)},
      {"arenas", integer(config.arenas)},
      {"start_poses", poses(config.start_poses)},
      {"physics_rate", number(config.physics_rate)},
      {"scan_rate", number(config.scan_rate)},
      {"odom_rate", number(config.odom_rate)},
      {"rtf", number(config.rtf)},
      {"lockstep", boolean(config.lockstep)},
      {"lockstep_robots", names(config.lockstep_robots)},
      {"cmd_vel_timeout", number(config.cmd_vel_timeout)},
      {"noise_profile", text(config.noise_profile)},
      {"seed", integer(config.seed)},
      {"scan_invalid_as_inf", boolean(config.scan_invalid_as_inf)},
      {"publish_localization", boolean(config.publish_localization)},
      {"robot_radius", number(robot.radius)},
      {"max_linear_velocity", number(robot.limits.max_linear_velocity)},
      {"max_angular_velocity", number(robot.limits.max_angular_velocity)},
      {"max_linear_acceleration", number(robot.limits.max_linear_acceleration)},
      {"max_angular_acceleration", number(robot.limits.max_angular_acceleration)},
      {"lidar_beams", integer(lidar_beams)},
      {"lidar_range_min", number(robot.lidar.range_min)},
      {"lidar_range_max", number(robot.lidar.range_max)},
      {"lidar_offset_x", number(robot.lidar.mount_x)},
      {"lidar_offset_y", number(robot.lidar.mount_y)},
      {"start_paused", boolean(config.start_paused)},
      {"stop_after", number(config.stop_after)},
      {"stats_file", text(config.stats_file)},
  };
  const std::string prefix = private_nh.getNamespace() + "/";
  XmlRpcValue all;
  if (!private_nh.getParam(private_nh.getNamespace(), all)) return config;  // nothing set: defaults
  if (all.getType() != XmlRpcValue::TypeStruct) throw ConfigError(private_nh.getNamespace(), "must hold parameters");
  for (auto& entry : all) {
    const auto reader = readers.find(entry.first);
    if (reader == readers.end()) {
      throw ConfigError(prefix + entry.first, "unknown parameter (see docs/simulator.md for the list)");
    }
    reader->second(prefix + entry.first, entry.second);
  }
  robot.lidar.beams = lidar_beams;
  return config;
}

}  // namespace sim
}  // namespace marl_mrta
