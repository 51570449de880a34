#include "marl_mrta/loc/odometry_model.h"

#include <algorithm>
#include <cmath>

#include "marl_mrta/nav/local_controller.h"

namespace marl_mrta {
namespace loc {
namespace {

using nav::normalizeAngle;

// A rotation's size for the noise: its distance from driving straight forward or backward, so
// that reversing counts as no turn.
double turnNoise(double rotation) {
  return std::min(std::abs(normalizeAngle(rotation)), std::abs(normalizeAngle(rotation - M_PI)));
}

void diffMotion(const OdometryModelParams& p, bool corrected, double dx, double dy, double dyaw, double yaw_before,
                std::vector<Particle>& particles, RandomSource& rng) {
  const double trans = std::hypot(dx, dy);
  // No bearing from two nearly equal positions (turning in place).
  const double rot1 = trans < 0.01 ? 0.0 : normalizeAngle(std::atan2(dy, dx) - yaw_before);
  const double rot2 = normalizeAngle(dyaw - rot1);
  const double rot1_noise = turnNoise(rot1), rot2_noise = turnNoise(rot2);
  const auto spread = [corrected](double alpha_sum) { return corrected ? std::sqrt(alpha_sum) : alpha_sum; };
  const double sigma_rot1 = spread(p.alpha1 * rot1_noise * rot1_noise + p.alpha2 * trans * trans);
  const double sigma_trans =
      spread(p.alpha3 * trans * trans + p.alpha4 * rot1_noise * rot1_noise + p.alpha4 * rot2_noise * rot2_noise);
  const double sigma_rot2 = spread(p.alpha1 * rot2_noise * rot2_noise + p.alpha2 * trans * trans);
  for (Particle& particle : particles) {
    const double rot1_hat = normalizeAngle(rot1 - rng.gaussian(sigma_rot1));
    const double trans_hat = trans - rng.gaussian(sigma_trans);
    const double rot2_hat = normalizeAngle(rot2 - rng.gaussian(sigma_rot2));
    Pose2D& pose = particle.pose;
    pose.x += trans_hat * std::cos(pose.yaw + rot1_hat);
    pose.y += trans_hat * std::sin(pose.yaw + rot1_hat);
    pose.yaw = normalizeAngle(pose.yaw + rot1_hat + rot2_hat);
  }
}

void omniMotion(const OdometryModelParams& p, bool corrected, double dx, double dy, double dyaw, double yaw_before,
                std::vector<Particle>& particles, RandomSource& rng) {
  const double trans = std::hypot(dx, dy);
  const double rot = dyaw;
  // amcl's omni and omni-corrected weigh the rotation terms differently (alpha1 vs alpha4).
  const double sigma_trans = corrected ? std::sqrt(p.alpha3 * trans * trans + p.alpha4 * rot * rot)
                                       : p.alpha3 * trans * trans + p.alpha1 * rot * rot;
  const double sigma_rot = corrected ? std::sqrt(p.alpha1 * rot * rot + p.alpha2 * trans * trans)
                                     : p.alpha4 * rot * rot + p.alpha2 * trans * trans;
  const double sigma_strafe = corrected ? std::sqrt(p.alpha4 * rot * rot + p.alpha5 * trans * trans)
                                        : p.alpha1 * rot * rot + p.alpha5 * trans * trans;
  // Direction of travel relative to the heading, as the odometry saw it.
  const double travel_bearing = normalizeAngle(std::atan2(dy, dx) - yaw_before);
  for (Particle& particle : particles) {
    Pose2D& pose = particle.pose;
    const double bearing = travel_bearing + pose.yaw;
    const double c = std::cos(bearing), s = std::sin(bearing);
    const double trans_hat = trans + rng.gaussian(sigma_trans);
    const double rot_hat = rot + rng.gaussian(sigma_rot);
    const double strafe_hat = rng.gaussian(sigma_strafe);
    pose.x += trans_hat * c + strafe_hat * s;
    pose.y += trans_hat * s - strafe_hat * c;
    pose.yaw = normalizeAngle(pose.yaw + rot_hat);
  }
}

}  // namespace

bool parseOdometryModelType(const std::string& name, OdometryModelType& type) {
  if (name == "diff") type = OdometryModelType::kDiff;
  else if (name == "omni") type = OdometryModelType::kOmni;
  else if (name == "diff-corrected") type = OdometryModelType::kDiffCorrected;
  else if (name == "omni-corrected") type = OdometryModelType::kOmniCorrected;
  else return false;
  return true;
}

void applyOdometryMotion(const OdometryModelParams& params, const Pose2D& odom_before, const Pose2D& odom_after,
                         std::vector<Particle>& particles, RandomSource& rng) {
  // The change in the odom frame, as amcl takes it (not rotated into the robot frame).
  const double dx = odom_after.x - odom_before.x;
  const double dy = odom_after.y - odom_before.y;
  const double dyaw = normalizeAngle(odom_after.yaw - odom_before.yaw);
  switch (params.type) {
    case OdometryModelType::kDiff:
      return diffMotion(params, false, dx, dy, dyaw, odom_before.yaw, particles, rng);
    case OdometryModelType::kDiffCorrected:
      return diffMotion(params, true, dx, dy, dyaw, odom_before.yaw, particles, rng);
    case OdometryModelType::kOmni:
      return omniMotion(params, false, dx, dy, dyaw, odom_before.yaw, particles, rng);
    case OdometryModelType::kOmniCorrected:
      return omniMotion(params, true, dx, dy, dyaw, odom_before.yaw, particles, rng);
  }
}

}  // namespace loc
}  // namespace marl_mrta
