#include "marl_mrta/loc/amcl_config.h"

#include <limits>
#include <sstream>

namespace marl_mrta {
namespace loc {
namespace {

using nav::ParamError;
using nav::ParamNode;

constexpr double kLargest = std::numeric_limits<double>::max();  // finite: an infinite pose is refused

std::string frameId(const ParamNode& ns, const std::string& key, const std::string& default_value) {
  const std::string frame = withoutLeadingSlash(ns.getString(key, default_value));
  if (frame.empty()) throw ParamError(ns.pathOf(key), "must name a frame");
  return frame;
}

void readLaserModel(const ParamNode& ns, AmclConfig& config) {
  const std::string type = ns.getString("laser_model_type", "likelihood_field");
  if (type == "beam" || type == "likelihood_field_prob") {
    throw ParamError(ns.pathOf("laser_model_type"),
                     "'" + type + "' is not available in the built-in amcl (likelihood_field only)");
  }
  if (type != "likelihood_field") {
    throw ParamError(ns.pathOf("laser_model_type"),
                     "unknown value '" + type + "' (expected likelihood_field, beam or likelihood_field_prob)");
  }
  LaserModelParams& laser = config.laser;
  laser.min_range = ns.getDouble("laser_min_range", -1.0, -1.0);
  laser.max_range = ns.getDouble("laser_max_range", -1.0, -1.0);
  laser.max_beams = ns.getInt("laser_max_beams", 30, 2);
  laser.z_hit = ns.getDouble("laser_z_hit", 0.95, 0.0, 1.0);
  laser.z_rand = ns.getDouble("laser_z_rand", 0.05, 0.0, 1.0);
  laser.sigma_hit = ns.getDouble("laser_sigma_hit", 0.2, 1e-6);
  config.laser_likelihood_max_dist = ns.getDouble("laser_likelihood_max_dist", 2.0, 0.0);
  if (laser.min_range > 0.0 && laser.max_range > 0.0 && laser.min_range >= laser.max_range) {
    std::ostringstream problem;
    problem << "must be less than laser_max_range (" << laser.max_range << "), got " << laser.min_range;
    throw ParamError(ns.pathOf("laser_min_range"), problem.str());
  }
  // The beam model's and beam skipping's parameters: checked, without effect here (as in stock
  // amcl with likelihood_field).
  ns.getDouble("laser_z_short", 0.1, 0.0, 1.0);
  ns.getDouble("laser_z_max", 0.05, 0.0, 1.0);
  ns.getDouble("laser_lambda_short", 0.1, 0.0);
  ns.getBool("do_beamskip", false);
  ns.getDouble("beam_skip_distance", 0.5, 0.0);
  ns.getDouble("beam_skip_threshold", 0.3, 0.0, 1.0);
  ns.getDouble("beam_skip_error_threshold", 0.9, 0.0, 1.0);
  ns.getDouble("beam_skip_error_threshold_", 0.9, 0.0, 1.0);  // amcl also reads this misspelling
}

void readOdometryModel(const ParamNode& ns, AmclConfig& config) {
  const std::string type = ns.getString("odom_model_type", "diff");
  if (!parseOdometryModelType(type, config.odometry.type)) {
    throw ParamError(ns.pathOf("odom_model_type"),
                     "unknown value '" + type + "' (expected diff, omni, diff-corrected or omni-corrected)");
  }
  config.odometry.alpha1 = ns.getDouble("odom_alpha1", 0.2, 0.0);
  config.odometry.alpha2 = ns.getDouble("odom_alpha2", 0.2, 0.0);
  config.odometry.alpha3 = ns.getDouble("odom_alpha3", 0.2, 0.0);
  config.odometry.alpha4 = ns.getDouble("odom_alpha4", 0.2, 0.0);
  config.odometry.alpha5 = ns.getDouble("odom_alpha5", 0.2, 0.0);
}

void readFilter(const ParamNode& ns, AmclConfig& config) {
  FilterParams& filter = config.filter;
  filter.min_particles = ns.getInt("min_particles", 100, 1);
  filter.max_particles = ns.getInt("max_particles", 5000, 1);
  if (filter.min_particles > filter.max_particles) {
    throw ParamError(ns.pathOf("min_particles"), "must not exceed max_particles (" +
                                                     std::to_string(filter.max_particles) + "), got " +
                                                     std::to_string(filter.min_particles));
  }
  filter.kld_err = ns.getDouble("kld_err", 0.01, 1e-6, 1.0);
  filter.kld_z = ns.getDouble("kld_z", 0.99, 0.0);
  filter.alpha_slow = ns.getDouble("recovery_alpha_slow", 0.001, 0.0, 1.0);
  filter.alpha_fast = ns.getDouble("recovery_alpha_fast", 0.1, 0.0, 1.0);
  filter.selective_resampling = ns.getBool("selective_resampling", false);
  config.resample_interval = ns.getInt("resample_interval", 2, 1);
  config.update_min_d = ns.getDouble("update_min_d", 0.2, 0.0);
  config.update_min_a = ns.getDouble("update_min_a", M_PI / 6.0, 0.0);
}

}  // namespace

std::string withoutLeadingSlash(const std::string& frame) {
  return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
}

AmclConfig readAmclConfig(const ParamNode& ns) {
  AmclConfig config;
  readFilter(ns, config);
  readOdometryModel(ns, config);
  readLaserModel(ns, config);

  config.odom_frame_id = frameId(ns, "odom_frame_id", "odom");
  config.base_frame_id = frameId(ns, "base_frame_id", "base_link");
  config.global_frame_id = frameId(ns, "global_frame_id", "map");
  config.transform_tolerance = ns.getDouble("transform_tolerance", 0.1, 0.0);
  config.tf_broadcast = ns.getBool("tf_broadcast", true);
  config.use_map_topic = ns.getBool("use_map_topic", false);
  config.first_map_only = ns.getBool("first_map_only", false);
  config.gui_publish_rate = ns.getDouble("gui_publish_rate", -1.0, -1.0);
  config.save_pose_rate = ns.getDouble("save_pose_rate", 0.5, -1.0);
  config.force_update_after_initialpose = ns.getBool("force_update_after_initialpose", false);
  config.force_update_after_set_map = ns.getBool("force_update_after_set_map", false);

  config.initial_pose.x = ns.getDouble("initial_pose_x", 0.0, -kLargest, kLargest);
  config.initial_pose.y = ns.getDouble("initial_pose_y", 0.0, -kLargest, kLargest);
  config.initial_pose.yaw = ns.getDouble("initial_pose_a", 0.0, -kLargest, kLargest);
  config.initial_covariance.xx = ns.getDouble("initial_cov_xx", 0.25, 0.0);
  config.initial_covariance.yy = ns.getDouble("initial_cov_yy", 0.25, 0.0);
  config.initial_covariance.aa = ns.getDouble("initial_cov_aa", (M_PI / 12.0) * (M_PI / 12.0), 0.0);
  config.seed = ns.getInt("seed", 0, 0);

  // Stock amcl's diagnostics and bag playback: accepted, no effect here.
  ns.getDouble("std_warn_level_x", 0.2, 0.0);
  ns.getDouble("std_warn_level_y", 0.2, 0.0);
  ns.getDouble("std_warn_level_yaw", 0.1, 0.0);
  ns.getDouble("bag_scan_period", -1.0);
  ns.getBool("restore_defaults", false);

  const std::vector<std::string> unknown = ns.unreadKeys();
  if (!unknown.empty()) {
    const std::string more = unknown.size() > 1 ? " (and " + std::to_string(unknown.size() - 1) + " more)" : "";
    throw ParamError(unknown.front(), "unknown parameter" + more);
  }
  return config;
}

}  // namespace loc
}  // namespace marl_mrta
