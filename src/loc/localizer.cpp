#include "marl_mrta/loc/localizer.h"

#include <cmath>

#include "marl_mrta/loc/odometry_model.h"
#include "marl_mrta/nav/ground_truth_localization.h"

namespace marl_mrta {
namespace loc {

Localizer::Localizer(const AmclConfig& config)
    : config_(config),
      rng_(static_cast<uint64_t>(config.seed)),
      filter_(config.filter),
      start_pose_(config.initial_pose),
      start_covariance_(config.initial_covariance) {}

void Localizer::restart(const Pose2D& mean, const PoseCovariance& covariance) {
  filter_.initGaussian(mean, covariance, rng_);
  start_mean_ = mean;
  odom_known_ = false;
}

void Localizer::setMap(const map::OccupancyMap& occupancy) {
  laser_.reset();
  map_ = std::make_unique<LocalizationMap>(occupancy, config_.laser_likelihood_max_dist);
  laser_ = std::make_unique<LikelihoodFieldModel>(config_.laser, *map_);
  restart(start_pose_, start_covariance_);
  if (pending_initial_pose_) {
    restart(pending_initial_pose_->first, pending_initial_pose_->second);
    pending_initial_pose_.reset();
  }
}

void Localizer::setInitialPose(const Pose2D& mean, const PoseCovariance& covariance) {
  if (map_) {
    restart(mean, covariance);
  } else {
    pending_initial_pose_ = std::make_pair(mean, covariance);
  }
  if (config_.force_update_after_initialpose) force_update_ = true;
}

void Localizer::setMapAndPose(const map::OccupancyMap& occupancy, const Pose2D& mean,
                              const PoseCovariance& covariance) {
  setMap(occupancy);
  restart(mean, covariance);
  if (config_.force_update_after_set_map) force_update_ = true;
}

void Localizer::globalLocalization() {
  if (!map_) return;  // as amcl: nothing to spread over yet
  filter_.initFrom([this](RandomSource& rng) { return map_->randomFreePose(rng); }, rng_);
  start_mean_.reset();
  odom_known_ = false;
}

ScanOutcome Localizer::processScan(const ScanObservation& scan, const Pose2D& odom_pose) {
  ScanOutcome outcome;
  double range_min, range_max;
  if (!map_) {
    outcome.ignored_because = "no map yet";
    return outcome;
  }
  if (!laser_->effectiveRanges(scan, range_min, range_max)) {
    outcome.ignored_because = "the scan's range_max is not positive or its range_min negative";
    return outcome;
  }
  bool update = false, first_since_init = false;
  if (!odom_known_) {
    // The first scan after an initialisation: its odometry is the reference; weigh only.
    odom_known_ = true;
    first_since_init = true;
    update = true;
    resample_count_ = 0;
  } else {
    const double dx = odom_pose.x - odom_at_update_.x, dy = odom_pose.y - odom_at_update_.y;
    const double dyaw = nav::normalizeAngle(odom_pose.yaw - odom_at_update_.yaw);
    update = std::abs(dx) > config_.update_min_d || std::abs(dy) > config_.update_min_d ||
             std::abs(dyaw) > config_.update_min_a || force_update_;
    force_update_ = false;
    if (update) applyOdometryMotion(config_.odometry, odom_at_update_, odom_pose, filter_.mutableParticles(), rng_);
  }
  if (update) {
    laser_->weigh(scan, filter_.mutableParticles());
    filter_.normalizeWeights();
    odom_at_update_ = odom_pose;
    outcome.used = true;
    if (++resample_count_ % config_.resample_interval == 0) {
      filter_.resample([this](RandomSource& rng) { return map_->randomFreePose(rng); }, rng_);
      outcome.resampled = true;
    }
  }
  if (outcome.resampled || first_since_init) {
    const int best = filter_.bestCluster();
    if (best >= 0) {
      estimate_ = PoseEstimate{filter_.clusters()[static_cast<size_t>(best)].mean, filter_.covariance()};
      map_to_odom_ = nav::mapToOdom(nav::asTransform(estimate_->pose), odom_pose);
      outcome.new_estimate = true;
    }
  }
  outcome.map_to_odom = map_to_odom_;
  if (estimate_) outcome.estimate = *estimate_;
  return outcome;
}

std::optional<PoseEstimate> Localizer::savePose() {
  if (estimate_) {
    start_pose_ = estimate_->pose;
    start_covariance_ = estimate_->covariance;
  }
  return estimate_;
}

}  // namespace loc
}  // namespace marl_mrta
