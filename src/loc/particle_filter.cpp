#include "marl_mrta/loc/particle_filter.h"

#include <algorithm>
#include <cmath>

#include "marl_mrta/nav/local_controller.h"

namespace marl_mrta {
namespace loc {

ParticleFilter::ParticleFilter(const FilterParams& params)
    : params_(params), limit_cache_(static_cast<size_t>(params.max_particles) + 1, 0) {
  particles_.assign(static_cast<size_t>(params_.max_particles), Particle{{}, 1.0 / params_.max_particles});
  rebuildHistogram();
  computeClusterStats();
}

void ParticleFilter::initGaussian(const Pose2D& mean, const PoseCovariance& covariance, RandomSource& rng) {
  // Principal axes of the (x, y) block; yaw is independent of them, as in amcl's covariances.
  const double half_trace = 0.5 * (covariance.xx + covariance.yy);
  const double half_gap = 0.5 * (covariance.xx - covariance.yy);
  const double spread = std::hypot(half_gap, covariance.xy);
  const double sigma_major = std::sqrt(std::max(0.0, half_trace + spread));
  const double sigma_minor = std::sqrt(std::max(0.0, half_trace - spread));
  const double axis = 0.5 * std::atan2(2.0 * covariance.xy, covariance.xx - covariance.yy);
  const double c = std::cos(axis), s = std::sin(axis);
  const double sigma_yaw = std::sqrt(std::max(0.0, covariance.aa));
  particles_.resize(static_cast<size_t>(params_.max_particles));
  for (Particle& particle : particles_) {
    const double major = rng.gaussian(sigma_major);
    const double minor = rng.gaussian(sigma_minor);
    const double yaw = rng.gaussian(sigma_yaw);
    particle.pose = {mean.x + c * major - s * minor, mean.y + s * major + c * minor, nav::normalizeAngle(mean.yaw + yaw)};
    particle.weight = 1.0 / params_.max_particles;
  }
  w_slow_ = w_fast_ = 0.0;
  rebuildHistogram();
  computeClusterStats();
  converged_ = false;
}

void ParticleFilter::initFrom(const PoseSampler& sampler, RandomSource& rng) {
  particles_.resize(static_cast<size_t>(params_.max_particles));
  for (Particle& particle : particles_) {
    particle.pose = sampler(rng);
    particle.weight = 1.0 / params_.max_particles;
  }
  w_slow_ = w_fast_ = 0.0;
  rebuildHistogram();
  computeClusterStats();
  converged_ = false;
}

void ParticleFilter::normalizeWeights() {
  double total = 0.0;
  for (const Particle& particle : particles_) total += particle.weight;
  const double count = static_cast<double>(particles_.size());
  double sum_of_squares = 0.0;
  if (total > 0.0) {
    for (Particle& particle : particles_) {
      particle.weight /= total;
      sum_of_squares += particle.weight * particle.weight;
    }
    // Running averages of the mean likelihood (the first one starts them).
    const double w_avg = total / count;
    w_slow_ = w_slow_ == 0.0 ? w_avg : w_slow_ + params_.alpha_slow * (w_avg - w_slow_);
    w_fast_ = w_fast_ == 0.0 ? w_avg : w_fast_ + params_.alpha_fast * (w_avg - w_fast_);
  } else {
    for (Particle& particle : particles_) particle.weight = 1.0 / count;
    sum_of_squares = 1.0 / count;
  }
  effective_sample_size_ = 1.0 / sum_of_squares;
}

int ParticleFilter::particleLimit(int bins) const {
  if (bins <= 1) return params_.min_particles;  // Fox's bound is 0 for one bin
  if (bins > params_.max_particles) return params_.max_particles;
  int& cached = limit_cache_[static_cast<size_t>(bins)];
  if (cached > 0) return cached;
  const double k = bins - 1.0;
  const double b = 2.0 / (9.0 * k);
  const double x = 1.0 - b + std::sqrt(b) * params_.kld_z;
  const double n = std::ceil(k / (2.0 * params_.kld_err) * x * x * x);
  cached = static_cast<int>(std::min<double>(params_.max_particles, std::max<double>(params_.min_particles, n)));
  return cached;
}

int ParticleFilter::kldSampleCount(double random_fraction, const PoseSampler& random_pose, RandomSource& rng) {
  kld_histogram_.clear();
  const double total = cumulative_.back();
  int count = 0;
  while (count < params_.max_particles) {
    Pose2D pose;
    if (random_fraction > 0.0 && rng.uniform() < random_fraction) {
      pose = random_pose(rng);
    } else {
      const auto it = std::upper_bound(cumulative_.begin(), cumulative_.end(), rng.uniform() * total);
      pose = particles_[std::min<size_t>(it - cumulative_.begin(), particles_.size() - 1)].pose;
    }
    kld_histogram_.insert(pose, 1.0);
    ++count;
    if (count >= particleLimit(static_cast<int>(kld_histogram_.binCount()))) break;
  }
  return count;
}

void ParticleFilter::resample(const PoseSampler& random_pose, RandomSource& rng) {
  if (params_.selective_resampling && effective_sample_size_ > 0.5 * particles_.size()) {
    rebuildHistogram();  // the set stays, weights and all
    computeClusterStats();
    return;
  }
  // Probability of a random pose per new particle (recovery; 0 when the heuristic is off).
  const double random_fraction = w_slow_ > 0.0 ? std::max(0.0, 1.0 - w_fast_ / w_slow_) : 0.0;
  cumulative_.resize(particles_.size());
  double running = 0.0;
  for (size_t i = 0; i < particles_.size(); ++i) cumulative_[i] = running += particles_[i].weight;

  const int count = kldSampleCount(random_fraction, random_pose, rng);
  // Low-variance sampler: one random offset, then `count` evenly spaced picks on the weights.
  next_.resize(static_cast<size_t>(count));
  const double spacing = running / count;
  const double offset = rng.uniform() * spacing;
  size_t source = 0;
  for (int m = 0; m < count; ++m) {
    Particle& particle = next_[static_cast<size_t>(m)];
    if (random_fraction > 0.0 && rng.uniform() < random_fraction) {
      particle.pose = random_pose(rng);
    } else {
      const double target = offset + m * spacing;
      while (cumulative_[source] < target && source + 1 < particles_.size()) ++source;
      particle.pose = particles_[source].pose;
    }
    particle.weight = 1.0 / count;
  }
  particles_.swap(next_);
  // Reset the averages after injecting random poses, so that recovery does not run away.
  if (random_fraction > 0.0) w_slow_ = w_fast_ = 0.0;
  rebuildHistogram();
  computeClusterStats();
  updateConverged();
}

void ParticleFilter::rebuildHistogram() {
  histogram_.clear();
  for (const Particle& particle : particles_) histogram_.insert(particle.pose, particle.weight);
}

void ParticleFilter::computeClusterStats() {
  // Sums per cluster and for the whole set: weight, w·x, w·y, w·cos, w·sin, w·x², w·x·y, w·y².
  struct Sums {
    int count = 0;
    double w = 0, x = 0, y = 0, cos = 0, sin = 0, xx = 0, xy = 0, yy = 0;
    void add(const Particle& p) {
      const double weight = p.weight;
      ++count;
      w += weight;
      x += weight * p.pose.x;
      y += weight * p.pose.y;
      cos += weight * std::cos(p.pose.yaw);
      sin += weight * std::sin(p.pose.yaw);
      xx += weight * p.pose.x * p.pose.x;
      xy += weight * p.pose.x * p.pose.y;
      yy += weight * p.pose.y * p.pose.y;
    }
    void finish(Pose2D& mean, PoseCovariance& cov) const {
      if (w <= 0.0) return;
      mean = {x / w, y / w, std::atan2(sin, cos)};
      cov.xx = xx / w - mean.x * mean.x;
      cov.xy = xy / w - mean.x * mean.y;
      cov.yy = yy / w - mean.y * mean.y;
      // Circular variance of the yaw (amcl's formula), from the mean resultant length.
      cov.aa = -2.0 * std::log(std::hypot(cos, sin) / w);
    }
  };
  const int cluster_count = histogram_.cluster();
  std::vector<Sums> per_cluster(static_cast<size_t>(cluster_count));
  Sums all;
  for (const Particle& particle : particles_) {
    const int label = histogram_.clusterOf(particle.pose);
    if (label >= 0) per_cluster[static_cast<size_t>(label)].add(particle);
    all.add(particle);
  }
  clusters_.assign(static_cast<size_t>(cluster_count), PoseCluster{});
  for (int c = 0; c < cluster_count; ++c) {
    const Sums& sums = per_cluster[static_cast<size_t>(c)];
    PoseCluster& cluster = clusters_[static_cast<size_t>(c)];
    cluster.count = sums.count;
    cluster.weight = sums.w;
    sums.finish(cluster.mean, cluster.covariance);
  }
  all.finish(mean_, covariance_);
}

void ParticleFilter::updateConverged() {
  double mean_x = 0.0, mean_y = 0.0;
  for (const Particle& particle : particles_) {
    mean_x += particle.pose.x;
    mean_y += particle.pose.y;
  }
  mean_x /= particles_.size();
  mean_y /= particles_.size();
  constexpr double kConvergedDistance = 0.5;  // [m] amcl's dist_threshold
  converged_ = std::all_of(particles_.begin(), particles_.end(), [&](const Particle& particle) {
    return std::abs(particle.pose.x - mean_x) <= kConvergedDistance &&
           std::abs(particle.pose.y - mean_y) <= kConvergedDistance;
  });
}

int ParticleFilter::bestCluster() const {
  int best = -1;
  double best_weight = 0.0;
  for (size_t c = 0; c < clusters_.size(); ++c) {
    if (clusters_[c].weight > best_weight) {
      best_weight = clusters_[c].weight;
      best = static_cast<int>(c);
    }
  }
  return best;
}

}  // namespace loc
}  // namespace marl_mrta
