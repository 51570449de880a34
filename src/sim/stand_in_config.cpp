#include "marl_mrta/sim/stand_in_config.h"

#include <algorithm>
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
  // The stand-in plays the robots it is given by name (real.launch's), however many.
  if (!config.robot_names.empty()) config.robots = static_cast<int>(config.robot_names.size());
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
