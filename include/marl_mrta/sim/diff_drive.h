// Differential-drive kinematics: velocity and acceleration limits, exact arc integration.
#pragma once

#include "marl_mrta/sim/geometry.h"
#include "marl_mrta/sim/robot_model.h"

namespace marl_mrta {
namespace sim {

// The command clamped to the velocity limits (non-finite components become 0).
Twist2D limitVelocity(const Twist2D& command, const DriveLimits& limits);

// The velocity after one step of `dt` towards `target`, changing each component by at most
// its acceleration limit times dt.
Twist2D accelerate(const Twist2D& current, const Twist2D& target, const DriveLimits& limits, double dt);

// Pose after driving `velocity` for `dt` (a circular arc; a straight line when angular is 0).
Pose2D integrate(const Pose2D& pose, const Twist2D& velocity, double dt);

}  // namespace sim
}  // namespace marl_mrta
