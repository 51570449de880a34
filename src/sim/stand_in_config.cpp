#include "marl_mrta/sim/stand_in_config.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

namespace marl_mrta {
namespace sim {

namespace {

using nav::ParamError;
using nav::ParamNode;

double positive(const ParamNode& params, const std::string& key, double default_value) {
  const double value = params.getDouble(key, default_value);
  if (!(value > 0.0) || !std::isfinite(value)) throw ParamError(params.pathOf(key), "must be a positive number");
  return value;
}

bool validName(const std::string& name) {
  if (name.empty() || name.front() == '/' || name.back() == '/') return false;
  return std::all_of(name.begin(), name.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/'; });
}

}  // namespace

std::vector<std::string> readNameList(const ParamNode& params, const std::string& key,
                                      const std::vector<std::string>& default_value) {
  const YAML::Node value = params.raw(key);
  if (!value.IsDefined()) return default_value;
  std::vector<std::string> names;
  if (value.IsScalar()) {
    std::string words = value.Scalar();
    std::replace(words.begin(), words.end(), ',', ' ');
    std::istringstream in(words);
    for (std::string word; in >> word;) names.push_back(word);
    return names;
  }
  if (!value.IsSequence()) throw ParamError(params.pathOf(key), "must be a list of robot names");
  for (size_t i = 0; i < value.size(); ++i) {
    if (!value[i].IsScalar()) throw ParamError(params.pathOf(key) + "[" + std::to_string(i) + "]", "must be a robot name");
    names.push_back(value[i].Scalar());
  }
  return names;
}

StandInConfig readStandInConfig(const ParamNode& params) {
  StandInConfig stand_in;
  stand_in.enabled = params.getBool("stand_in", stand_in.enabled);
  stand_in.robot_names = readNameList(params, "robot_names", {});
  stand_in.imu_rate = positive(params, "imu_rate", stand_in.imu_rate);
  stand_in.scan_stamp_lag = params.getDouble("scan_stamp_lag", stand_in.scan_stamp_lag, 0.0, 1.0);
  stand_in.lds_rpm = positive(params, "lds_rpm", stand_in.lds_rpm);
  stand_in.wheel_radius = positive(params, "wheel_radius", stand_in.wheel_radius);
  stand_in.wheel_separation = positive(params, "wheel_separation", stand_in.wheel_separation);
  stand_in.battery_voltage = params.getDouble("battery_voltage", stand_in.battery_voltage, 0.0, 30.0);
  stand_in.battery_drain = params.getDouble("battery_drain", stand_in.battery_drain, 0.0, 100.0);
  stand_in.ground_truth_file = params.getString("ground_truth_file", stand_in.ground_truth_file);
  return stand_in;
}

void checkStandIn(StandInConfig& stand_in, SimConfig& config) {
  if (config.lockstep) throw ParamError("lockstep", "must be false with stand_in (a robot does not wait for its controllers)");
  if (config.arenas != 1) throw ParamError("arenas", "must be 1 with stand_in");
  if (config.publish_localization) {
    throw ParamError("publish_localization", "must be false with stand_in (map -> odom is amcl's on real robots)");
  }
  if (config.start_paused) throw ParamError("start_paused", "must be false with stand_in (no pause on real robots)");
  if (stand_in.robot_names.empty()) {
    for (int i = 0; i < config.robots; ++i) stand_in.robot_names.push_back("tb3_" + std::to_string(i));
  }
  for (size_t i = 0; i < stand_in.robot_names.size(); ++i) {
    const std::string& name = stand_in.robot_names[i];
    if (!validName(name)) {
      throw ParamError("robot_names[" + std::to_string(i) + "]",
                       "'" + name + "' is not a relative namespace (letters, digits, _ and /, no leading slash)");
    }
    if (std::count(stand_in.robot_names.begin(), stand_in.robot_names.end(), name) > 1) {
      throw ParamError("robot_names", "'" + name + "' is given twice");
    }
  }
  config.robots = static_cast<int>(stand_in.robot_names.size());
  if (stand_in.imu_rate > config.physics_rate) {
    std::ostringstream problem;
    problem << "must not exceed physics_rate (" << config.physics_rate << " Hz), got " << stand_in.imu_rate;
    throw ParamError("imu_rate", problem.str());
  }
  if (config.scan_rate > 0.0 && stand_in.scan_stamp_lag > 1.0 / config.scan_rate) {
    std::ostringstream problem;
    problem << "must not exceed one rotation (" << 1.0 / config.scan_rate << " s), got " << stand_in.scan_stamp_lag;
    throw ParamError("scan_stamp_lag", problem.str());
  }
}

}  // namespace sim
}  // namespace marl_mrta
