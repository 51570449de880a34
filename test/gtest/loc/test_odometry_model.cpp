// amcl's odometry models, checked statistically (fixed seed, 200000 particles): the sampled
// rotations, translation (and strafe) have the odometry's values as means and the alpha
// expressions as spreads — as standard deviations in `diff` and `omni`, as variances in the
// `-corrected` models.
#include <gtest/gtest.h>

#include <cmath>

#include "marl_mrta/loc/odometry_model.h"
#include "marl_mrta/nav/local_controller.h"

using namespace marl_mrta::loc;
using marl_mrta::nav::normalizeAngle;

namespace {

constexpr size_t kSamples = 200000;

struct Moments {
  double mean = 0.0, variance = 0.0;
};
Moments moments(const std::vector<double>& values) {
  Moments m;
  for (double v : values) m.mean += v;
  m.mean /= values.size();
  for (double v : values) m.variance += (v - m.mean) * (v - m.mean);
  m.variance /= values.size();
  return m;
}

// Checks a sampled component against its expected mean and standard deviation.
void expectDistribution(const std::vector<double>& values, double mean, double sigma, const char* what) {
  const Moments m = moments(values);
  EXPECT_NEAR(mean, m.mean, 5.0 * sigma / std::sqrt(double(kSamples)) + 1e-12) << what;
  EXPECT_NEAR(sigma * sigma, m.variance, 0.02 * sigma * sigma + 1e-15) << what;
}

// Every particle at `start`, moved by the odometry step from `before` to `after`.
std::vector<Particle> moved(const OdometryModelParams& params, const Pose2D& start, const Pose2D& before,
                            const Pose2D& after) {
  std::vector<Particle> particles(kSamples, Particle{start, 1.0 / kSamples});
  RandomSource rng(7);
  applyOdometryMotion(params, before, after, particles, rng);
  return particles;
}

// The odometry step from `before` as first rotation, translation and second rotation.
Pose2D stepFrom(const Pose2D& before, double rot1, double trans, double rot2) {
  return {before.x + trans * std::cos(before.yaw + rot1), before.y + trans * std::sin(before.yaw + rot1),
          normalizeAngle(before.yaw + rot1 + rot2)};
}

// The sampled (rot1, trans, rot2) of each particle that started at `start`.
void decompose(const std::vector<Particle>& particles, const Pose2D& start, std::vector<double>& rot1,
               std::vector<double>& trans, std::vector<double>& rot2) {
  for (const Particle& p : particles) {
    const double dx = p.pose.x - start.x, dy = p.pose.y - start.y;
    rot1.push_back(normalizeAngle(std::atan2(dy, dx) - start.yaw));
    trans.push_back(std::hypot(dx, dy));
    rot2.push_back(normalizeAngle(p.pose.yaw - start.yaw - rot1.back()));
  }
}

OdometryModelParams alphas(OdometryModelType type, double a1, double a2, double a3, double a4, double a5 = 0.0) {
  OdometryModelParams params;
  params.type = type;
  params.alpha1 = a1, params.alpha2 = a2, params.alpha3 = a3, params.alpha4 = a4, params.alpha5 = a5;
  return params;
}

}  // namespace

TEST(OdometryModel, DiffSpreadsAreTheAlphaExpressionsAsStandardDeviations) {
  const OdometryModelParams params = alphas(OdometryModelType::kDiff, 0.1, 0.2, 0.3, 0.4);
  const Pose2D before{1.0, 2.0, 0.5}, start{-3.0, 0.5, 0.3};
  const double rot1 = 0.2, trans = 0.5, rot2 = 0.1;
  const auto particles = moved(params, start, before, stepFrom(before, rot1, trans, rot2));
  std::vector<double> r1, t, r2;
  decompose(particles, start, r1, t, r2);
  // alpha1·rot1² + alpha2·trans², alpha3·trans² + alpha4·(rot1² + rot2²), alpha1·rot2² + alpha2·trans²
  expectDistribution(r1, rot1, 0.1 * rot1 * rot1 + 0.2 * trans * trans, "rot1");
  expectDistribution(t, trans, 0.3 * trans * trans + 0.4 * rot1 * rot1 + 0.4 * rot2 * rot2, "trans");
  expectDistribution(r2, rot2, 0.1 * rot2 * rot2 + 0.2 * trans * trans, "rot2");
}

TEST(OdometryModel, DiffCorrectedSpreadsAreTheAlphaExpressionsAsVariances) {
  // Small enough that no sampled translation turns negative (which the decomposition would misread).
  const OdometryModelParams params = alphas(OdometryModelType::kDiffCorrected, 0.01, 0.02, 0.01, 0.01);
  const Pose2D before{0.0, 0.0, -2.0}, start{2.0, 1.0, 2.5};
  const double rot1 = -0.3, trans = 0.4, rot2 = 0.25;
  const auto particles = moved(params, start, before, stepFrom(before, rot1, trans, rot2));
  std::vector<double> r1, t, r2;
  decompose(particles, start, r1, t, r2);
  expectDistribution(r1, rot1, std::sqrt(0.01 * rot1 * rot1 + 0.02 * trans * trans), "rot1");
  expectDistribution(t, trans, std::sqrt(0.01 * trans * trans + 0.01 * (rot1 * rot1 + rot2 * rot2)), "trans");
  expectDistribution(r2, rot2, std::sqrt(0.01 * rot2 * rot2 + 0.02 * trans * trans), "rot2");
}

TEST(OdometryModel, DiffCountsDrivingBackwardsAsNoTurn) {
  // Reversing 0.3 m: the first rotation is pi, its noise term that of a rotation of 0.
  const OdometryModelParams params = alphas(OdometryModelType::kDiff, 0.5, 0.2, 0.3, 0.4);
  const Pose2D before{0.0, 0.0, 0.0}, after{-0.3, 0.0, 0.0}, start{0.0, 0.0, 1.0};
  const auto particles = moved(params, start, before, after);
  std::vector<double> heading, back;
  for (const Particle& p : particles) {
    back.push_back(std::hypot(p.pose.x, p.pose.y));
    heading.push_back(normalizeAngle(std::atan2(-p.pose.y, -p.pose.x) - start.yaw));  // direction of travel, reversed
  }
  expectDistribution(heading, 0.0, 0.2 * 0.09, "rot1 (reversed)");
  expectDistribution(back, 0.3, 0.3 * 0.09, "trans");
}

TEST(OdometryModel, DiffTurningInPlaceMovesOnlyTheHeadingMean) {
  const OdometryModelParams params = alphas(OdometryModelType::kDiff, 0.1, 0.1, 0.1, 0.1);
  const Pose2D before{1.0, 1.0, 3.0}, after{1.0, 1.0, -2.8}, start{4.0, 4.0, 0.0};  // +0.483 rad across +-pi
  const double turn = normalizeAngle(after.yaw - before.yaw);
  const auto particles = moved(params, start, before, after);
  std::vector<double> yaw, x;
  for (const Particle& p : particles) {
    yaw.push_back(normalizeAngle(p.pose.yaw - start.yaw));
    x.push_back(p.pose.x);
  }
  // rot1 = 0 (no bearing in place): the heading's spread is rot2's, alpha1·turn².
  expectDistribution(yaw, turn, 0.1 * turn * turn, "heading");
  EXPECT_NEAR(4.0, moments(x).mean, 1e-3);
}

TEST(OdometryModel, OmniSpreadsAlongAcrossAndInHeading) {
  const OdometryModelParams params = alphas(OdometryModelType::kOmni, 0.1, 0.2, 0.3, 0.4, 0.5);
  // Sideways step to the left of the odometry's heading, and a turn.
  const Pose2D before{0.0, 0.0, 0.0}, after{0.0, 0.4, 0.2}, start{1.0, 1.0, 1.0};
  const double trans = 0.4, rot = 0.2;
  const auto particles = moved(params, start, before, after);
  const double bearing = M_PI / 2 + start.yaw;  // travel direction of each particle
  std::vector<double> along, across, heading;
  for (const Particle& p : particles) {
    const double dx = p.pose.x - start.x, dy = p.pose.y - start.y;
    along.push_back(dx * std::cos(bearing) + dy * std::sin(bearing));
    across.push_back(dx * std::sin(bearing) - dy * std::cos(bearing));
    heading.push_back(p.pose.yaw - start.yaw);
  }
  expectDistribution(along, trans, 0.3 * trans * trans + 0.1 * rot * rot, "translation");
  expectDistribution(across, 0.0, 0.1 * rot * rot + 0.5 * trans * trans, "strafe");
  expectDistribution(heading, rot, 0.4 * rot * rot + 0.2 * trans * trans, "rotation");
}

TEST(OdometryModel, OmniCorrectedSpreadsAreTheAlphaExpressionsAsVariances) {
  const OdometryModelParams params = alphas(OdometryModelType::kOmniCorrected, 0.01, 0.02, 0.03, 0.04, 0.05);
  const Pose2D before{0.0, 0.0, 0.0}, after{0.5, 0.0, -0.3}, start{0.0, 0.0, 0.0};
  const double trans = 0.5, rot = -0.3;
  const auto particles = moved(params, start, before, after);
  std::vector<double> along, across, heading;
  for (const Particle& p : particles) {
    along.push_back(p.pose.x);
    across.push_back(-p.pose.y);
    heading.push_back(p.pose.yaw);
  }
  expectDistribution(along, trans, std::sqrt(0.03 * trans * trans + 0.04 * rot * rot), "translation");
  expectDistribution(across, 0.0, std::sqrt(0.04 * rot * rot + 0.05 * trans * trans), "strafe");
  expectDistribution(heading, rot, std::sqrt(0.01 * rot * rot + 0.02 * trans * trans), "rotation");
}
