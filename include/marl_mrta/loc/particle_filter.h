// The sample set of amcl's particle filter (pf.c): Gaussian and model-driven initialisation,
// weight normalisation with the slow/fast averages of the recovery heuristic, KLD-sampling
// resampling between min and max particles, and cluster statistics for the estimate.
//
// Resampling draws the new particles with the low-variance (systematic) sampler of
// Probabilistic Robotics (p. 110). amcl uses independent draws instead, because the number of
// particles KLD-sampling asks for is only known while drawing; here a first pass of independent
// draws into the histogram finds that number (Fox 2003: draw until n exceeds the bound for the k
// bins filled so far) and the second pass draws that many with the low-variance sampler.
#pragma once

#include <functional>
#include <vector>

#include "marl_mrta/loc/pose_histogram.h"
#include "marl_mrta/loc/random_source.h"

namespace marl_mrta {
namespace loc {

struct Particle {
  Pose2D pose;          // map frame [m, m, rad], yaw in [-pi, pi)
  double weight = 0.0;  // normalised: the set sums to 1
};

// The (x, y) block and the yaw variance of a pose covariance, as amcl keeps it [m^2, rad^2].
struct PoseCovariance {
  double xx = 0.0, xy = 0.0, yy = 0.0;
  double aa = 0.0;  // yaw
};

struct PoseCluster {
  int count = 0;        // particles
  double weight = 0.0;  // their summed weight
  Pose2D mean;          // weighted; yaw as the circular mean
  PoseCovariance covariance;
};

struct FilterParams {
  int min_particles = 100;
  int max_particles = 5000;
  double kld_err = 0.01;  // largest KL distance between the sampled and the true distribution
  double kld_z = 0.99;    // used as the upper standard normal quantile itself, as amcl does
  // Recovery (Probabilistic Robotics p. 258): rates of the slow and fast weight averages; when
  // the fast one drops below the slow one, resampling mixes in random poses. 0, 0: off.
  double alpha_slow = 0.001;
  double alpha_fast = 0.1;
  bool selective_resampling = false;  // resample only when the effective sample size < N / 2
};

class ParticleFilter {
 public:
  using PoseSampler = std::function<Pose2D(RandomSource&)>;

  explicit ParticleFilter(const FilterParams& params);
  const FilterParams& params() const { return params_; }

  // max_particles drawn from N(mean, covariance) (pf_init).
  void initGaussian(const Pose2D& mean, const PoseCovariance& covariance, RandomSource& rng);
  // max_particles drawn from `sampler` (pf_init_model; global localisation).
  void initFrom(const PoseSampler& sampler, RandomSource& rng);

  const std::vector<Particle>& particles() const { return particles_; }
  // For the motion and sensor models, which move and weigh every particle.
  std::vector<Particle>& mutableParticles() { return particles_; }

  // After a sensor model multiplied the weights: normalises them and updates the averages of
  // the recovery heuristic (pf_update_sensor). All weights 0: uniform again.
  void normalizeWeights();
  // Draws the next set (pf_update_resample); `random_pose` supplies recovery samples.
  void resample(const PoseSampler& random_pose, RandomSource& rng);

  // The number of particles KLD-sampling asks for when the samples fill `bins` bins, clamped to
  // [min_particles, max_particles] (Fox 2003). One bin needs no more than min_particles.
  int particleLimit(int bins) const;
  // Bins the current set fills.
  size_t binCount() const { return histogram_.binCount(); }

  // Statistics of the set after the last initialisation or resampling.
  const std::vector<PoseCluster>& clusters() const { return clusters_; }
  // The heaviest cluster (amcl's estimate); -1 without clusters.
  int bestCluster() const;
  const Pose2D& mean() const { return mean_; }
  const PoseCovariance& covariance() const { return covariance_; }
  double effectiveSampleSize() const { return effective_sample_size_; }
  // Every particle within 0.5 m of the mean along x and y (pf_update_converged).
  bool converged() const { return converged_; }

 private:
  void rebuildHistogram();
  void computeClusterStats();
  void updateConverged();
  // Number of particles for the next set: independent draws until KLD-sampling is satisfied.
  int kldSampleCount(double random_fraction, const PoseSampler& random_pose, RandomSource& rng);

  FilterParams params_;
  std::vector<Particle> particles_, next_;
  std::vector<double> cumulative_;  // scratch: cumulative weights
  PoseHistogram histogram_, kld_histogram_;
  mutable std::vector<int> limit_cache_;  // particleLimit() by bin count, 0: not computed yet
  std::vector<PoseCluster> clusters_;
  Pose2D mean_;
  PoseCovariance covariance_;
  double w_slow_ = 0.0, w_fast_ = 0.0;
  double effective_sample_size_ = 0.0;
  bool converged_ = false;
};

}  // namespace loc
}  // namespace marl_mrta
