// The localisation step of amcl's node without ROS: what happens to the filter when a map, an
// initial pose, a service call or a laser scan arrives, in the order they arrive. Every random
// draw comes from one engine seeded with `seed`, so the same inputs in the same order give the
// same particles, estimates and map -> odom transforms, bit for bit.
//
// Per scan (amcl's laserReceived): the filter is updated when the odometry moved by more than
// update_min_d along x or y of the odom frame, or turned by more than update_min_a, since the
// last update (or when an update was requested): motion model, then laser model; every
// resample_interval-th update resamples. The first scan after an initialisation only weighs.
// After a resampling (or that first scan) the estimate is the mean of the heaviest cluster
// and map -> odom = estimate · (odom -> base)⁻¹ of the scan's instant.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "marl_mrta/loc/amcl_config.h"
#include "marl_mrta/loc/laser_model.h"
#include "marl_mrta/loc/localization_map.h"
#include "marl_mrta/loc/particle_filter.h"
#include "marl_mrta/loc/random_source.h"
#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/local_controller.h"

namespace marl_mrta {
namespace loc {

struct PoseEstimate {
  Pose2D pose;                // map frame: the mean of the heaviest cluster
  PoseCovariance covariance;  // of the whole particle set, as amcl reports it
};

struct ScanOutcome {
  bool used = false;          // the filter took the scan (its particles changed)
  bool resampled = false;
  bool new_estimate = false;  // the estimate was recomputed: amcl_pose is due
  // map -> odom once there is an estimate: due after every scan (amcl republishes the last one
  // when the scan changed nothing, so that it stays fresh).
  std::optional<nav::Transform2D> map_to_odom;
  PoseEstimate estimate;      // the latest (with map_to_odom)
  std::string ignored_because;  // why the scan could not be taken at all (no map, unusable limits)
};

class Localizer {
 public:
  explicit Localizer(const AmclConfig& config);

  const AmclConfig& config() const { return config_; }
  bool hasMap() const { return map_ != nullptr; }
  const LocalizationMap* map() const { return map_.get(); }
  const ParticleFilter& filter() const { return filter_; }

  // A (new) map: the filter starts over around the initial pose, which is the configured one
  // until savePose() stored an estimate; an initial pose that came before the first map is
  // applied then. Throws std::invalid_argument for an unusable map.
  void setMap(const map::OccupancyMap& occupancy);
  // The initialpose topic: the filter starts over around `mean` (kept until a map arrives).
  void setInitialPose(const Pose2D& mean, const PoseCovariance& covariance);
  // The set_map service: a new map and a pose in it.
  void setMapAndPose(const map::OccupancyMap& occupancy, const Pose2D& mean, const PoseCovariance& covariance);
  // The global_localization service: particles spread uniformly over the free cells.
  void globalLocalization();
  // The request_nomotion_update service: the next scan updates the filter even without motion.
  void requestNoMotionUpdate() { force_update_ = true; }

  // A scan and the base's odometry pose (odom frame) at the scan's stamp.
  ScanOutcome processScan(const ScanObservation& scan, const Pose2D& odom_pose);

  // The mean the filter was last started around (map, initial pose, set_map); none after a global
  // localisation, which has no mean until it converges.
  const std::optional<Pose2D>& startMean() const { return start_mean_; }

  // The last estimate, if any (amcl's save_pose_rate): also becomes the pose a new map starts from.
  std::optional<PoseEstimate> savePose();

 private:
  void restart(const Pose2D& mean, const PoseCovariance& covariance);

  AmclConfig config_;
  RandomSource rng_;
  ParticleFilter filter_;
  std::unique_ptr<LocalizationMap> map_;
  std::unique_ptr<LikelihoodFieldModel> laser_;
  Pose2D start_pose_;
  PoseCovariance start_covariance_;
  std::optional<std::pair<Pose2D, PoseCovariance>> pending_initial_pose_;
  std::optional<Pose2D> start_mean_;
  bool odom_known_ = false;  // amcl's pf_init_: an odometry pose since the last initialisation
  Pose2D odom_at_update_;
  bool force_update_ = false;
  int resample_count_ = 0;
  std::optional<PoseEstimate> estimate_;
  std::optional<nav::Transform2D> map_to_odom_;
};

}  // namespace loc
}  // namespace marl_mrta
