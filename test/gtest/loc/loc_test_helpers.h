// The particle filter's test bench: the lab map, TurtleBot3's amcl parameters, and a Burger
// driven through the lab by the simulator core (its noise, odometry drift and ray-cast LDS-01
// scans), each scan handed to the localizer with the odometry of its tick.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "marl_mrta/loc/amcl_config.h"
#include "marl_mrta/loc/localizer.h"
#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/local_controller.h"
#include "marl_mrta/nav/param_tree.h"
#include "marl_mrta/sim/robot_model.h"
#include "marl_mrta/sim/sim_config.h"
#include "marl_mrta/sim/world.h"

namespace marl_mrta {
namespace loc {
namespace testing {

const std::string kSourceDir = MARL_MRTA_SOURCE_DIR;

inline map::OccupancyMap labMap() { return map::loadMap(kSourceDir + "/maps/lab.yaml"); }

// The amcl namespace as launch/include/robot_nav.launch loads it (config/nav/amcl_params.yaml,
// then the robot's frames and initial pose), under `extra_file` when given.
inline YAML::Node amclTree(const std::string& extra_file = "") {
  YAML::Node tree(YAML::NodeType::Map);
  nav::loadYamlFileInto(tree, kSourceDir + "/config/nav/amcl_params.yaml", "");
  nav::setParam(tree, "odom_frame_id", YAML::Node("tb3_0/odom"));
  nav::setParam(tree, "base_frame_id", YAML::Node("tb3_0/base_footprint"));
  nav::setParam(tree, "global_frame_id", YAML::Node("map"));
  if (!extra_file.empty()) nav::loadYamlFileInto(tree, extra_file, "");
  return tree;
}

inline AmclConfig tb3Config() { return readAmclConfig(nav::ParamNode(amclTree(), "tb3_0/amcl")); }

inline double yawError(double a, double b) { return std::abs(nav::normalizeAngle(a - b)); }
inline double distance(const Pose2D& a, const Pose2D& b) { return std::hypot(a.x - b.x, a.y - b.y); }

// The lab is point-symmetric about its centre (3.5, 2.5): a pose and this one see the same scan.
inline Pose2D labTwin(const Pose2D& pose) { return {7.0 - pose.x, 5.0 - pose.y, nav::normalizeAngle(pose.yaw + M_PI)}; }

// A clockwise round of the lab from the first start pose (0.5, 0.5, 0): along the south wall,
// north through the door of the partition, east along the north wall, down the east side and
// back west, clear of the columns.
// The lab with a cabinet against the middle of its west wall (0.3 m x 0.6 m), which breaks the
// symmetry: its twin place on the east wall is bare.
inline map::OccupancyMap labWithCabinet() {
  map::OccupancyMap map = labMap();
  for (int cy = 0; cy < map.height; ++cy) {
    for (int cx = 0; cx < map.width; ++cx) {
      double wx, wy;
      map.cellToWorld(cx, cy, wx, wy);
      if (wx > 0.0 && wx < 0.8 && wy > 2.0 && wy < 3.0) map.data[static_cast<size_t>(cy) * map.width + cx] = map::OccupancyMap::kOccupied;
    }
  }
  return map;
}

inline std::vector<Pose2D> labRound() {
  return {{2.8, 0.6, 0}, {2.8, 2.5, 0}, {4.3, 2.5, 0}, {4.3, 4.4, 0}, {6.4, 4.4, 0}, {6.4, 0.6, 0}, {4.3, 0.6, 0}};
}

// What the localizer was told and what was true at one scan.
struct ScanStep {
  double time = 0.0;   // [s] sim time
  Pose2D truth;        // map frame
  Pose2D odom;         // odom frame
  ScanOutcome outcome;
  // Where the localisation puts the robot at the scan: map -> odom · odometry (what move_base uses).
  bool localized = false;
  Pose2D estimate;
};

// One Burger in the lab, driven by a waypoint follower that sees the ground truth.
class LabDrive {
 public:
  explicit LabDrive(uint64_t seed = 0, const map::OccupancyMap& map = labMap(), const sim::Pose2D& start = {0.5, 0.5, 0.0},
                    const std::string& noise_profile = "measured_tb3")
      : map_(map), world_(map_, worldConfig(noise_profile, seed, start)) {}

  const map::OccupancyMap& map() const { return map_; }
  Pose2D truth() const { const auto& p = world_.robot(0).pose; return {p.x, p.y, p.yaw}; }

  // Follows `waypoints` (only their positions), handing every scan to `localizer`; returns the
  // steps. Fails the test when a waypoint is not reached in time.
  std::vector<ScanStep> drive(Localizer& localizer, const std::vector<Pose2D>& waypoints,
                              double time_limit = 300.0) {
    std::vector<ScanStep> steps;
    size_t next = 0;
    const double end = world_.time() + time_limit;
    while (next < waypoints.size()) {
      if (world_.time() > end) {
        ADD_FAILURE() << "waypoint " << next << " not reached within " << time_limit << " s";
        break;
      }
      const sim::Pose2D& pose = world_.robot(0).pose;
      const double dx = waypoints[next].x - pose.x, dy = waypoints[next].y - pose.y;
      if (std::hypot(dx, dy) < 0.1) {
        ++next;
        continue;
      }
      const double heading_error = nav::normalizeAngle(std::atan2(dy, dx) - pose.yaw);
      sim::Twist2D command;
      if (std::abs(heading_error) > 0.4) {
        command.angular = heading_error > 0 ? 1.0 : -1.0;  // turn on the spot first
      } else {
        command.linear = 0.22;
        command.angular = std::max(-1.5, std::min(1.5, 2.0 * heading_error));
      }
      world_.setCommand(0, command);
      step(localizer, steps);
    }
    return steps;
  }

  // Stands still (or turns in place at `angular` rad/s) for `seconds`, handing scans over.
  std::vector<ScanStep> hold(Localizer& localizer, double seconds, double angular = 0.0) {
    std::vector<ScanStep> steps;
    const double end = world_.time() + seconds;
    while (world_.time() < end) {
      world_.setCommand(0, {0.0, angular});
      step(localizer, steps);
    }
    return steps;
  }

  // The scan of the latest tick as the localizer takes it (LDS-01 at base_scan, no return = 0).
  ScanObservation scan() const {
    const sim::LidarSpec& lidar = world_.config().robot.lidar;
    ScanObservation scan;
    scan.laser_x = lidar.mount_x;
    scan.laser_y = lidar.mount_y;
    scan.angle_min = lidar.angle_min;
    scan.angle_increment = lidar.angleIncrement();
    scan.range_min = lidar.range_min;
    scan.range_max = lidar.range_max;
    scan.ranges = world_.robot(0).scan;
    return scan;
  }
  Pose2D odom() const { const auto& p = world_.robot(0).odom_pose; return {p.x, p.y, p.yaw}; }

 private:
  static sim::WorldConfig worldConfig(const std::string& noise_profile, uint64_t seed, const sim::Pose2D& start) {
    sim::WorldConfig config;
    config.start_poses = {start};
    config.noise = sim::loadNoiseProfiles(kSourceDir + "/config/noise_profiles.yaml").at(noise_profile);
    config.seed = seed;
    return config;
  }
  void step(Localizer& localizer, std::vector<ScanStep>& steps) {
    if (!world_.step().scan_updated) return;
    ScanStep s;
    s.time = world_.time();
    s.truth = truth();
    s.odom = odom();
    s.outcome = localizer.processScan(scan(), s.odom);
    if (s.outcome.map_to_odom) {
      s.localized = true;
      const nav::Pose2D estimate = s.outcome.map_to_odom->apply(s.odom);
      s.estimate = estimate;
    }
    steps.push_back(s);
  }

  map::OccupancyMap map_;
  sim::World world_;
};

// Largest position and yaw errors of the localisation over `steps` (those with an estimate).
struct Errors {
  double position = 0.0, yaw = 0.0;
  size_t checked = 0;
};
inline Errors worstErrors(const std::vector<ScanStep>& steps, size_t skip = 0) {
  Errors errors;
  for (size_t i = skip; i < steps.size(); ++i) {
    if (!steps[i].localized) continue;
    errors.position = std::max(errors.position, distance(steps[i].estimate, steps[i].truth));
    errors.yaw = std::max(errors.yaw, yawError(steps[i].estimate.yaw, steps[i].truth.yaw));
    ++errors.checked;
  }
  return errors;
}

}  // namespace testing
}  // namespace loc
}  // namespace marl_mrta
