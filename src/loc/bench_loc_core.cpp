// Speed of the particle filter core on a map (no ROS): the obstacle-distance field, and the CPU
// time of one filter update (motion model, likelihood field, resampling) while tracking and
// right after global localisation, with LDS-01 scans ray-cast by the simulator core along a
// round of the lab.
//   bench_loc_core <map.yaml> <amcl_params.yaml>   -> JSON on stdout
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "marl_mrta/loc/amcl_config.h"
#include "marl_mrta/loc/localizer.h"
#include "marl_mrta/nav/cpu_clock.h"
#include "marl_mrta/nav/ground_truth_localization.h"
#include "marl_mrta/sim/lidar.h"
#include "marl_mrta/sim/scan_caster.h"

using namespace marl_mrta;
using namespace marl_mrta::loc;

namespace {

using Clock = nav::ThreadCpuClock;  // CPU time: the machine may be shared
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

std::string statsJson(std::vector<double> samples) {
  if (samples.empty()) return "{\"n\": 0}";
  std::sort(samples.begin(), samples.end());
  double sum = 0.0;
  for (double v : samples) sum += v;
  const auto at = [&](double p) { return samples[std::min(samples.size() - 1, static_cast<size_t>(p * (samples.size() - 1) + 0.5))]; };
  char buf[200];
  std::snprintf(buf, sizeof buf, "{\"n\": %zu, \"mean_ms\": %.4f, \"median_ms\": %.4f, \"p95_ms\": %.4f, \"max_ms\": %.4f}",
                samples.size(), sum / samples.size(), at(0.5), at(0.95), samples.back());
  return buf;
}

// Poses every 2 cm along straight legs through `waypoints`, heading along each leg.
std::vector<Pose2D> path(const std::vector<Pose2D>& waypoints) {
  std::vector<Pose2D> poses;
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) {
    const double dx = waypoints[i + 1].x - waypoints[i].x, dy = waypoints[i + 1].y - waypoints[i].y;
    const double length = std::hypot(dx, dy), yaw = std::atan2(dy, dx);
    for (double s = 0.0; s < length; s += 0.02) poses.push_back({waypoints[i].x + s * dx / length, waypoints[i].y + s * dy / length, yaw});
  }
  return poses;
}

class ScanSource {
 public:
  explicit ScanSource(const map::OccupancyMap& map) : caster_(map), lidar_(sim::LidarSpec{}) {}
  ScanObservation at(const Pose2D& pose) {
    ScanObservation scan;
    scan.laser_x = lidar_.spec().mount_x;
    scan.angle_increment = lidar_.spec().angleIncrement();
    scan.range_min = lidar_.spec().range_min;
    scan.range_max = lidar_.spec().range_max;
    lidar_.castExact(caster_, {pose.x, pose.y, pose.yaw}, {}, ranges_);
    for (float& r : ranges_) {
      if (!std::isfinite(r)) r = 0.0f;  // no return, as the LDS-01 driver reports it
    }
    scan.ranges = ranges_;
    return scan;
  }

 private:
  sim::ScanCaster caster_;
  sim::Lidar lidar_;
  std::vector<float> ranges_;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: bench_loc_core <map.yaml> <amcl_params.yaml>\n";
    return 2;
  }
  try {
    const map::OccupancyMap occupancy = map::loadMap(argv[1]);
    YAML::Node tree(YAML::NodeType::Map);
    nav::loadYamlFileInto(tree, argv[2], "");
    const AmclConfig config = readAmclConfig(nav::ParamNode(tree, "amcl"));
    ScanSource scans(occupancy);
    // A round of the lab (docs/guide/navigation.md), odometry without drift: the cost does not depend on it.
    const std::vector<Pose2D> round = path({{0.5, 0.5, 0}, {2.8, 0.6, 0}, {2.8, 2.5, 0}, {4.3, 2.5, 0}, {4.3, 4.4, 0},
                                            {6.4, 4.4, 0}, {6.4, 0.6, 0}, {4.3, 0.6, 0}});
    std::vector<double> map_ms;
    for (int i = 0; i < 5; ++i) {
      const auto t0 = Clock::now();
      const LocalizationMap field(occupancy, config.laser_likelihood_max_dist);
      map_ms.push_back(msSince(t0));
    }
    const auto run = [&](bool global, size_t max_updates, std::vector<double>& update_ms, std::vector<double>& particles) {
      AmclConfig start = config;
      start.initial_pose = round.front();
      Localizer localizer(start);
      localizer.setMap(occupancy);
      if (global) localizer.globalLocalization();
      const nav::Transform2D map_to_odom_frame = nav::inverse(nav::asTransform(round.front()));
      for (const Pose2D& pose : round) {
        const ScanObservation scan = scans.at(pose);
        const Pose2D odom = map_to_odom_frame.apply(pose);
        const size_t count = localizer.filter().particles().size();
        const auto t0 = Clock::now();
        const ScanOutcome outcome = localizer.processScan(scan, odom);
        const double ms = msSince(t0);
        if (!outcome.used) continue;
        update_ms.push_back(ms);
        particles.push_back(static_cast<double>(count));
        if (update_ms.size() >= max_updates) break;
      }
    };
    std::vector<double> tracking_ms, tracking_particles, global_ms, global_particles;
    run(false, 1000, tracking_ms, tracking_particles);
    run(true, 5, global_ms, global_particles);
    double mean_tracking_particles = 0.0;
    for (double n : tracking_particles) mean_tracking_particles += n / tracking_particles.size();
    std::printf("{\"map\": \"%s\", \"params\": \"%s\", \"distance_field\": %s,\n", argv[1], argv[2], statsJson(map_ms).c_str());
    std::printf(" \"tracking_update\": %s, \"tracking_mean_particles\": %.0f,\n", statsJson(tracking_ms).c_str(),
                mean_tracking_particles);
    std::printf(" \"global_first_updates\": %s, \"global_particles\": %.0f}\n", statsJson(global_ms).c_str(),
                global_particles.empty() ? 0.0 : global_particles.front());
  } catch (const std::exception& error) {
    std::cerr << "bench_loc_core: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
