// Everything the amcl node reads from its private namespace, with amcl's (noetic) names and
// defaults, checked once at start.
//
// An unknown key is an error naming it ("tb3_0/amcl/laser_z_hitt: unknown parameter"): stock
// amcl ignores it, so a typo silently leaves the default in place. Keys stock amcl knows are
// accepted even where they change nothing here, as in stock with the likelihood-field model
// (the beam model's laser_z_short, laser_z_max, laser_lambda_short; beam skipping, which only
// likelihood_field_prob uses; the diagnostics' std_warn_level_*; bag_scan_period;
// restore_defaults). Values this filter does not implement (laser_model_type beam or
// likelihood_field_prob) are refused with one line.
#pragma once

#include <cmath>
#include <string>

#include "marl_mrta/loc/laser_model.h"
#include "marl_mrta/loc/odometry_model.h"
#include "marl_mrta/loc/particle_filter.h"
#include "marl_mrta/nav/param_tree.h"

namespace marl_mrta {
namespace loc {

struct AmclConfig {
  FilterParams filter;
  int resample_interval = 2;          // filter updates per resampling
  double update_min_d = 0.2;          // [m] travel (along x or y of the odom frame) before an update
  double update_min_a = M_PI / 6.0;   // [rad] rotation before an update
  OdometryModelParams odometry;
  LaserModelParams laser;
  double laser_likelihood_max_dist = 2.0;  // [m] obstacle distances are capped here

  std::string odom_frame_id = "odom";
  std::string base_frame_id = "base_link";
  std::string global_frame_id = "map";
  double transform_tolerance = 0.1;   // [s] map -> odom is stamped this much after the scan
  bool tf_broadcast = true;           // publish map -> odom
  bool use_map_topic = false;         // the `map` topic instead of the static_map service
  bool first_map_only = false;        // with the topic: ignore maps after the first
  double gui_publish_rate = -1.0;     // [Hz] most particle clouds per second; <= 0: every update
  double save_pose_rate = 0.5;        // [Hz] the estimate into ~initial_pose_*, ~initial_cov_*; <= 0: never
  bool force_update_after_initialpose = false;
  bool force_update_after_set_map = false;

  Pose2D initial_pose;                // map frame
  PoseCovariance initial_covariance{0.25, 0.0, 0.25, (M_PI / 12.0) * (M_PI / 12.0)};
  int seed = 0;                       // of every random draw (project extension)
};

// Reads and checks the whole namespace. Throws nav::ParamError (one line naming the key).
AmclConfig readAmclConfig(const nav::ParamNode& ns);

// A frame id as tf2 takes it: without a leading slash (amcl strips it from every frame it reads).
std::string withoutLeadingSlash(const std::string& frame);

}  // namespace loc
}  // namespace marl_mrta
