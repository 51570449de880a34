#include "marl_mrta/sim/diff_drive.h"

#include <algorithm>
#include <cmath>

namespace marl_mrta {
namespace sim {

namespace {

double clampMagnitude(double value, double limit) {
  if (!std::isfinite(value)) return 0.0;
  return std::min(std::max(value, -limit), limit);
}

}  // namespace

Twist2D limitVelocity(const Twist2D& command, const DriveLimits& limits) {
  return {clampMagnitude(command.linear, limits.max_linear_velocity),
          clampMagnitude(command.angular, limits.max_angular_velocity)};
}

Twist2D accelerate(const Twist2D& current, const Twist2D& target, const DriveLimits& limits, double dt) {
  return {current.linear + clampMagnitude(target.linear - current.linear, limits.max_linear_acceleration * dt),
          current.angular + clampMagnitude(target.angular - current.angular, limits.max_angular_acceleration * dt)};
}

Pose2D integrate(const Pose2D& pose, const Twist2D& velocity, double dt) {
  const double turn = velocity.angular * dt;
  Pose2D next;
  if (std::abs(turn) < 1e-9) {
    // Second-order expansion of the arc: exact enough and free of 0/0.
    const double heading = pose.yaw + 0.5 * turn;
    next.x = pose.x + velocity.linear * dt * std::cos(heading);
    next.y = pose.y + velocity.linear * dt * std::sin(heading);
  } else {
    const double radius = velocity.linear / velocity.angular;
    next.x = pose.x + radius * (std::sin(pose.yaw + turn) - std::sin(pose.yaw));
    next.y = pose.y - radius * (std::cos(pose.yaw + turn) - std::cos(pose.yaw));
  }
  next.yaw = normalizeAngle(pose.yaw + turn);
  return next;
}

}  // namespace sim
}  // namespace marl_mrta
