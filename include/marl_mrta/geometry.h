// Poses and angles in the plane, shared by the simulator and navigation (map frame, SI units).
#pragma once

#include <cmath>

namespace marl_mrta {

struct Pose2D {
  double x = 0.0;    // [m]
  double y = 0.0;    // [m]
  double yaw = 0.0;  // [rad]
};

// The same angle in [-pi, pi) as fmod(angle + pi, 2 pi) - pi. Every angle passes through
// angle + pi, so one already in range comes back rounded to the spacing of doubles near pi
// (up to 4.4e-16 off). Navigation's controller and recovery compute with this; their commands
// depend on it to the last bit.
inline double normalizeAngleByFmod(double angle) {
  angle = std::fmod(angle + M_PI, 2.0 * M_PI);
  return (angle < 0.0 ? angle + 2.0 * M_PI : angle) - M_PI;
}

// The same angle in [-pi, pi); one already in range is returned unchanged, exactly.
inline double normalizeAngle(double angle) {
  if (angle >= -M_PI && angle < M_PI) return angle;
  return normalizeAngleByFmod(angle);
}

}  // namespace marl_mrta
