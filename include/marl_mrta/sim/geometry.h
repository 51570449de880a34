// Plain 2D geometry shared by the simulator's parts (map frame, SI units).
#pragma once

#include "marl_mrta/geometry.h"

namespace marl_mrta {
namespace sim {

using ::marl_mrta::normalizeAngle;
using ::marl_mrta::Pose2D;

struct Point2D {
  double x = 0.0;
  double y = 0.0;
};

// Body-frame velocity of a differential-drive robot.
struct Twist2D {
  double linear = 0.0;   // [m/s] along the robot's x axis
  double angular = 0.0;  // [rad/s] about z
};

}  // namespace sim
}  // namespace marl_mrta
