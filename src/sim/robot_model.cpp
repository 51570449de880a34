#include "marl_mrta/sim/robot_model.h"

#include <cmath>
#include <limits>

namespace marl_mrta {
namespace sim {

double LidarSpec::angleIncrement() const { return 2.0 * M_PI / beams; }

float LidarSpec::noReturnValue() const {
  return invalid_as_inf ? std::numeric_limits<float>::infinity() : 0.0f;
}

float LidarSpec::tooCloseValue() const {
  return invalid_as_inf ? -std::numeric_limits<float>::infinity() : 0.0f;
}

}  // namespace sim
}  // namespace marl_mrta
