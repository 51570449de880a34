// amcl's odometry motion models (amcl_odom.cpp): each particle moves by the odometry change
// between two filter updates, with noise drawn from the alphas.
//
// `diff` is sample_motion_model_odometry (Probabilistic Robotics p. 136) as amcl has it: the
// motion split into a first rotation, a translation and a second rotation, rotations near
// forward or backward counted as small. Like amcl's `diff` and `omni`, the alpha expression is used
// as the *standard deviation* (alpha1·rot² + alpha2·trans², ...), where the book has it as the
// variance; `diff-corrected` and `omni-corrected` take its square root, as the book does.
#pragma once

#include <string>
#include <vector>

#include "marl_mrta/loc/particle_filter.h"
#include "marl_mrta/loc/random_source.h"

namespace marl_mrta {
namespace loc {

enum class OdometryModelType { kDiff, kOmni, kDiffCorrected, kOmniCorrected };

// "diff", "omni", "diff-corrected", "omni-corrected"; false for anything else.
bool parseOdometryModelType(const std::string& name, OdometryModelType& type);

struct OdometryModelParams {
  OdometryModelType type = OdometryModelType::kDiff;
  double alpha1 = 0.2;  // rotation noise from rotation
  double alpha2 = 0.2;  // rotation noise from translation
  double alpha3 = 0.2;  // translation noise from translation
  double alpha4 = 0.2;  // translation noise from rotation
  double alpha5 = 0.2;  // strafe noise from translation (omni only)
};

// Moves every particle by the motion the odometry measured from `odom_before` to `odom_after`
// (both the base's pose in the odom frame), with sampled noise.
void applyOdometryMotion(const OdometryModelParams& params, const Pose2D& odom_before, const Pose2D& odom_after,
                         std::vector<Particle>& particles, RandomSource& rng);

}  // namespace loc
}  // namespace marl_mrta
