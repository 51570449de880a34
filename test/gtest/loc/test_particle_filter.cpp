// The filter's parts without a map: the pose histogram (kd-tree of bins, clusters), the
// KLD-sampling bound, Gaussian initialisation, resampling and the cluster statistics.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "marl_mrta/loc/particle_filter.h"
#include "marl_mrta/loc/pose_histogram.h"

using namespace marl_mrta::loc;

namespace {

constexpr double kDeg = M_PI / 180.0;

FilterParams tb3Filter() {
  FilterParams params;
  params.min_particles = 500;
  params.max_particles = 3000;
  params.kld_err = 0.02;
  params.kld_z = 0.99;
  params.alpha_slow = params.alpha_fast = 0.0;
  return params;
}

Pose2D noRandomPose(RandomSource&) {
  ADD_FAILURE() << "a random pose was drawn with recovery off";
  return {};
}

}  // namespace

TEST(PoseHistogram, BinsAreHalfMetreByTenDegrees) {
  EXPECT_EQ((PoseHistogram::Key{0, 0, 18}), PoseHistogram::keyOf({0.0, 0.0, 0.0}));
  EXPECT_EQ((PoseHistogram::Key{0, -1, 18}), PoseHistogram::keyOf({0.49, -0.01, 9.9 * kDeg}));
  EXPECT_EQ((PoseHistogram::Key{1, 0, 19}), PoseHistogram::keyOf({0.5, 0.0, 10.1 * kDeg}));
  EXPECT_EQ((PoseHistogram::Key{0, 0, 0}), PoseHistogram::keyOf({0.0, 0.0, -M_PI}));
  EXPECT_EQ((PoseHistogram::Key{0, 0, 35}), PoseHistogram::keyOf({0.0, 0.0, M_PI - 1e-12}));
  EXPECT_EQ((PoseHistogram::Key{0, 0, 0}), PoseHistogram::keyOf({0.0, 0.0, M_PI}));  // the same angle as -pi
}

TEST(PoseHistogram, CountsBinsAndSumsTheirWeights) {
  PoseHistogram histogram;
  histogram.insert({0.1, 0.1, 0.0}, 0.25);
  histogram.insert({0.2, 0.3, 0.05}, 0.25);  // same bin
  histogram.insert({2.1, 0.1, 0.0}, 0.5);
  histogram.insert({0.1, 0.1, 1.0}, 1.0);    // other yaw bin
  EXPECT_EQ(3u, histogram.binCount());
  EXPECT_DOUBLE_EQ(0.5, histogram.weightAt({0.4, 0.4, 0.02}));
  EXPECT_DOUBLE_EQ(0.5, histogram.weightAt({2.4, 0.0, 0.0}));
  EXPECT_DOUBLE_EQ(0.0, histogram.weightAt({1.1, 0.1, 0.0}));
  histogram.clear();
  EXPECT_EQ(0u, histogram.binCount());
  EXPECT_DOUBLE_EQ(0.0, histogram.weightAt({0.1, 0.1, 0.0}));
}

TEST(PoseHistogram, ClustersJoinTouchingBinsAcrossYawPlusMinusPi) {
  PoseHistogram histogram;
  // A chain of touching bins along x, one bin apart diagonally, and a lone bin 2 m away.
  for (double x : {0.1, 0.6, 1.1}) histogram.insert({x, 0.1, 0.0}, 1.0);
  histogram.insert({1.6, 0.6, 10.0 * kDeg}, 1.0);
  histogram.insert({3.6, 0.1, 0.0}, 1.0);
  // Either side of yaw = +-pi: neighbouring bins 0 and 35.
  histogram.insert({5.1, 5.1, M_PI - 0.01}, 1.0);
  histogram.insert({5.1, 5.1, -M_PI + 0.01}, 1.0);
  EXPECT_EQ(3, histogram.cluster());
  const int chain = histogram.clusterOf({0.1, 0.1, 0.0});
  EXPECT_EQ(chain, histogram.clusterOf({1.6, 0.6, 10.0 * kDeg}));
  EXPECT_NE(chain, histogram.clusterOf({3.6, 0.1, 0.0}));
  EXPECT_EQ(histogram.clusterOf({5.1, 5.1, M_PI - 0.01}), histogram.clusterOf({5.1, 5.1, -M_PI + 0.01}));
  EXPECT_EQ(-1, histogram.clusterOf({9.0, 9.0, 0.0}));
}

TEST(PoseHistogram, ManyBinsStayFindable) {
  // A line of bins inserted in order makes the most unbalanced tree.
  PoseHistogram histogram;
  for (int i = 0; i < 500; ++i) histogram.insert({0.5 * i + 0.25, 0.25, 0.0}, 1.0);
  EXPECT_EQ(500u, histogram.binCount());
  EXPECT_EQ(1, histogram.cluster());
  EXPECT_DOUBLE_EQ(1.0, histogram.weightAt({0.5 * 321 + 0.1, 0.3, 0.0}));
}

TEST(KldSampling, BoundFollowsFoxAndStaysWithinMinAndMax) {
  const ParticleFilter filter(tb3Filter());
  // n = ceil((k-1)/(2 err) · (1 - 2/(9(k-1)) + sqrt(2/(9(k-1))) z)³), computed by hand.
  EXPECT_EQ(500, filter.particleLimit(1));   // one bin: no more than the minimum
  EXPECT_EQ(500, filter.particleLimit(2));   // 49 -> min
  EXPECT_EQ(500, filter.particleLimit(10));  // 326 -> min
  EXPECT_EQ(1468, filter.particleLimit(50));
  EXPECT_EQ(2822, filter.particleLimit(100));
  EXPECT_EQ(3000, filter.particleLimit(200));  // 5468 -> max
  EXPECT_EQ(3000, filter.particleLimit(100000));
}

TEST(ParticleFilter, GaussianInitialisationHasTheMeanAndCovariance) {
  FilterParams params = tb3Filter();
  params.max_particles = 20000;
  ParticleFilter filter(params);
  RandomSource rng(3);
  const PoseCovariance cov{0.04, 0.015, 0.01, 0.09};
  filter.initGaussian({1.0, 2.0, 3.0}, cov, rng);
  ASSERT_EQ(20000u, filter.particles().size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0, syaw = 0, syy_yaw = 0;
  for (const Particle& p : filter.particles()) {
    EXPECT_GE(p.pose.yaw, -M_PI);
    EXPECT_LT(p.pose.yaw, M_PI);
    const double dx = p.pose.x - 1.0, dy = p.pose.y - 2.0;
    const double dyaw = std::remainder(p.pose.yaw - 3.0, 2.0 * M_PI);
    sx += dx, sy += dy, sxx += dx * dx, sxy += dx * dy, syy += dy * dy, syaw += dyaw, syy_yaw += dyaw * dyaw;
  }
  const double n = 20000.0;
  EXPECT_NEAR(0.0, sx / n, 0.005);
  EXPECT_NEAR(0.0, sy / n, 0.005);
  EXPECT_NEAR(0.0, syaw / n, 0.01);
  EXPECT_NEAR(cov.xx, sxx / n, 0.04 * 0.05);
  EXPECT_NEAR(cov.xy, sxy / n, 0.02 * 0.1);
  EXPECT_NEAR(cov.yy, syy / n, 0.01 * 0.05);
  EXPECT_NEAR(cov.aa, syy_yaw / n, 0.09 * 0.05);
  // The set's statistics say the same.
  EXPECT_NEAR(cov.xx, filter.covariance().xx, 0.04 * 0.05);
  EXPECT_NEAR(1.0, filter.mean().x, 0.005);
  EXPECT_NEAR(3.0, filter.mean().yaw, 0.01);
  EXPECT_EQ(1u, filter.clusters().size());
}

TEST(ParticleFilter, ResamplingCopiesParticlesInProportionToTheirWeight) {
  ParticleFilter filter(tb3Filter());
  RandomSource rng(1);
  filter.initGaussian({0.0, 0.0, 0.0}, {}, rng);  // every particle at the origin
  // Two places, each half of the set, weights 1:3; KLD: 2 bins -> min_particles (500).
  std::vector<Particle>& particles = filter.mutableParticles();
  for (size_t i = 0; i < particles.size(); ++i) {
    const bool heavy = i >= particles.size() / 2;
    particles[i].pose = heavy ? Pose2D{5.25, 1.25, 0.0} : Pose2D{1.25, 1.25, 0.0};
    particles[i].weight = heavy ? 3.0 : 1.0;
  }
  filter.normalizeWeights();
  filter.resample(noRandomPose, rng);
  ASSERT_EQ(500u, filter.particles().size());
  int at_heavy = 0;
  for (const Particle& p : filter.particles()) {
    at_heavy += p.pose.x == 5.25;
    EXPECT_DOUBLE_EQ(1.0 / 500, p.weight);
  }
  EXPECT_EQ(375, at_heavy);  // low-variance: exactly 3/4, not about
  ASSERT_EQ(2u, filter.clusters().size());
  const PoseCluster& best = filter.clusters()[static_cast<size_t>(filter.bestCluster())];
  EXPECT_NEAR(5.25, best.mean.x, 1e-12);
  EXPECT_NEAR(0.75, best.weight, 1e-12);
  EXPECT_NEAR(0.75 * 5.25 + 0.25 * 1.25, filter.mean().x, 1e-9);
  EXPECT_NEAR(0.75 * 0.25 * 16.0, filter.covariance().xx, 1e-9);  // two points 4 m apart
}

TEST(ParticleFilter, AllZeroWeightsBecomeUniform) {
  ParticleFilter filter(tb3Filter());
  for (Particle& p : filter.mutableParticles()) p.weight = 0.0;
  filter.normalizeWeights();
  for (const Particle& p : filter.particles()) EXPECT_DOUBLE_EQ(1.0 / 3000, p.weight);
  EXPECT_NEAR(3000.0, filter.effectiveSampleSize(), 1e-6);
}

TEST(ParticleFilter, RecoveryMixesInRandomPosesWhenTheLikelihoodDrops) {
  FilterParams params = tb3Filter();
  params.alpha_slow = 0.001;
  params.alpha_fast = 0.1;
  ParticleFilter filter(params);
  RandomSource rng(2);
  filter.initGaussian({1.0, 1.0, 0.0}, {0.01, 0.0, 0.01, 0.01}, rng);
  int random_draws = 0;
  const auto far_away = [&](RandomSource&) {
    ++random_draws;
    return Pose2D{20.0, 20.0, 0.0};
  };
  // A good scan, then much worse ones: the fast average falls below the slow one.
  for (double likelihood : {10.0, 1.0, 1.0, 1.0}) {
    for (Particle& p : filter.mutableParticles()) p.weight *= likelihood;
    filter.normalizeWeights();
    filter.resample(far_away, rng);
  }
  EXPECT_GT(random_draws, 0);
  int injected = 0;
  for (const Particle& p : filter.particles()) injected += p.pose.x == 20.0;
  EXPECT_GT(injected, 0);
}

TEST(ParticleFilter, SelectiveResamplingKeepsAnEvenlyWeightedSet) {
  FilterParams params = tb3Filter();
  params.selective_resampling = true;
  ParticleFilter filter(params);
  RandomSource rng(4);
  filter.initGaussian({1.0, 1.0, 0.0}, {0.04, 0.0, 0.04, 0.04}, rng);
  filter.normalizeWeights();  // even weights: effective sample size N > N / 2
  const std::vector<Particle> before = filter.particles();
  filter.resample(noRandomPose, rng);
  ASSERT_EQ(before.size(), filter.particles().size());
  EXPECT_EQ(0, std::memcmp(before.data(), filter.particles().data(), before.size() * sizeof(Particle)));
}
