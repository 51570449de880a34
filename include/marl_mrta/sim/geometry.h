// Plain 2D geometry shared by the simulator's parts (map frame, SI units).
#pragma once

#include <cmath>

namespace marl_mrta {
namespace sim {

struct Point2D {
  double x = 0.0;
  double y = 0.0;
};

struct Pose2D {
  double x = 0.0;    // [m]
  double y = 0.0;    // [m]
  double yaw = 0.0;  // [rad]
};

// Body-frame velocity of a differential-drive robot.
struct Twist2D {
  double linear = 0.0;   // [m/s] along the robot's x axis
  double angular = 0.0;  // [rad/s] about z
};

// The same angle in [-pi, pi).
inline double normalizeAngle(double angle) {
  if (angle >= -M_PI && angle < M_PI) return angle;  // the usual case, kept exact
  angle = std::fmod(angle + M_PI, 2.0 * M_PI);
  return (angle < 0.0 ? angle + 2.0 * M_PI : angle) - M_PI;
}

}  // namespace sim
}  // namespace marl_mrta
